"""What a logged frame is drawn as: the hands, the contact highlight, the places, the camera."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from microg.paths import protocol_file
from microg.skeleton import Hand, slot
from microg.study.protocol import load_protocol
from microg.study import framelog
from microg.study.framelog import touching_slots
from microg.view.scene import (FrameScene, both_sides, default_camera, hand_values, hud_lines, place_states,
                               rendered_bones, task_layout, tracked_bones, z_to_direction)
from microg.view.server import Playback

from .conftest import project


def a_hand(rng, side="right") -> Hand:
    joints = rng.uniform(-0.1, 0.1, (5, 5, 3)) + [0.0, 0.2, 0.0]
    joints[0, 1] = joints[0, 0]  # the thumb's metacarpal has zero length, as in the Leap skeleton
    widths = rng.uniform(0.012, 0.02, (5, 4))
    return Hand(side, joints, widths, rng.uniform(-0.1, 0.1, 3), np.array([0.5, 0.5, 0.5, 0.5]))


def logged(hand: Hand | None, rendered: np.ndarray, side: int = 1) -> np.ndarray:
    """A logged frame with ``hand`` on ``side`` (the other side untracked), through the frame log's codec."""
    frame = np.zeros((), dtype=framelog.FRAME)
    for field in framelog.HAND_FIELDS:
        frame[field] = np.nan
    if hand is not None:
        frame["tracked"][side], frame["track_id"][side] = True, hand.track_id
        for field in ("joints", "widths", "palm_position", "palm_orientation"):
            frame[field][side] = getattr(hand, field)
        frame["rendered"][side] = rendered
    return framelog.decode(framelog.encode(frame[None]), 1)[0]


def test_a_logged_hand_comes_back_as_the_session_wrote_it():
    rng = np.random.default_rng(1)
    hand = a_hand(rng)
    rendered = rng.uniform(-0.2, 0.2, (20, 3))
    values = hand_values(logged(hand, rendered), side=1)
    assert np.array_equal(values.joints, hand.joints) and np.array_equal(values.widths, hand.widths)
    assert np.array_equal(values.palm_position, hand.palm_position)
    assert np.array_equal(values.palm_orientation, hand.palm_orientation)
    assert np.array_equal(values.rendered, rendered.astype(np.float32))  # the log keeps what was computed as float32
    assert np.isnan(hand_values(logged(hand, rendered), side=0).joints).all()


def test_the_rendered_hand_moves_each_phalanx_to_its_rendered_centre_and_keeps_its_shape():
    rng = np.random.default_rng(2)
    hand = a_hand(rng)
    tracked = tracked_bones(hand_values(logged(hand, np.zeros((20, 3))), 1))
    rendered_centres = hand.bone_centres.reshape(20, 3).copy()
    pressed = [slot("right", 1, 3) - 20, slot("right", 0, 3) - 20]  # index and thumb tips, pushed out
    rendered_centres[pressed] += [[0.0, 0.01, 0.0], [-0.004, 0.0, 0.002]]
    rendered_centres[0] = np.nan  # the thumb's metacarpal is no phalanx: the physics has no centre for it
    rendered = rendered_bones(hand_values(logged(hand, rendered_centres), 1))

    # tracked bones run joint to joint with half the width as radius (the phalanx sphere's)
    assert np.allclose(tracked.start, hand.joints[:, :-1].reshape(20, 3))
    assert np.allclose(tracked.end, hand.joints[:, 1:].reshape(20, 3))
    assert np.allclose(tracked.radius, hand.widths.ravel() / 2)
    drawn = rendered.drawn
    assert not drawn[0] and drawn[1:].all() and tracked.drawn.all()
    assert np.allclose(rendered.centre[1:], rendered_centres[1:], atol=1e-7)
    assert np.allclose((rendered.end - rendered.start)[1:], (tracked.end - tracked.start)[1:])
    untouched = [k for k in range(1, 20) if k not in pressed]
    assert np.allclose(rendered.start[untouched], tracked.start[untouched])


def test_an_untracked_hand_draws_nothing():
    rng = np.random.default_rng(3)
    frame = logged(a_hand(rng), np.zeros((20, 3)))
    empty, right = hand_values(frame, 0), hand_values(frame, 1)
    assert not tracked_bones(empty).drawn.any() and not rendered_bones(empty).drawn.any()
    both = both_sides([tracked_bones(empty), tracked_bones(right)])
    assert both.drawn.tolist() == [False] * 20 + [True] * 20


def test_the_touching_mask_highlights_exactly_the_phalanges_in_contact():
    slots = [slot("right", 1, 3), slot("left", 0, 2), slot("right", 4, 0)]
    touching = touching_slots(sum(1 << k for k in slots))
    assert np.flatnonzero(touching).tolist() == sorted(slots) == [2, 27, 36]
    assert not touching_slots(0).any()


@pytest.mark.parametrize("done, lit, expected", [
    (0, False, ("next", "pending", "pending")),
    (0, True, ("lit", "pending", "pending")),
    (1, True, ("done", "lit", "pending")),
    (2, False, ("done", "done", "next")),
    (3, False, ("done", "done", "done")),
])
def test_place_markers_light_up_in_order(done, lit, expected):
    assert place_states(done, lit, 3) == expected


