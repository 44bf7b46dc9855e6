"""The stop of a spin on scripted observations: a spin slowed by a grip's steady torque, a free flip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from microg.task.observation import Observation
from microg.task.rules import StopSpinRules, TaskRules
from microg.task.stages import COMPLETED, TIMEOUT
from microg.task.stop_spin import RESTING, SPINNING, StopSpinState, advance, measures

RATE = 100.0
SPIN, REST_OMEGA, HOLD_S = 4.0, 0.3, 1.0
GRIP_AT, SLOWING = 0.5, 3.0
"""The hand grasps at GRIP_AT (s) and its steady torque slows the spin by SLOWING rad/s^2."""
RULES = TaskRules(start=(0.0, 0.2, 0.0), start_orientation=(1.0, 0.0, 0.0, 0.0), places=((0.0, 0.3, 0.0),),
                  place_radius=0.02, hold_s=3.0, timeout_s=5.0, grasp_settle_s=0.1, drop_grace_s=0.25,
                  workspace_min=(-1.0, -1.0, -1.0), workspace_max=(1.0, 1.0, 1.0), kind="stop_spin",
                  stop_spin=StopSpinRules(spin_axis=(0.0, 1.0, 0.0), spin_rate=SPIN, rest_omega=REST_OMEGA,
                                          rest_speed=0.02, hold_s=HOLD_S))


def about_y(angle: float) -> np.ndarray:
    return np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])


def about_x(angle: float) -> np.ndarray:
    return np.array([math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0])


def play(observe, seconds: float = 6.0):
    """Feed ``observe(t) -> Observation`` at RATE for ``seconds``; the final state and the events."""
    state, events = StopSpinState(), []
    for k in range(round(seconds * RATE)):
        state, new = advance(state, observe(k / RATE), RULES)
        events += new
    return state, events


def slowed(t: float, release: bool = False, drift: float = 0.0) -> Observation:
    """Spinning at SPIN about its own (and the world's) y axis, grasped at GRIP_AT and slowed by SLOWING
    to a stop; ``release``: let go at the stop, leaving it drifting at ``drift`` m/s."""
    omega = max(0.0, SPIN - SLOWING * max(0.0, t - GRIP_AT))
    stopped = omega == 0.0
    grasped = t >= GRIP_AT and not (release and stopped)
    return Observation(t, grasped, (0.0, 0.2, 0.0), about_y(SPIN * t), angular_velocity=np.array([0.0, omega, 0.0]),
                       velocity=np.array([drift if stopped else 0.0, 0.0, 0.0]))


def test_a_grip_that_slows_the_spin_brings_it_to_rest_when_the_slowing_says():
    state, events = play(slowed)
    # |omega| = SPIN - SLOWING (t - GRIP_AT) falls below REST_OMEGA after (SPIN - REST_OMEGA) / SLOWING
    due = GRIP_AT + (SPIN - REST_OMEGA) / SLOWING
    rest = math.floor(due * RATE + 1e-9) / RATE + 1 / RATE  # the first frame after it
    assert state.stage == COMPLETED and not state.flipped and state.attempts == 0
    assert state.time_to_rest == pytest.approx(rest, abs=1e-9)
    assert state.completion_time == pytest.approx(rest + HOLD_S, abs=1e-9)
    assert measures(state) == {"time_to_rest_s": state.time_to_rest, "flipped": False}
    assert [e.data["stage"] for e in events if e.kind == "stage"] == [SPINNING, RESTING]


def test_a_stopped_object_let_go_at_rest_in_its_place_stays_stopped():
    state, _ = play(lambda t: slowed(t, release=True, drift=0.005))
    assert state.stage == COMPLETED and state.attempts == 1  # the release before the end is a drop


def test_a_stopped_object_let_go_drifting_is_not_at_rest_and_the_task_times_out():
    state, events = play(lambda t: slowed(t, release=True, drift=0.05))
    assert state.stage == TIMEOUT and state.time_to_rest is None
    assert measures(state)["time_to_rest_s"] is None
    assert [e.data["stage"] for e in events if e.kind == "stage"][-1] == SPINNING


FLIP_S = 2.0
"""The free object turns half a turn about its x axis in this time while its spin stays in the world."""


def flipping(t: float) -> Observation:
    """A free tumble: the spin stays SPIN about the world's y axis while the object turns over about
    x, so its own spin axis goes from +y to -y: the intermediate-axis flip."""
    turned = math.pi * min(t / FLIP_S, 1.0)
    return Observation(t, False, (0.0, 0.2, 0.0), about_x(turned), angular_velocity=np.array([0.0, SPIN, 0.0]))


def test_an_object_that_turns_over_flips_and_never_rests():
    state, events = play(flipping)
    assert state.stage == TIMEOUT and state.flipped and measures(state)["flipped"] is True
    # its own spin axis is R^T y: at an angle equal to the turn; past 90 degrees at FLIP_S / 2
    flip = next(e for e in events if e.kind == "flip")
    assert flip.t == pytest.approx(math.floor(FLIP_S / 2 * RATE + 1e-9) / RATE + 1 / RATE, abs=1e-9)


def test_a_grip_that_makes_the_spin_turn_back_is_no_flip():
    def braked(t):  # the grip overshoots: the spin reverses to -1 rad/s while held
        omega = SPIN if t < GRIP_AT else -1.0
        return Observation(t, t >= GRIP_AT, (0.0, 0.2, 0.0), about_y(0.0), angular_velocity=np.array([0.0, omega, 0.0]))

    state, _ = play(braked)
    assert not state.flipped


def test_a_spin_that_keeps_its_axis_has_not_flipped():
    state, _ = play(lambda t: Observation(t, False, (0.0, 0.2, 0.0), about_y(SPIN * t),
                                          angular_velocity=np.array([0.0, SPIN, 0.0])))
    assert state.stage == TIMEOUT and not state.flipped
