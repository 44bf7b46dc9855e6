"""The simulated participant plays the other task kinds in the real physics: it catches a launched
cube and stops a spinning one (checked from the recorded object and hand), and a launch it cannot
reach times out untouched."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from microg.hands import Tracking
from microg.participant import SimulatedParticipant
from microg.sim import PlacedObject, compose_scene, grasped, make_world
from microg.study.inputs import participant_plan
from microg.study.protocol import load_protocol
from microg.study.session import task_world
from microg.study.store import PlannedTask
from microg.task import COMPLETED, TIMEOUT, play

PROTOCOL = load_protocol(Path(__file__).parents[1] / "study" / "protocols" / "kinds-simulated.toml")


def plan_and_world(phase: str):
    interaction = next(p.interaction for p in PROTOCOL.phases if p.name == phase)
    task = PlannedTask(0, phase, interaction, "cube", "C", 1)
    return participant_plan(PROTOCOL, task), task_world(PROTOCOL, task)


def played(plan, world, seed):
    """The task played by a veteran: its moments and, per frame, the time (and the physics'), the object's position,
    velocity and angular velocity, the tracked palm and whether the physics had the object grasped."""
    participant = SimulatedParticipant(plan, "veteran", seed, time_limit_s=plan.rules.timeout_s + 10.0)
    moments = list(play(world, Tracking(participant, PROTOCOL.guard), plan.rules))
    record = {
        "t": np.array([m.after.t for m in moments]),
        "physics_t": np.array([m.world.time for m in moments]),
        "position": np.array([m.after.position for m in moments]),
        "velocity": np.array([m.after.velocity for m in moments]),
        "omega": np.array([m.after.angular_velocity for m in moments]),
        "palm": np.array([m.frame.hands[0].palm_position for m in moments]),
        "grasped": np.array([bool(grasped(m.world)[0]) for m in moments]),
        "touched": np.array([bool(np.any(m.after.touching)) for m in moments]),
    }
    return moments, record


def test_a_veteran_catches_the_launched_cube_and_holds_it_moving_with_its_hand():
    plan, world = plan_and_world("catching")
    moments, r = played(plan, world, 2)
    state = moments[-1].state
    assert state.stage == COMPLETED and state.attempts == 0
    catch = PROTOCOL.task.catch
    launch = catch.launch_speed * np.asarray(catch.direction)
    # Until the hand met it, the cube flew on the launch's straight line from the start (zero gravity).
    met = np.linalg.norm(r["velocity"] - launch, axis=1) > 1e-9
    free = ~np.cumsum(met).astype(bool)
    assert free.sum() > 50 and np.linalg.norm(r["position"][free][-1] - r["palm"][free][-1]) < 0.1
    expected = np.asarray(plan.start) + np.outer(r["physics_t"][free], launch)
    np.testing.assert_allclose(r["position"][free], expected, atol=1e-6)
    # Caught: grasped through the last hold_s, sitting still in the hand, moving as the palm moves,
    # and it had been flying at the launch's speed.
    last = r["t"] >= r["t"][-1] - catch.hold_s + 0.02
    assert r["grasped"][last].all()
    in_hand = np.linalg.norm(r["position"][last] - r["palm"][last], axis=1)
    assert in_hand.max() - in_hand.min() < 0.005
    window = r["t"][last][-1] - r["t"][last][0]
    palm_velocity = (r["palm"][last][-1] - r["palm"][last][0]) / window
    object_velocity = (r["position"][last][-1] - r["position"][last][0]) / window
    assert np.linalg.norm(object_velocity - palm_velocity) < 0.1 * catch.launch_speed
    assert np.isclose(np.linalg.norm(r["velocity"][free][-1]), catch.launch_speed, rtol=1e-12)
    # The task's time to catch is when that grasp began, by the recorded grasp.
    began = r["t"][np.flatnonzero(~r["grasped"])[-1] + 1]
    assert abs(state.time_to_catch - began) < 0.05


def test_a_veteran_stops_the_spinning_cube_and_it_rests_in_the_grip():
    plan, world = plan_and_world("stopping")
    moments, r = played(plan, world, 3)
    state = moments[-1].state
    spin = PROTOCOL.task.stop_spin
    assert state.stage == COMPLETED
    np.testing.assert_allclose(np.linalg.norm(r["omega"][0]), spin.spin_rate, rtol=1e-9)
    # At rest for the last hold_s: held, turning slower than rest_omega (from the recorded world).
    last = r["t"] >= r["t"][-1] - spin.hold_s + 0.02
    assert r["grasped"][last].all()
    assert np.linalg.norm(r["omega"][last], axis=1).max() < spin.rest_omega
    assert np.linalg.norm(r["omega"][0]) > 5 * np.median(np.linalg.norm(r["omega"][last], axis=1))


def test_a_launch_away_from_the_hand_beyond_its_reach_times_out_untouched():
    """Launched at 1 m/s away from the participant, every point of its path the hand could reach in
    time lies more than 40 cm from where the hand waits: it waits for an object within reach until
    the task times out (the object goes back and is launched again each time it leaves)."""
    plan, _ = plan_and_world("catching")
    away = dataclasses.replace(PROTOCOL.task.catch, launch_speed=1.0, direction=(0.0, 0.0, -1.0))
    rules = dataclasses.replace(plan.rules, catch=away, timeout_s=4.0)
    plan = dataclasses.replace(plan, rules=rules)
    start, orientation = PROTOCOL.start_pose("cube")
    launched = PlacedObject(plan.object, start, orientation, (0.0, 0.0, -1.0), (0.0, 0.0, 0.0))
    world = make_world(compose_scene([launched], "impulse_penetration", gravity=PROTOCOL.gravity))
    moments, r = played(plan, world, 2)
    state = moments[-1].state
    assert state.stage == TIMEOUT and state.attempts == 0
    assert not r["touched"].any() and not r["grasped"].any()
    assert sum(e.kind == "respawn" for m in moments for e in m.events) >= 3