def test_a_capsule_turn_carries_z_onto_its_bone():
    rng = np.random.default_rng(4)
    directions = np.vstack([rng.normal(size=(50, 3)), [[0, 0, 1], [0, 0, -2], [1e-3, 0, -1], [0, 0, 0],
                                                       [np.nan, 0, 0]]])
    turns = z_to_direction(directions)
    assert np.allclose(np.linalg.norm(turns, axis=1), 1.0)
    turned = Rotation.from_quat(turns[:, [1, 2, 3, 0]]).apply([0.0, 0.0, 1.0])
    unit = directions[:-2] / np.linalg.norm(directions[:-2], axis=1, keepdims=True)
    assert np.allclose(turned[:-2], unit, atol=1e-9)
    assert np.allclose(turned[-2:], [0.0, 0.0, 1.0])


@pytest.mark.parametrize("protocol", ["paper", "paper-microgravity"])
@pytest.mark.parametrize("aspect", [4 / 3, 1.0])
def test_the_default_camera_frames_the_start_and_every_place(protocol, aspect):
    layout = task_layout(load_protocol(protocol_file(protocol)), "long_cuboid")
    camera = default_camera(layout, aspect)
    width, height = round(400 * aspect), 400
    rings = np.vstack([layout.places + [dx, dy, 0.0] for dx, dy in [(0, 0.04), (0, -0.04), (0.04, 0), (-0.04, 0)]])
    pixels = project(np.vstack([layout.start, rings]), camera, width, height)
    assert (pixels > 0).all() and (pixels[:, 0] < width).all() and (pixels[:, 1] < height).all()
    # and not from so far away that the scene is lost: it spans at least half the width
    assert np.ptp(pixels[:, 0]) > width / 2
    if protocol == "paper":
        assert layout.table_height == 0.15 and layout.start[1] == pytest.approx(0.15 + 0.04 / 2)
    else:
        assert layout.table_height is None


def test_the_heads_up_display_says_stage_timer_place_and_attempts():
    scene = FrameScene(t=12.345, stage="maintenance", place=1, place_lit=True, place_timer=1.25, held=True,
                       attempts=2, object_position=np.zeros(3), object_orientation=np.array([1.0, 0, 0, 0]),
                       tracked=None, rendered=None, touching=np.zeros(40, bool), places=("done", "lit", "pending"))
    layout = task_layout(load_protocol(protocol_file("paper")), "cube")
    assert layout.hold_s == 3.0 and len(layout.places) == 3
    assert hud_lines(scene, layout) == ["maintenance · 12.3 s", "place 2 lit: 1.2 / 3 s · holding",
                                        "attempts (drops): 2"]
    done = FrameScene(**{**scene.__dict__, "stage": "completed", "place": 3, "place_lit": False, "held": False})
    assert hud_lines(done, layout)[1] == "all 3 places done · not holding"


def test_a_send_is_drawn_with_its_target_zone_and_no_places_and_the_view_stays_put():
    """A task of another kind has no place rings; a send's has its target zone. Every task of the
    protocol is framed alike (the start, the places and the target), so the view does not jump."""
    protocol = load_protocol(protocol_file("microgravity-skills"))
    send, stop = task_layout(protocol, "cube", "sending"), task_layout(protocol, "cube", "stopping")
    assert send.kind == "send" and np.array_equal(send.target, protocol.task.send.target)
    assert send.target_radius == protocol.task.send.radius
    assert send.places.shape == stop.places.shape == (0, 3) and stop.target is None
    first, second = default_camera(send), default_camera(stop)
    assert np.array_equal(first.eye, second.eye) and np.array_equal(first.target, second.target)
    pixels = project(np.vstack([send.start, send.target + [send.target_radius, 0, 0], protocol.task.places]), first,
                     400, 300)
    assert (pixels > 0).all() and (pixels[:, 0] < 400).all() and (pixels[:, 1] < 300).all()
    scene = FrameScene(t=2.0, stage="drift", place=0, place_lit=False, place_timer=0.0, held=False, attempts=1,
                       object_position=np.zeros(3), object_orientation=np.array([1.0, 0, 0, 0]), tracked=None,
                       rendered=None, touching=np.zeros(40, bool), places=())
    assert hud_lines(scene, send) == ["drift · 2.0 s", "not holding", "attempts (misses): 1"]


def test_playback_moves_at_its_speed_stops_at_the_end_and_follows_the_live_edge():
    playback = Playback(seconds=1.0, playing=True, speed=2.0)
    playback.advance(0.5, duration=10.0)
    assert playback.seconds == 2.0 and playback.playing
    playback.advance(10.0, duration=10.0)
    assert playback.seconds == 10.0 and not playback.playing
    paused = Playback(seconds=3.0)
    paused.advance(1.0, duration=10.0)
    assert paused.seconds == 3.0
    live = Playback(follow=True)
    live.advance(0.01, duration=7.5)
    assert live.seconds == 7.5
