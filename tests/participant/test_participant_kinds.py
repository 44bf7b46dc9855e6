"""The simulated participant plays the other task kinds in the real physics: it catches a launched
cube, stops a spinning one and sends one to a target (checked from the recorded object and hand),
and a launch it cannot reach times out untouched."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from microg.participant import SimulatedParticipant
from microg.sim import PlacedObject, compose_scene, make_world
from microg.sim.rotation import quat_to_matrix
from microg.study.inputs import participant_plan
from microg.study.protocol import load_protocol
from microg.study.session import task_world
from microg.study.store import PlannedTask
from microg.skeleton import SIDES
from microg.task import COMPLETED, KINDS, TIMEOUT, Lanes, play

PROTOCOLS = Path(__file__).parents[1] / "study" / "protocols"
PROTOCOL = load_protocol(PROTOCOLS / "kinds-simulated.toml")
SENDING = load_protocol(PROTOCOLS / "send.toml")


def plan_and_world(phase: str, protocol=PROTOCOL):
    interaction = next(p.interaction for p in protocol.phases if p.name == phase)
    task = PlannedTask(0, phase, interaction, "cube", "C", 1)
    return participant_plan(protocol, task), task_world(protocol, task)


def played(plan, world, seed):
    """The task played by a veteran: its final state, its events and, per frame, the time (and the
    physics'), the object's position, velocity and angular velocity, the tracked palm and whether the
    physics had the object grasped."""
    participant = SimulatedParticipant(plan, "veteran", seed, time_limit_s=plan.rules.timeout_s + 10.0)
    lanes = Lanes(KINDS[plan.rules.kind], world, 1, guard=PROTOCOL.guard, window=PROTOCOL.filter_window)
    lanes.load(0, world, plan.rules)
    batches = list(play(lanes, participant))
    records = np.concatenate([moments.records for moments in batches])
    after, side = records["after"], SIDES.index(plan.hand)
    record = {
        "t": after["t"], "physics_t": after["time"], "position": after["position"], "velocity": after["velocity"],
        "omega": after["angular_velocity"], "palm": records["hands"]["points"][:, side, 0],
        "grasped": after["grasped_by"].any(axis=1), "touched": after["touching"].any(axis=1),
    }
    events = [e for moments in batches for i in range(len(moments)) for e in moments.task_events(i)]
    return lanes.state(0), events, record


def test_a_veteran_catches_the_launched_cube_and_holds_it_moving_with_its_hand():
    plan, world = plan_and_world("catching")
    state, _, r = played(plan, world, 2)
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
    state, _, r = played(plan, world, 3)
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
    rules = dataclasses.replace(plan.rules.with_numbers("catch", away), timeout_s=4.0)
    plan = dataclasses.replace(plan, rules=rules)
    start, orientation = PROTOCOL.start_pose("cube")
    launched = PlacedObject(plan.object, start, orientation, (0.0, 0.0, -1.0), (0.0, 0.0, 0.0))
    world = make_world(compose_scene([launched], "impulse_penetration", gravity=PROTOCOL.gravity))
    state, events, r = played(plan, world, 2)
    assert state.stage == TIMEOUT and state.attempts == 0
    assert not r["touched"].any() and not r["grasped"].any()
    assert sum(e.kind == "respawn" for e in events) >= 3


def _drift_line(r, since, until):
    """The straight line (a point and the velocity) that the object drifts on, free, between the
    release at ``since`` and ``until``: from the last frame before ``until`` at which its velocity
    changed (the open hand coasts along with it for a while, and its palm may still nudge it)."""
    window = np.flatnonzero((r["t"] >= since) & (r["t"] < until))
    changed = np.flatnonzero(np.any(r["velocity"][window][1:] != r["velocity"][window][:-1], axis=1))
    free = window[changed[-1] + 1 if len(changed) else 0:]
    return r["position"][free[0]], r["velocity"][free[0]], r["physics_t"][free[0]], free


def _closest(point, velocity, centre):
    f = np.subtract(centre, point)
    return float(np.linalg.norm(f - max(f @ velocity / (velocity @ velocity), 0.0) * velocity))


def test_a_veteran_sends_the_cube_misses_once_and_sends_it_again_into_the_target_zone():
    """Each send's drift, once the hand has let go, is the straight line of its velocity (zero
    gravity): the miss's closest approach and the arrival's send error are that line's closest
    approach to the target, the release is where the recorded grasp went, and the second send
    arrives in the zone."""
    plan, world = plan_and_world("sending", SENDING)
    state, events, r = played(plan, world, 2)
    send = SENDING.task.send
    releases, misses = [e for e in events if e.kind == "release"], [e for e in events if e.kind == "miss"]
    assert state.stage == COMPLETED and state.attempts == len(misses) == 1 and len(releases) == 2
    for release in releases:  # where and as fast as the object moved at the first frame the grasp was gone
        at = np.flatnonzero((r["t"] <= release.t) & r["grasped"])[-1] + 1
        np.testing.assert_allclose(release.data["position"], r["position"][at], atol=1e-12)
        assert release.data["speed"] == pytest.approx(np.linalg.norm(r["velocity"][at]), abs=1e-12)
    for since, until, measured in ((releases[0].t, misses[0].t, misses[0].data["closest_m"]),
                                   (releases[1].t, np.inf, state.send_error)):
        point, velocity, t0, free = _drift_line(r, since, until)
        assert len(free) > 10
        np.testing.assert_allclose(r["position"][free], point + np.outer(r["physics_t"][free] - t0, velocity),
                                   atol=1e-6)
        assert measured == pytest.approx(_closest(point, velocity, send.target), abs=1e-6)
    assert misses[0].data["closest_m"] > send.radius > state.send_error
    last = releases[1]
    due = np.linalg.norm(np.subtract(last.data["position"], send.target)) / send.arrival_s
    assert state.release_speed_error == pytest.approx(last.data["speed"] - due, abs=1e-12)


def _run_through(grasped, index):
    """The first frame of the run of grasped frames that goes on at ``index``."""
    return index - np.argmin(grasped[index::-1]) + 1 if not grasped[:index + 1].all() else 0


def test_a_veterans_two_hands_hand_the_cube_over_and_the_measures_follow_their_grasps():
    """The right hand takes the cube and offers it; the left takes it from below, palm up; the right
    lets go and the left holds it in the zone. The transfer time runs from the left hand's grasp to
    the right hand's letting go and both held it from that grasp's settling to the right hold's end,
    by the grasps the physics reports for each hand."""
    from microg.participant import HandingParticipant

    protocol = load_protocol(PROTOCOLS / "handover.toml")
    plan, world = plan_and_world("passing", protocol)
    handover = protocol.task.handover
    participant = HandingParticipant(plan, "veteran", 1, time_limit_s=plan.rules.timeout_s + 10.0)
    lanes = Lanes(KINDS[plan.rules.kind], world, 1, guard=protocol.guard, window=protocol.filter_window)
    lanes.load(0, world, plan.rules)
    records = np.concatenate([moments.records for moments in play(lanes, participant)])
    state, after, hands = lanes.state(0), records["after"], records["hands"]
    assert state.stage == COMPLETED
    t = after["t"]
    left, right = after["grasped_by"].astype(bool).T
    assert np.argmax(right) < np.argmax(left)  # the first hand took it first
    let_go = np.flatnonzero(right)[-1] + 1
    took = _run_through(left, let_go - 1)
    assert state.transfer_time == pytest.approx(t[let_go] - t[took], abs=1e-9)
    rules = plan.rules
    assert state.both_held == pytest.approx((t[let_go] + rules.drop_grace_s) - (t[took] + rules.grasp_settle_s), abs=0.02)
    # Taken from below, palm up: the left palm under the cube, facing up, as the right let go.
    palm, palm_orientation = hands["points"][let_go, 0, 0], hands["orientation"][let_go, 0]  # the left hand's
    assert palm[1] < after["position"][let_go, 1] - plan.object.half_extents[1]
    assert quat_to_matrix(palm_orientation)[1, 1] < -0.9  # the back of the hand (its y) faces down
    # It ends held by the left hand alone, in the zone, for the hold.
    last = t >= t[-1] - handover.hold_s + 0.02
    assert left[last].all() and not right[last].any()
    assert np.linalg.norm(after["position"][-1] - np.asarray(handover.place)) <= handover.radius
