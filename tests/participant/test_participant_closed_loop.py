"""The participant in closed loop with the real physics: reproducible, minimum-jerk, task done, re-grasps,
and, given the task's display, following the task."""

import dataclasses

import numpy as np
import pytest

from microg.hands.guard import GuardConfig
from microg.hands.filter import FILTER_WINDOW
from microg.participant import BEGINNER, VETERAN, SimulatedParticipant, TaskPlan
from microg.participant.bench import EARTH, PLACES, START, ZERO_G, bench_plan, bench_rules, \
    bench_world, run_once
from microg.participant.noise import TrackingNoiseLevels
from microg.sim import PlacedObject, World, compose_scene, grasped, make_world, step
from microg.task import COMPLETED, KINDS, Lanes, observe, play

STILL = TrackingNoiseLevels(palm_position=0.0, palm_rotation=0.0, digit_angle=0.0)


def run(participant, world, until, on_frame=None):
    """Step ``world`` with the participant's frames, each decided on what the last frame showed
    (no task display: the participant judges the task itself), until ``until(participant, world)``
    or it ends."""
    while not until(participant, world):
        frame = participant.next_frame(observe(world))
        if frame is None:
            break
        world = step(world, frame)
        if on_frame is not None:
            on_frame(participant, world, frame)
    return world


def frames_of(seed, count=400):
    plan = bench_plan("cube", ZERO_G)
    world = bench_world(plan, "impulse_penetration")
    participant = SimulatedParticipant(plan, "veteran", seed)
    frames = []
    for _ in range(count):
        frame = participant.next_frame(observe(world))
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
    plan = bench_plan("cube", ZERO_G)
    participant = SimulatedParticipant(plan, skill, 3, noise=STILL)
    samples = []

    def record(p, w, frame):
        samples.append((frame.timestamp, p.action, frame.hands[0].palm_position))

    run(participant, bench_world(plan, "impulse_penetration"), lambda p, w: p.action == "descend", record)
    times = np.array([t for t, _, _ in samples])
    palms = np.array([x for _, _, x in samples])
    actions = [a for _, a, _ in samples]
    first = actions.index("reach")
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


def held_windows(times, positions, rules):
    """For each place, the start of the first run of ``hold_s`` inside its radius after the previous one."""
    starts, after = [], 0.0
    for place in rules.places:
        inside = np.linalg.norm(positions - np.asarray(place), axis=1) <= rules.place_radius
        begin = None
        for t, ok in zip(times, inside):
            if t < after:
                continue
            if ok and begin is None:
                begin = t
            elif not ok:
                begin = None
            if begin is not None and t - begin >= rules.hold_s:
                break
        else:
            return starts
        starts.append(begin)
        after = begin + rules.hold_s
    return starts


def test_a_veteran_picks_and_places_the_cube_under_earth_gravity_with_the_papers_model():
    plan = bench_plan("cube", EARTH)
    participant = SimulatedParticipant(plan, "veteran", 11)
    times, positions, palms, holding = [], [], [], []

    def record(p, w, frame):
        times.append(w.time)
        positions.append(w.data.position[0].copy())
        palms.append(frame.hands[0].palm_position)
        holding.append(bool(grasped(w)[0]))

    run(participant, bench_world(plan, "impulse_penetration"), lambda p, w: w.time > 40.0, record)
    assert participant.action == "done"
    times, positions, palms = np.array(times), np.array(positions), np.array(palms)
    starts = held_windows(times, positions, plan.rules)
    assert len(starts) == 3, "the cube stayed 3 s within each place's radius, in order"
    # Released: after the third hold the cube left the grasp and ended away from the hand.
    last_hold_end = starts[2] + plan.rules.hold_s
    assert not holding[-1]
    assert np.linalg.norm(positions[-1] - palms[-1]) > 0.05
    assert any(holding[i] for i in range(len(times)) if times[i] > last_hold_end)


def knocked_out(world: World) -> World:
    """``world`` with the object back at its start (on the table under gravity), at rest."""
    data = world.data.copy()
    data.position[0] = START
    data.velocity[0] = 0.0
    data.angular_velocity[0] = 0.0
    return World(world.model, data)


