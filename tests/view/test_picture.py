"""Pictures for papers: the headless renderer draws things where they are, the exported strip has
a panel per key moment, the animation a frame per step, and bad requests get clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from microg.cli import main
from microg.view import (default_camera, find_run, find_session, key_moments, open_readonly, read_track,
                               task_layout)
from microg.view.picture import Renderer

from .conftest import colour_mask, pixels_near, project

SIZE = (480, 360)


@pytest.fixture(scope="module")
def task(logged_study):
    with open_readonly(logged_study) as store:
        track = read_track(store, find_run(store, find_session(store, "P01"), 0))
        layout = task_layout(store.protocol, track.run.object)
    return track, layout, default_camera(layout, aspect=SIZE[0] / SIZE[1])


def test_the_renderer_draws_object_places_and_highlighted_hand_where_the_log_has_them(task):
    track, layout, camera = task
    moments = {m.label: m.index for m in key_moments(track, 3)}
    ring = 0.04 / np.linalg.norm(camera.eye - camera.target) / np.tan(np.radians(camera.fov_deg) / 2) * SIZE[1] / 2
    with Renderer(layout, camera, SIZE) as renderer:
        scene = track.scene(moments["place 2"], 3)
        image = renderer.draw(scene)
        start = renderer.draw(track.scene(moments["start"], 3))
    obj = project(scene.object_position, camera, *SIZE)[0]
    places = project(layout.places, camera, *SIZE)
    hand = project(scene.rendered.centre[scene.touching], camera, *SIZE)
    assert len(hand) == 2  # thumb and index press on the cube
    assert pixels_near(colour_mask(image, "object"), obj, 25) > 400
    assert pixels_near(colour_mask(image, "done"), places[0], ring * 1.3) > 100
    assert pixels_near(colour_mask(image, "lit"), places[1], ring * 1.3) > 50
    assert colour_mask(image, "lit").sum() == pixels_near(colour_mask(image, "lit"), places[1], ring * 1.3)
    assert colour_mask(image, "done").sum() == pixels_near(colour_mask(image, "done"), places[0], ring * 1.3)
    for phalanx in hand:
        assert pixels_near(colour_mask(image, "highlight"), phalanx, 15) > 30
    assert not colour_mask(image, "rendered").any()  # both phalanges touch: all highlighted
    # at the start nothing touches, nothing is lit or done, and the hand is drawn in its own colour
    for name in ("highlight", "lit", "done"):
        assert not colour_mask(start, name).any()
    first = track.scene(moments["start"], 3)
    for phalanx in project(first.rendered.centre[first.rendered.drawn], camera, *SIZE):
        assert pixels_near(colour_mask(start, "rendered"), phalanx, 15) > 30


def panel_count(path) -> int:
    """Panels of a strip: each has a grey frame, two dark vertical lines across the picture."""
    grey = np.asarray(Image.open(path).convert("L"))
    lines = np.flatnonzero((grey < 120).mean(axis=0) > 0.3)
    runs = 1 + np.count_nonzero(np.diff(lines) > 1) if len(lines) else 0
    return runs // 2


def test_the_exported_strip_has_a_panel_per_key_moment_in_the_paper_colours(logged_study, tmp_path):
    run = CliRunner().invoke
    strip = tmp_path / "strip.png"
    result = run(main, ["view", str(logged_study), "--session", "P01", "--task", "1",
                        "--out", str(strip)])
    assert result.exit_code == 0 and result.output.strip() == f"wrote {strip}", result.output
    assert panel_count(strip) == 6  # start, picked up, place 1-3, released
    picture = np.asarray(Image.open(strip).convert("RGB"))
    for name in ("object", "lit", "done", "highlight", "rendered"):
        assert colour_mask(picture, name).sum() > 100, name

    chosen = tmp_path / "two.pdf"
    result = run(main, ["view", str(logged_study), "--session", "1", "--task", "0",
                        "--at", "0.5", "--at", "2", "--out", str(chosen), "--no-title"])
    assert result.exit_code == 0 and chosen.read_bytes().startswith(b"%PDF")
    small = tmp_path / "two.png"
    run(main, ["view", str(logged_study), "--session", "P01", "--task", "0", "--at", "0.5",
               "--at", "2", "--out", str(small), "--size", "200x150"])
    assert panel_count(small) == 2


def test_an_animation_has_a_frame_per_step_of_the_task(task, logged_study, tmp_path):
    track, _, _ = task
    out = tmp_path / "task.gif"
    result = CliRunner().invoke(main, ["view", str(logged_study), "--session", "P01", "--task",
                                       "0", "--out", str(out), "--fps", "5", "--speed", "2", "--size", "160x120",
                                       "--quiet"])
    assert result.exit_code == 0, result.output
    with Image.open(out) as gif:
        assert gif.n_frames == int(track.duration // (2 / 5)) + 1
        assert gif.size[0] == 160 and gif.size[1] > 120  # the heads-up display goes under the scene
        assert gif.info["duration"] == 200


@pytest.mark.parametrize("arguments, message", [
    (["--session", "P09", "--task", "0"], "no participant or session 'P09'"),
    (["--session", "P01", "--task", "7"], "has no logged task 7; its runs: task 0: stage1 cube"),
    (["--session", "P01", "--task", "0", "--at", "99"], "--at 99: task 0 of P01 lasts 4.39 s"),
    (["--session", "P01", "--task", "0", "--run", "3"], "has no logged task 0 run 3"),
    (["--session", "P01", "--task", "0", "--out", "{tmp}/x.gif", "--at", "1"], "--at chooses the panels of a strip"),
    (["--session", "P01", "--task", "0", "--out", "{tmp}/x.gif", "--fps", "0"], "fps = 0.0, speed = 1.0: both must be"),
    (["--session", "P01", "--task", "0", "--size", "big"], "'big': give WIDTHxHEIGHT"),
])
def test_export_says_what_is_wrong(logged_study, tmp_path, arguments, message):
    result = CliRunner().invoke(main, ["view", str(logged_study), "--out",
                                       str(tmp_path / "out.png"), *(a.format(tmp=tmp_path) for a in arguments)])
    assert result.exit_code != 0 and message in result.output
    assert not list(tmp_path.iterdir())


def test_export_refuses_a_missing_study_another_format_and_overwriting(logged_study, tmp_path):
    run = CliRunner().invoke
    result = run(main, ["view", str(tmp_path / "none"), "--session", "P01", "--task", "0",
                        "--out", str(tmp_path / "a.png")])
    assert result.exit_code == 1 and f"no study in {tmp_path / 'none'}" in result.output
    result = run(main, ["view", str(logged_study), "--session", "P01", "--task", "0",
                        "--out", str(tmp_path / "a.jpg")])
    assert result.exit_code == 1 and "--out" in result.output and ".png, .pdf, .svg" in result.output
    taken = tmp_path / "taken.png"
    taken.write_bytes(b"a figure")
    result = run(main, ["view", str(logged_study), "--session", "P01", "--task", "0",
                        "--out", str(taken)])
    assert result.exit_code == 1 and "exists" in result.output and taken.read_bytes() == b"a figure"


def test_the_renderer_draws_a_mesh_object_by_its_surface():
    # The shipped mallet seen from the front (+z), its handle along x: the object's colour covers
    # the handle and the head, not the corners of its bounding box beside the handle.
    from microg.paths import object_file
    from microg.sim import load_object
    from microg.view.scene import Camera, object_layout, world_scene

    spec = load_object(object_file("mallet"))
    start = np.array([0.0, 0.2, 0.0])
    layout = object_layout(spec, start)
    camera = Camera(eye=start + [0.0, 0.0, 0.4], target=start, fov_deg=40.0)
    nothing = np.full((2, 5, 5, 3), np.nan)
    scene = world_scene(0.0, object_position=start, object_orientation=(1.0, 0.0, 0.0, 0.0), joints=nothing,
                        widths=np.full((2, 5, 4), np.nan), rendered=np.full((40, 3), np.nan),
                        touching=np.zeros(40, dtype=bool), held=False)
    with Renderer(layout, camera, SIZE) as renderer:
        image = renderer.draw(scene)
    mask = colour_mask(image, "object")
    handle, head = start + [-0.05, 0.0, 0.0], start + [0.045, 0.025, 0.0]  # body frame: handle at -x, head at +x
    beside_handle = start + [-0.05, 0.025, 0.0]  # inside the bounding box, outside the mallet
    for point, drawn in ((handle, True), (head, True), (beside_handle, False)):
        assert (pixels_near(mask, project(point, camera, *SIZE)[0], 3) > 10) == drawn, point


def test_a_strip_of_a_send_draws_its_target_zone_no_places_and_the_sends_moments(tmp_path):
    """A simulated skills study's send that arrived: its key moments are the send's, and the
    picture of its end has the target zone drawn round the target and no place ring."""
    from tests.study.conftest import PROTOCOLS

    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path), "--participants", "2", "--seed", "1", "--jobs",
                                       "1", "--protocol", str(PROTOCOLS / "skills-quick.toml"), "--quiet"])
    assert result.exit_code == 0, result.output
    with open_readonly(tmp_path / "study") as store:
        sends = [(session, task.index) for session in (find_session(store, p) for p in ("P01", "P02"))
                 for task in store.tasks(session.id) if task.phase == "sending"]
        runs = [(session, find_run(store, session, index)) for session, index in sends]
        arrived = [(session, run) for session, run in runs if run.status == "completed"]
        assert arrived, f"no send arrived: {[(s.participant_id, r.label, r.status) for s, r in runs]}"
        track = read_track(store, arrived[0][1])
        layout = task_layout(store.protocol, track.run.object, track.run.phase)
    assert layout.kind == "send" and not len(layout.places)
    moments = key_moments(track, 0, layout.kind)
    assert [m.label for m in moments] == ["start", "picked up", "let go", "arrived"]
    camera = default_camera(layout, aspect=SIZE[0] / SIZE[1])
    with Renderer(layout, camera, SIZE) as renderer:
        image = renderer.draw(track.scene(moments[-1].index, 0))
    centre = project(layout.target[None], camera, *SIZE)[0]
    ring = project((layout.target + [layout.target_radius, 0, 0])[None], camera, *SIZE)[0]
    reach = np.linalg.norm(ring - centre) * 1.3
    zone = colour_mask(image, "target")
    assert pixels_near(zone, centre, reach) > 200 and zone.sum() == pixels_near(zone, centre, reach)
    for name in ("lit", "done"):  # no place ring lit or done (the grey rings of pending places have no hue)
        assert not colour_mask(image, name).any(), name
