"""The physics refuses what no tracker delivers, naming it, instead of computing for minutes or
flinging objects at km/s."""

from __future__ import annotations

import numpy as np
import pytest

from microg.participant.scripted import probe_hand
from microg.skeleton import Hand, HandFrame
from microg.sim import SceneError, make_batch, step, step_batch
from microg.sim.world import MAX_INTERVAL
from tests.physics import placed, world_of


def test_a_frame_far_ahead_is_a_clock_jump_not_a_pause():
    world = step(world_of([placed("cube")]), HandFrame(0.0))
    with pytest.raises(SceneError, match=r"is 10000 s after the previous frame's 0.0.*MAX_INTERVAL = 60"):
        step(world, HandFrame(1e4))
    assert step(world, HandFrame(MAX_INTERVAL)).data.frame_time == MAX_INTERVAL  # a long pause is fine
    batch = step_batch(make_batch([world, world]), [HandFrame(1.0), HandFrame(2.0)])
    with pytest.raises(SceneError, match="MAX_INTERVAL"):
        step_batch(batch, [HandFrame(2.0), HandFrame(1e4)])


@pytest.mark.parametrize("change, message", [
    (lambda j, w, p, q: (j, np.full_like(w, 1.0), p, q), r"widths\[0, 0\] = 1 m: wider than any finger"),
    (lambda j, w, p, q: (j + 1e3, w, p, q), r"joints\[0, 0, 0\] = 1000 m: farther from the tracker than 10 m"),
    (lambda j, w, p, q: (j, w, p, np.array([2.0, 0, 0, 0])), "not a unit quaternion"),
    (lambda j, w, p, q: (j, w, p, np.array([1.0, np.nan, 0, 0])), "partly unknown"),
])
def test_a_hand_no_person_has_is_refused_with_its_field_and_value(change, message):
    good = probe_hand({"index.distal": (0.0, 0.2, 0.0), "thumb.distal": (0.05, 0.2, 0.0)})
    joints, widths, palm, orientation = change(np.nan_to_num(good.joints), np.nan_to_num(good.widths, nan=0.01),
                                               good.palm_position, good.palm_orientation)
    with pytest.raises(ValueError, match=message):
        Hand("right", joints, widths, palm, orientation)