@pytest.mark.parametrize("gravity", [ZERO_G, EARTH], ids=["zero_g", "earth"])
def test_after_a_forced_drop_the_participant_grasps_the_object_again(gravity):
    plan = bench_plan("cube", gravity)
    participant = SimulatedParticipant(plan, "veteran", 5)
    world = run(participant, bench_world(plan, "impulse_penetration"),
                lambda p, w: p.action == "hold" and w.time > 0.5 + p.state["since"])
    assert grasped(world)[0]
    world = knocked_out(world)
    knocked_at = world.time
    world = run(participant, world, lambda p, w: p.state["attempts"] == 1)
    assert participant.state["attempts"] == 1 and world.time - knocked_at < 1.0
    world = run(participant, world,
                lambda p, w: grasped(w)[0] and p.action == "carry" or w.time > knocked_at + 8.0)
    assert grasped(world)[0], "the participant took hold of the cube again"
    assert world.time - knocked_at < 8.0
    world = run(participant, world, lambda p, w: p.action == "hold" or w.time > knocked_at + 12.0)
    assert np.linalg.norm(world.data.position[0] - np.asarray(PLACES[0])) <= plan.rules.place_radius


def lanes_of(plan, world) -> Lanes:
    """One lane of the plan's task on ``world``, tracked as a session tracks it."""
    lanes = Lanes(KINDS[plan.rules.kind], world, 1, guard=GuardConfig(nominal_rate=world.model.scene.tracking_rate),
                  window=FILTER_WINDOW)
    lanes.load(0, world, plan.rules)
    return lanes


def test_with_the_task_display_the_participant_holds_until_the_task_moves_on_and_stops_when_it_is_over():
    """Through the task loop (``microg.task.play``): the participant counts a place done on the
    frame after the task shows it done (not by its own clock, which runs at least ``hold_margin_s``
    longer), and once the task shows completion it gives one last frame and ends."""
    plan = bench_plan("cube", EARTH)
    participant = SimulatedParticipant(plan, "veteran", 2)
    world = bench_world(plan, "impulse_penetration")
    lanes = lanes_of(plan, world)
    shown_places, own_places = [], []
    for moments in play(lanes, participant):
        own_places.append(participant.state["place"])
        shown_places.append(moments.display(len(moments) - 1).place)
    state = lanes.state(0)
    assert state.stage == COMPLETED and state.attempts == 0
    # own_places[i] was decided on the display of frame i - 1.
    for i in range(1, len(own_places)):
        if own_places[i] > own_places[i - 1]:
            assert shown_places[i - 1] == own_places[i] and shown_places[i - 2] < own_places[i]
    assert own_places[-1] == 3
    last = lanes.observation(0)
    assert last.display.stage == COMPLETED
    assert participant.next_frame(last) is not None
    assert participant.action == "done" and participant.next_frame(last) is None


@pytest.mark.parametrize("gravity", [ZERO_G, EARTH], ids=["zero_g", "earth"])
def test_a_grip_that_lapses_drops_the_object_in_its_carry_once_and_the_task_is_done_after_it(gravity):
    """A lapse near certain on every carry (``grip_lapse``): the grip opens on the way to the first
    place, the task counts the drop, and the participant takes the object again and, minding its
    grip from then on, completes the task without another; the same participant without lapses
    drops nothing."""
    plan = bench_plan("cube", gravity)
    results = {}
    for lapse in (0.0, 0.95):
        participant = SimulatedParticipant(plan, dataclasses.replace(VETERAN, grip_lapse=lapse), 2)
        world = bench_world(plan, "impulse_penetration")
        lanes, drops = lanes_of(plan, world), []
        for moments in play(lanes, participant):
            drops += [e.data for i in range(len(moments)) for e in moments.task_events(i) if e.kind == "drop"]
        state = lanes.state(0)
        results[lapse] = state.stage, state.attempts, drops
    assert results[0.0][:2] == (COMPLETED, 0)
    stage, attempts, drops = results[0.95]
    assert (stage, attempts) == (COMPLETED, 1), results[0.95]
    assert drops[0]["stage"] == "maintenance" and drops[0]["place"] == 0, "dropped on the way to the first place"


