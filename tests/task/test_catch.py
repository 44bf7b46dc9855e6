"""The catch on scripted observations: a launched object on its straight line in zero gravity, a still hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from microg.task.observation import Observation
from microg.task.kinds.catch import CatchRules
from microg.task.rules import TaskRules
from microg.task import COMPLETED, KINDS, TIMEOUT

KIND = KINDS["catch"]
APPROACH, CATCH = "approach", "catch"

RATE = 100.0
START = np.array([0.2, 0.2, 0.0])
HAND = np.array([0.0, 0.2, 0.0])
REACH = 0.03
"""m: the still hand's phalanges touch the object once its centre is this close."""
SPEED, HOLD_S, SETTLE_S, GRACE_S = 0.4, 0.8, 0.1, 0.25
DIRECTION = (HAND - START) / np.linalg.norm(HAND - START)
RULES = TaskRules(start=tuple(START), start_orientation=(1.0, 0.0, 0.0, 0.0), places=((0.0, 0.3, 0.0),),
                  place_radius=0.02, hold_s=3.0, timeout_s=5.0, grasp_settle_s=SETTLE_S, drop_grace_s=GRACE_S,
                  workspace_min=(-1.0, -1.0, -1.0), workspace_max=(1.0, 1.0, 1.0), kind="catch",
                  tables=(("catch", CatchRules(launch_speed=SPEED, direction=tuple(DIRECTION), spin=(0.0, 0.0, 0.0),
                                                      hold_s=HOLD_S)),))
TOUCH = np.ones(40, dtype=bool)
NONE = np.zeros(40, dtype=bool)


def arrival() -> float:
    """The first frame's time at which the launched object, at START + SPEED t along DIRECTION, is
    within REACH of the hand: (distance - REACH) / SPEED, on the frames' clock."""
    due = (np.linalg.norm(HAND - START) - REACH) / SPEED
    return math.ceil(due * RATE - 1e-9) / RATE


def play(grip, seconds: float = 6.0):
    """The catch over ``seconds``: the object flies on its line until the hand takes it, then stays
    where it was taken while ``grip(t, since)`` says (touching, grasped), ``since`` the time it
    reached the hand. Returns the final state and the events."""
    state, events, caught_at = KIND.start(), [], None
    for k in range(round(seconds * RATE)):
        t = k / RATE
        position = START + SPEED * DIRECTION * t
        if caught_at is None and np.linalg.norm(position - HAND) <= REACH:
            caught_at = t
        touching, grasped = grip(t, caught_at) if caught_at is not None else (False, False)
        if caught_at is not None and (touching or grasped):
            position = START + SPEED * DIRECTION * caught_at
        velocity = np.zeros(3) if caught_at is not None and (touching or grasped) else SPEED * DIRECTION
        obs = Observation(t, grasped, position, touching=TOUCH if touching else NONE, velocity=velocity)
        state, new = KIND.advance(state, obs, RULES)
        events += new
    return state, events


def test_a_hand_that_closes_on_the_object_as_it_arrives_catches_it_at_the_time_its_path_gives():
    state, events = play(lambda t, since: (True, True))
    assert state.stage == COMPLETED and state.attempts == 0
    assert state.time_to_catch == pytest.approx(arrival(), abs=1e-9)
    assert state.completion_time == pytest.approx(arrival() + HOLD_S, abs=1e-9)
    assert KIND.measured(state.record) == {"time_to_catch_s": state.time_to_catch}
    assert [e.data["stage"] for e in events if e.kind == "stage"] == [APPROACH, CATCH]


def test_a_hand_that_only_touches_never_catches_and_the_touch_is_an_attempt():
    state, events = play(lambda t, since: (t - since < 0.2, False))  # the object bounces off and flies on
    assert state.stage == TIMEOUT and state.completion_time is None and state.attempts == 1
    assert KIND.measured(state.record) == {"time_to_catch_s": None}
    drops = [e for e in events if e.kind == "drop"]
    assert len(drops) == 1 and drops[0].t == pytest.approx(arrival() + 0.2 + GRACE_S, abs=1e-9)


def test_a_hold_shorter_than_hold_s_goes_back_to_approach_and_is_an_attempt_when_the_touch_ends():
    state, events = play(lambda t, since: ((t - since < 0.5,) * 2))
    assert state.stage == TIMEOUT and state.attempts == 1
    assert [e.data["stage"] for e in events if e.kind == "stage"] == [APPROACH, CATCH, APPROACH]


def test_contact_flicker_shorter_than_the_grace_is_one_touch():
    gap = GRACE_S / 2  # the fingers lose the object for half the grace, then close on it
    state, _ = play(lambda t, since: ((not (0.05 <= t - since < 0.05 + gap),) * 2))
    assert state.stage == COMPLETED and state.attempts == 0
