"""Reading a session for the view: the key moments, the god-object hand on the surface, and a
reader in another thread following a session while it is written."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from microg.study.store import StoreError
from microg.view.track import find_run, find_session, key_moments, open_readonly, read_track, session_runs

from tests.study.scripted import gated_session
from tests.waiting import joined, wait_until

from .conftest import new_study

CUBE_HALF = 0.03
PHALANX_RADIUS = 0.008
SQUEEZE = 0.006
"""How far the scripted pinch closes into the object (``pinch_keyframes``)."""


def signed_distance_to_cube(points, centre, wxyz):
    """Distance (m) from the cube's surface, negative inside."""
    body = Rotation.from_quat(np.roll(wxyz, -1)).inv().apply(np.atleast_2d(points) - centre)
    q = np.abs(body) - CUBE_HALF
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def test_key_moments_are_the_pick_up_each_place_and_the_release(logged_study):
    with open_readonly(logged_study) as store:
        session = find_session(store, "P01")
        track = read_track(store, find_run(store, session, 0))
        places, radius = np.asarray(store.protocol.task.places), store.protocol.task.place_radius
    moments = key_moments(track, 3)
    assert [m.label for m in moments] == ["start", "picked up", "place 1", "place 2", "place 3", "released"]
    assert [m.index for m in moments] == sorted(m.index for m in moments)
    held = list(np.flatnonzero(track.frames["held"]))
    assert moments[1].index == held[0] > 0
    for k, moment in enumerate(moments[2:5]):
        scene = track.scene(moment.index, 3)
        assert scene.place == k and scene.place_lit and scene.places[k] == "lit"
        assert np.linalg.norm(scene.object_position - places[k]) <= radius
        assert scene.place_timer > 0.9 * store.protocol.task.hold_s  # the moment just before the place is done
        after = track.scene(moment.index + 1, 3)
        assert after.places[k] == "done"
    end = track.scene(moments[-1].index, 3)
    assert moments[-1].index == len(track.frames) - 1 and end.stage == "completed" and end.places == ("done",) * 3
    assert end.t == pytest.approx(track.run.time_s, abs=0.3)  # the task ends when the hold has gone


def test_the_rendered_hand_stays_on_the_surface_while_the_tracked_hand_sinks_in(logged_study):
    """Phalanges in contact are drawn exactly on the surface (the god-object proxy); the tracked
    ones are where the pinch put them, on average its squeeze deep (frame by frame they also lag
    the tracking filter, so a single frame may show one just outside)."""
    with open_readonly(logged_study) as store:
        track = read_track(store, find_run(store, find_session(store, "P01"), 0))
    depths = []
    for index in range(0, len(track.frames), 5):
        scene = track.scene(index, 3)
        if not (scene.held and scene.touching.any()):
            continue
        on_surface = signed_distance_to_cube(scene.rendered.centre[scene.touching], scene.object_position,
                                             scene.object_orientation)
        tracked = signed_distance_to_cube(scene.tracked.centre[scene.touching], scene.object_position,
                                          scene.object_orientation)
        assert np.allclose(on_surface, PHALANX_RADIUS, atol=1e-6)
        depths += list(PHALANX_RADIUS - tracked)
    assert len(depths) > 100
    assert np.mean(depths) == pytest.approx(SQUEEZE, abs=0.002)


def test_a_reader_follows_a_session_while_another_thread_writes_it(tmp_path):
    folder = new_study(tmp_path / "study")
    gate, waiting = threading.Semaphore(0), threading.Semaphore(0)
    writer = gated_session(folder, gate, waiting)  # commits a frame batch, says so, waits for the gate
    seen = []  # (frames read, run status) each time the session waits after a batch
    with open_readonly(folder) as store:
        batch = store.protocol.frame_batch
        track = None
        while track is None or track.run.status == "running":
            wait_until(lambda: waiting.acquire(blocking=False), "the session to wait after a batch",
                       seen=lambda: seen[-1:], going=writer.is_alive)
            if track is None:
                track = read_track(store, session_runs(store, find_session(store, "P01").id)[0])
            else:
                track.refresh(store)
            seen.append((len(track.frames), track.run.status))
            gate.release()  # the session may commit its next batch (or end the task)
        gate.release(1_000_000)  # let the session run on to its end
        joined(writer, "the session")
        logged = store.db.execute("SELECT frames FROM task_runs WHERE id = ?", (track.run.id,)).fetchone()[0]
    growing = [frames for frames, status in seen if status == "running"]
    assert len(growing) >= 3 and growing == [batch * (i + 1) for i in range(len(growing))]  # batch by batch
    assert seen[-1] == (logged, "completed") and growing[-1] < logged
    assert (np.diff(track.frames["t"]) > 0).all()


def test_the_view_opens_a_study_read_only_and_names_what_is_missing(logged_study, tmp_path):
    with open_readonly(logged_study) as store:
        with pytest.raises(StoreError, match="the study database cannot be written .*readonly"):
            store.db.execute("INSERT INTO events (session_id, t, wall, kind, data) VALUES (1, 0, '', 'x', '{}')")
        assert find_session(store, None).participant_id == "P01"
        assert find_session(store, "1").participant_id == "P01"
        with pytest.raises(StoreError, match=r"--session P07: no participant or session 'P07' .* sessions: 1 \(P01, "
                                             r"completed\)"):
            find_session(store, "P07")
        with pytest.raises(StoreError, match="has no logged task 5; its runs: task 0: stage1 cube"):
            find_run(store, find_session(store, "P01"), 5)
    with pytest.raises(StoreError, match="no study in .*nothing here"):
        open_readonly(tmp_path / "nothing here")
    waiting = new_study(tmp_path / "fresh")
    with open_readonly(waiting) as store:
        assert find_session(store, "P01") is None and find_session(store, None) is None