def test_the_bench_plays_the_task_by_its_rules():
    plan = bench_plan("cube", ZERO_G, time_limit_s=60.0)
    result = run_once(SimulatedParticipant(plan, "veteran", 4, time_limit_s=70.0), "impulse_penetration")
    assert result.completed and result.places_done == 3 and result.attempts == 0
    assert 3 * plan.rules.hold_s < result.completion_time < 60.0
    # Frames come at the tracker's 115 Hz (a few missing), until the release was judged.
    assert 100 * result.completion_time < result.frames < 120 * (result.completion_time + 1.0)
    assert result.participant_time > 0 and result.world_time > 0


def test_plan_and_participant_errors_name_the_field():
    spec = bench_plan("cube").object
    with pytest.raises(ValueError, match="TaskPlan.hand = 'middle'"):
        TaskPlan(object=spec, start=START, rules=bench_rules(), hand="middle")
    with pytest.raises(ValueError, match="rules.places is empty"):
        TaskPlan(object=spec, start=START, rules=dataclasses.replace(bench_rules(), places=()))
    with pytest.raises(ValueError, match=r"TaskPlan.start = \(0.0, 0.1\): must be three"):
        TaskPlan(object=spec, start=(0.0, 0.1), rules=bench_rules())
    with pytest.raises(TypeError, match="must be a TaskPlan"):
        SimulatedParticipant("cube")
    with pytest.raises(ValueError, match="skill = 'expert'"):
        SimulatedParticipant(bench_plan("cube"), "expert")
    with pytest.raises(ValueError, match="closed-loop"):
        SimulatedParticipant(bench_plan("cube")).next_frame(None)


@pytest.mark.parametrize("spin, intercept", [((1.0, 1.0, 1.0), 2.0), ((3.0, 0.02, 0.02), 4.0)])
def test_a_slow_reach_for_a_tumbling_object_turns_the_hand_smoothly(spin, intercept):
    """The long cuboid tumbles in place (zero g) while a slow participant reaches for it: the reach
    follows it, and once the object has turned more than half a turn from where the reach began it
    is reached afresh from where the hand is. No point of the hand moves 3 cm in one frame (3 m/s,
    beyond a person's fastest reach); when the reach's end came round to the antipode of its start's
    quaternion the hand swung round by up to 4 and 7.6 cm in one frame in these two cases, and
    in a calibration's study by 17 cm, which the tracking guard would have taken for a new hand."""
    plan = bench_plan("long_cuboid", ZERO_G)
    tumbling = PlacedObject(plan.object, plan.start, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), spin)
    world = make_world(compose_scene([tumbling], "impulse_penetration", gravity=ZERO_G))
    slow = dataclasses.replace(VETERAN, movement_intercept=intercept, hesitation_s=0.0)
    participant = SimulatedParticipant(plan, slow, 3)
    points = []

    def record(p, w, frame):
        hand = frame.hands[0]
        points.append(np.vstack([hand.palm_position, np.asarray(hand.joints).reshape(-1, 3)]))

    run(participant, world, lambda p, w: w.time > 6.0, record)
    moved = np.linalg.norm(np.diff(np.array(points), axis=0), axis=-1).max(axis=1)
    assert len(points) > 500 and moved.max() < 0.03, moved.max()


@pytest.mark.parametrize("seed", [1, 5])
def test_a_participant_at_the_fastest_a_person_moves_never_jumps_as_far_as_the_guard_refuses(seed):
    """Issue 28: Fitts' constants at their smallest (a fast learner after much practice) turning the
    hand over for the flat cuboid: no point of the hand moves as far as the tracking guard's jump
    distance between two frames (before movements were paced by MAX_POINT_SPEED, these seeds moved a
    fingertip 13-16 cm in one frame, and an in-silico study refused the frame)."""
    skill = dataclasses.replace(BEGINNER, name="fastest", movement_intercept=0.05, movement_slope=0.02,
                                carry_slowdown=1.0)
    plan = bench_plan("flat_cuboid", time_limit_s=40.0)
    participant = SimulatedParticipant(plan, skill, seed)
    moved, last = [], None

    def record(p, w, frame):
        nonlocal last
        points = np.vstack([np.vstack([h.joints.reshape(-1, 3), h.palm_position]) for h in frame.hands])
        if last is not None and len(points) == len(last):
            moved.append(float(np.linalg.norm(points - last, axis=1).max()))
        last = points

    run(participant, bench_world(plan, "impulse_penetration"), lambda p, w: p.closed, record)
    assert len(moved) > 3000, "the task ended before 30 s of frames"
    assert max(moved) < GuardConfig().jump_distance
