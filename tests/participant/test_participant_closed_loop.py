"""The participant in closed loop with the real physics: reproducible, minimum-jerk, task done, re-grasps."""

import dataclasses

import numpy as np
import pytest

from microg.sim import grasped, step
from microg.participant import VETERAN, PickPlacePlan, SimulatedParticipant
from microg.participant.bench import EARTH, PLACES, ZERO_G, bench_plan, bench_world
from microg.participant.noise import TrackingNoiseLevels

STILL = TrackingNoiseLevels(palm_position=0.0, palm_rotation=0.0, digit_angle=0.0)


def run(participant, world, until, on_frame=None):
    """Step ``world`` with the participant's frames until ``until(participant, world)`` or it ends."""
    while not until(participant, world):
        frame = participant.next_frame(world)
        if frame is None:
            break
        world = step(world, frame)
        if on_frame is not None:
            world = on_frame(participant, world, frame) or world
    return world


def frames_of(seed, count=400):
    world = bench_world("cube", "impulse_penetration", ZERO_G)
    participant = SimulatedParticipant(bench_plan("cube"), "veteran", seed)
    frames = []
    for _ in range(count):
        frame = participant.next_frame(world)
        frames.append(frame)
        world = step(world, frame)
    return frames, participant.description


def test_the_same_seed_gives_identical_frames_and_another_seed_different_ones():
    first, description = frames_of(7)
    again, _ = frames_of(7)
    other, _ = frames_of(8)
    assert description == "simulated:veteran:seed=7"
    assert all(a == b for a, b in zip(first, again))
    assert sum(a == b for a, b in zip(first, other)) == 0
    times = np.array([f.timestamp for f in first])
    assert times[0] == 0.0 and np.all(np.diff(times) > 0)


def test_a_reach_follows_the_minimum_jerk_profile():
    """Noise and tremor off: the palm's path to the pre-grasp pose is the Flash-Hogan quintic."""
    skill = dataclasses.replace(VETERAN, tremor_rms=0.0, hesitation_s=0.0)
    participant = SimulatedParticipant(bench_plan("cube"), skill, 3, noise=STILL)
    world = bench_world("cube", "impulse_penetration", ZERO_G)
    samples = []

    def record(p, w, frame):
        samples.append((frame.timestamp, p.phase, frame.hands[0].palm_position))

    run(participant, world, lambda p, w: p.phase == "descend", record)
    times = np.array([t for t, _, _ in samples])
    palms = np.array([x for _, _, x in samples])
    phases = [ph for _, ph, _ in samples]
    first = phases.index("reach")
    t0, t1 = times[first - 1], times[-1]   # the reach is planned on the last waiting frame
    start, end = palms[first - 1], palms[-1]
    inside = slice(first, len(times) - 1)
    tau = (times[inside] - t0) / (t1 - t0)
    progress = (palms[inside] - start) @ (end - start) / np.dot(end - start, end - start)
    quintic = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5
    np.testing.assert_allclose(progress, quintic, atol=0.02)
    # Straight line: no sideways excursion from the start-end segment.
    offsets = palms[inside] - start - np.outer(progress, end - start)
    assert np.abs(offsets).max() < 1e-6
    speed = np.linalg.norm(np.diff(palms[first - 1:], axis=0), axis=1) / np.diff(times[first - 1:])
    assert speed.max() / (np.linalg.norm(end - start) / (t1 - t0)) == pytest.approx(1.875, rel=0.03)


def held_windows(times, positions, plan):
    """For each place, the start of the first run of ``hold_s`` inside its radius after the previous one."""
    starts, after = [], 0.0
    for place in plan.places:
        inside = np.linalg.norm(positions - np.asarray(place), axis=1) <= plan.place_radius
        begin = None
        for t, ok in zip(times, inside):
            if t < after:
                continue
            if ok and begin is None:
                begin = t
            elif not ok:
                begin = None
            if begin is not None and t - begin >= plan.hold_s:
                break
        else:
            return starts
        starts.append(begin)
        after = begin + plan.hold_s
    return starts


def test_a_veteran_picks_and_places_the_cube_under_earth_gravity_with_the_papers_model():
    world = bench_world("cube", "impulse_penetration", EARTH)
    participant = SimulatedParticipant(bench_plan("cube"), "veteran", 11)
    times, positions, palms, holding = [], [], [], []

    def record(p, w, frame):
        times.append(w.time)
        positions.append(w.data.position[0].copy())
        palms.append(frame.hands[0].palm_position)
        holding.append(bool(grasped(w)[0]))

    world = run(participant, world, lambda p, w: w.time > 40.0, record)
    assert participant.phase == "done"
    times, positions, palms = np.array(times), np.array(positions), np.array(palms)
    starts = held_windows(times, positions, participant.plan)
    assert len(starts) == 3, "the cube stayed 3 s within each place's radius, in order"
    # Released: after the third hold the cube left the grasp and ended away from the hand.
    last_hold_end = starts[2] + participant.plan.hold_s
    assert not holding[-1]
    assert np.linalg.norm(positions[-1] - palms[-1]) > 0.05
    assert any(holding[i] for i in range(len(times)) if times[i] > last_hold_end)


@pytest.mark.parametrize("gravity", [ZERO_G, EARTH], ids=["zero_g", "earth"])
def test_after_a_forced_drop_the_participant_grasps_the_object_again(gravity):
    plan = PickPlacePlan("cube", PLACES)
    world = bench_world("cube", "impulse_penetration", gravity)
    participant = SimulatedParticipant(plan, "veteran", 5)
    world = run(participant, world, lambda p, w: p.phase == "hold" and w.time > 0.5 + p._phase_start)
    assert grasped(world)[0]
    # Knock the cube out of the hand: put it back at its start (on the table under gravity), at rest.
    world.data.position[0] = (0.0, 0.2, 0.0)
    world.data.velocity[0] = 0.0
    world.data.angular_velocity[0] = 0.0
    knocked_at = world.time
    world = run(participant, world, lambda p, w: p.drops == 1)
    assert participant.drops == 1 and world.time - knocked_at < 1.0
    world = run(participant, world, lambda p, w: grasped(w)[0] and p.phase == "carry" or w.time > knocked_at + 8.0)
    assert grasped(world)[0], "the participant took hold of the cube again"
    assert world.time - knocked_at < 8.0
    world = run(participant, world, lambda p, w: p.phase == "hold" or w.time > knocked_at + 12.0)
    assert np.linalg.norm(world.data.position[0] - np.asarray(PLACES[0])) <= plan.place_radius


def test_plan_and_world_errors_name_the_field():
    with pytest.raises(ValueError, match="places has 2 places"):
        PickPlacePlan("cube", PLACES[:2])
    with pytest.raises(ValueError, match=r"places\[1\] = .*three"):
        PickPlacePlan("cube", (PLACES[0], (0.0, 0.1), PLACES[2]))
    with pytest.raises(ValueError, match="hold_s = -1"):
        PickPlacePlan("cube", PLACES, hold_s=-1)
    with pytest.raises(ValueError, match="skill = 'expert'"):
        SimulatedParticipant(bench_plan("cube"), "expert")
    participant = SimulatedParticipant(PickPlacePlan("ball", PLACES), "veteran", 0)
    with pytest.raises(ValueError, match="object_name.*'ball'.*cube"):
        participant.next_frame(bench_world("cube", "impulse_penetration", ZERO_G))
    with pytest.raises(ValueError, match="closed-loop"):
        participant.next_frame(None)
