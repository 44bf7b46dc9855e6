"""Batched worlds: one compiled call steps many worlds, each exactly as it would step alone."""

import numpy as np
import pytest

from microg.skeleton import HandFrame
from microg.sim import SceneError, World, make_batch, stack_frames, step, step_batch
from microg.participant.scripted import probe_hand
from tests.physics import placed, world_of


def hand_at(t, world_index):
    """A different scripted hand per world: a fingertip tapping the cube at its own speed and place,
    then a second hand appearing; world 3 has no hand at all."""
    if world_index == 3:
        return ()
    speed = 0.2 + 0.3 * world_index
    tips = {"index.distal": (0.01 * world_index, 0.25 - speed * t, 0.0)}
    hands = (probe_hand(tips, "right"),)
    if t > 0.2:
        hands += (probe_hand({"thumb.distal": (-0.05, 0.2, 0.01 * world_index)}, "left"),)
    return hands


@pytest.mark.parametrize("interaction", ["impulse_penetration", "penetration_only", "soft_hand"])
def test_a_batch_of_worlds_follows_exactly_the_trajectories_of_single_worlds(interaction):
    world = world_of([placed("cube"), placed("long_cuboid", position=(0.2, 0.2, 0.0))], interaction=interaction)
    singles = []
    for i in range(4):
        data = world.data.copy()
        data.velocity[1] = (0.0, 0.0, 0.05 * i)
        data.angular_velocity[1] = (0.0, 2.0 * i, 0.0)
        singles.append(World(world.model, data))
    batch = make_batch(singles)
    touched = False
    for t in np.arange(0.0, 0.4, 1 / 110):
        frames = [HandFrame(float(t), hand_at(t, i)) for i in range(4)]
        singles = [step(w, f) for w, f in zip(singles, frames)]
        batch = step_batch(batch, stack_frames(frames))
        for i, single in enumerate(singles):
            assert np.array_equal(batch.reals[i], single.data.reals, equal_nan=True)
            assert np.array_equal(batch.flags[i], single.data.flags)
            assert np.array_equal(batch.counts[i], single.data.counts)
        touched |= any(w.data.active.any() for w in singles)
    assert touched or any(w.data.velocity[0].any() for w in singles)  # the hands touched the cube
    assert batch.world(0).data.steps == singles[0].data.steps > 0


def test_step_batch_leaves_its_argument_untouched_and_checks_frame_order():
    batch = make_batch(world_of([placed("cube", velocity=(0.1, 0.0, 0.0))]).model.scene, 3)
    batch = step_batch(batch, [HandFrame(0.0)] * 3)
    before = batch.reals.copy()
    later = step_batch(batch, [HandFrame(0.5)] * 3)
    assert np.array_equal(batch.reals, before, equal_nan=True)
    assert later.field("position")[:, 0, 0] == pytest.approx([0.05] * 3)
    with pytest.raises(SceneError, match="not after the previous frame"):
        step_batch(later, [HandFrame(1.0), HandFrame(0.5), HandFrame(1.0)])
    with pytest.raises(SceneError, match="2 frames for a batch of 3"):
        step_batch(later, [HandFrame(1.0)] * 2)


def test_step_takes_a_frame_as_its_record_to_the_same_world():
    world = world_of([placed("cube"), placed("long_cuboid", position=(0.2, 0.2, 0.0))])
    frames = [HandFrame(float(t), hand_at(t, 2)) for t in np.arange(0.0, 0.4, 1 / 110)]
    records = stack_frames(frames)
    from_frames, from_records = world, world
    for frame, record in zip(frames, records):
        from_frames, from_records = step(from_frames, frame), step(from_records, record)
        assert from_frames.data.reals.tobytes() == from_records.data.reals.tobytes()
        assert from_frames.data.flags.tobytes() == from_records.data.flags.tobytes()
        assert from_frames.data.counts.tobytes() == from_records.data.counts.tobytes()
    assert np.abs(from_records.data.velocity[0]).max() > 0.1  # the fingertip hit the cube
    with pytest.raises(SceneError, match="not after the previous frame"):
        step(from_records, records[3])
    with pytest.raises(SceneError, match=r"frame is a ndarray .*expected a HandFrame or a microg.skeleton.HANDS record"):
        step(from_records, records[3:4])
    with pytest.raises(SceneError, match="frame is a float"):
        step(from_records, 0.5)
