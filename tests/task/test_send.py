"""The send on scripted observations: a hand holds the object still, lets it go at a release velocity,
and it drifts on its straight line in zero gravity; the expected numbers come from that line."""

from __future__ import annotations

import numpy as np

from microg.task.observation import Observation
from microg.task.kinds.send import SendRules
from microg.task.rules import TaskRules
from microg.task import COMPLETED, KINDS, TIMEOUT

KIND = KINDS["send"]
CARRY, DRIFT, PICK_UP = "carry", "drift", "pick_up"

RATE = 100.0
HELD_AT = np.array([0.0, 0.2, 0.0])
TARGET = np.array([0.3, 0.2, 0.1])
RADIUS, ARRIVAL_S = 0.04, 2.0
SETTLE_S, GRACE_S, LET_GO = 0.1, 0.25, 0.5
"""s: the hand grasps from the first frame and lets go at LET_GO."""
RULES = TaskRules(start=tuple(HELD_AT), start_orientation=(1.0, 0.0, 0.0, 0.0), places=((0.0, 0.3, 0.0),),
                  place_radius=0.02, hold_s=3.0, timeout_s=6.0, grasp_settle_s=SETTLE_S, drop_grace_s=GRACE_S,
                  workspace_min=(-1.0, -1.0, -1.0), workspace_max=(1.0, 1.0, 1.0), kind="send",
                  tables=(("send", SendRules(target=tuple(TARGET), radius=RADIUS, arrival_s=ARRIVAL_S)),))


def play(velocity, seconds: float = 6.5):
    """The send over ``seconds``: held still at HELD_AT until LET_GO, then drifting at ``velocity``
    from there. Returns the final state and the events."""
    state, events = KIND.start(), []
    for k in range(round(seconds * RATE)):
        t = k / RATE
        held = t < LET_GO - 1e-9
        position = HELD_AT if held else HELD_AT + velocity * (t - LET_GO)
        obs = Observation(t, held, position, velocity=np.zeros(3) if held else velocity)
        state, new = KIND.advance(state, obs, RULES)
        events += new
        if state.finished:
            break
    return state, events


def closest_approach(velocity) -> float:
    """The line's distance from the target's centre: the part of HELD_AT - TARGET across the line."""
    f, u = TARGET - HELD_AT, velocity / np.linalg.norm(velocity)
    return float(np.linalg.norm(f - (f @ u) * u))


def speed_error(velocity) -> float:
    return float(np.linalg.norm(velocity) - np.linalg.norm(TARGET - HELD_AT) / ARRIVAL_S)


def test_a_release_toward_the_target_arrives_with_the_errors_its_line_gives():
    velocity = (TARGET + np.array([0.0, 0.02, 0.0]) - HELD_AT) / 1.5  # 2 cm off centre, a little fast
    state, events = play(velocity)
    assert state.stage == COMPLETED and state.attempts == 0
    got = KIND.measured(state.record)
    assert abs(got["send_error_m"] - closest_approach(velocity)) < 1e-9
    assert abs(got["release_speed_error"] - speed_error(velocity)) < 1e-9
    assert 0.015 < got["send_error_m"] < 0.02 and got["release_speed_error"] > 0  # aimed 2 cm off, on a slant
    stages = [e.data["stage"] for e in events if e.kind == "stage"]
    assert stages == [PICK_UP, CARRY, DRIFT]
    completed = next(e for e in events if e.kind == "completed")
    entry_s = np.roots([velocity @ velocity, 2 * (HELD_AT - TARGET) @ velocity,
                        (HELD_AT - TARGET) @ (HELD_AT - TARGET) - RADIUS**2]).real.min()
    assert LET_GO + entry_s <= completed.t < LET_GO + entry_s + 1 / RATE + 1e-9  # the first frame inside


def test_a_release_beside_the_target_misses_by_its_closest_approach_and_times_out():
    velocity = (TARGET + np.array([0.0, 0.1, 0.0]) - HELD_AT) / 2.0  # aimed 10 cm beside the centre
    state, events = play(velocity)
    assert state.stage == TIMEOUT and state.attempts == 1
    assert [e.kind for e in events].count("miss") == 1
    got = KIND.measured(state.record)
    assert abs(got["send_error_m"] - closest_approach(velocity)) < 1e-9
    assert got["send_error_m"] > RADIUS
    assert abs(got["release_speed_error"] - speed_error(velocity)) < 1e-9


def test_a_release_away_from_the_target_misses_at_once():
    velocity = np.array([-0.1, 0.0, 0.0])
    state, events = play(velocity)
    assert state.stage == TIMEOUT and state.attempts == 1
    miss = next(e for e in events if e.kind == "miss")
    assert miss.t < LET_GO + GRACE_S + 2 / RATE  # as soon as the hold has ended
    assert abs(KIND.measured(state.record)["send_error_m"] - np.linalg.norm(TARGET - HELD_AT)) < 1e-9  # the release point


def test_a_task_never_released_has_no_send_measures():
    state, _ = play(np.zeros(3), seconds=0.4)
    assert state.stage == CARRY
    assert KIND.measured(state.record) == {"send_error_m": None, "release_speed_error": None}
