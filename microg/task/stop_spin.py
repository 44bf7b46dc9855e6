"""The stop of a spin as a state machine: an object floating and turning, brought to rest.

``advance(state, observation, rules)`` takes what the world shows at one frame and returns the new
state and the events that happened, as ``microg.task.stages`` does for the pick-and-place; the
numbers are ``rules.stop_spin`` (a protocol's ``[task.stop_spin]``) and the task's limits.

Rules (times are the observations' clock; omega is the object's angular velocity):

- *The spin.* The task's world starts the object at the task's start turning at ``spin_rate``
  about ``spin_axis``, an axis of the object's own frame (``microg.study.Protocol.start_motion``).
- *Holding* as in every task (``microg.task.holding``: ``grasp_settle_s``, ``drop_grace_s``).
- *Spinning* (the first stage) until the object is *at rest*: |omega| < ``rest_omega`` while it is
  held or its centre moves slower than ``rest_speed``. Then *resting*; leaving the rest goes back
  to spinning.
- *Completed* once the object has been at rest ``hold_s``. **Completion time** runs from the task's
  first frame to then; **time to rest** to when that rest began.
- *Flipped*: the object's spin axis, in the object's own frame, turned more than 90 degrees while
  it turned freely at ``rest_omega`` or faster (the intermediate-axis flip), from the axis it
  turned about when that free spell began (the first spell's: ``spin_axis``, as the task starts
  it). It turns freely while nothing touches it at the frame's end and its centre's velocity
  changes less than ``FREE_DV`` from the frame before (a touch within the frame, over by its end,
  changes it; a falling object is never free, so flips are judged in weightlessness). So a grip
  that brakes the spin and makes it turn back, or a touch that knocks it into another spin, is no
  flip.
- *Attempts* are drops: holds that ended before the task was completed.
- *Timeout*: a task still unfinished ``timeout_s`` after its first frame ends as not completed
  (the object never came to rest).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from microg.sim.rotation import quat_to_matrix

from .holding import EPS, Holding, Placeless, hold
from .observation import Observation
from .rules import TaskRules
from .stages import COMPLETED, TIMEOUT, TaskDisplay, TaskEvent

SPINNING, RESTING = "spinning", "resting"
STAGES = (SPINNING, RESTING, COMPLETED, TIMEOUT)
FREE_DV = 1e-4
"""m/s: an object whose centre's velocity changed more than this from one frame to the next was
touched (a free object in weightlessness keeps it to round-off)."""


class _StopSpinFields(NamedTuple):
    stage: str = SPINNING
    started: float | None = None
    ended: float | None = None
    holding: Holding = Holding()
    rest_since: float | None = None
    """When the current rest began (None while spinning)."""
    flipped: bool = False
    free_axis: tuple[float, float, float] | None = None
    """The spin axis in the object's frame when the current free spell began (None: not free)."""
    last_velocity: tuple[float, float, float] | None = None
    """The object's centre's velocity at the frame before (None at the first frame, which shows the
    object moving as the task started it)."""
    attempts: int = 0
    """Drops so far: holds lost before the task was completed."""
    time_to_rest: float | None = None
    """s from the first frame to the rest that completed the task (None unless completed)."""


class StopSpinState(Placeless, _StopSpinFields):
    """A stop of a spin's state: its stage, its hold, its rest and whether it flipped."""

    __slots__ = ()


def advance(state: StopSpinState, obs: Observation, rules: TaskRules) -> tuple[StopSpinState, list[TaskEvent]]:
    """One frame of the stop of a spin (rules in the module docstring)."""
    if state.finished:
        return state, []
    t, events, spin = float(obs.t), [], rules.stop_spin
    if state.started is None:
        state = state._replace(started=t)
        events.append(TaskEvent(t, "stage", {"stage": SPINNING}))
    if t - state.started >= rules.timeout_s - EPS:
        events.append(TaskEvent(t, "timeout", {"stage": state.stage}))
        return state._replace(stage=TIMEOUT, ended=t), events
    holding, change = hold(state.holding, t, bool(obs.grasped), rules)
    state = state._replace(holding=holding)
    if change.began is not None:
        events.append(TaskEvent(t, "hold", {"since": change.began}))
    elif change.ended is not None:
        attempts = state.attempts + 1
        events.append(TaskEvent(t, "drop", {"since": change.ended, "stage": state.stage, "attempts": attempts}))
        state = state._replace(attempts=attempts)
    omega = np.asarray(obs.angular_velocity, dtype=np.float64)
    rate = float(np.linalg.norm(omega))
    velocity = tuple(float(v) for v in obs.velocity)
    steady = state.last_velocity is None or float(np.linalg.norm(np.subtract(velocity, state.last_velocity))) < FREE_DV
    free = steady and not obs.grasped and (obs.touching is None or not np.any(obs.touching))
    state = state._replace(last_velocity=velocity)
    if not free or rate < spin.rest_omega:
        state = state._replace(free_axis=None)
    elif not state.flipped:
        own = quat_to_matrix(np.asarray(obs.orientation, dtype=np.float64)).T @ omega
        if state.free_axis is None:
            state = state._replace(free_axis=tuple(float(w) for w in own))
        if float(own @ np.asarray(state.free_axis)) < 0.0:
            events.append(TaskEvent(t, "flip", {"omega": [float(w) for w in own]}))
            state = state._replace(flipped=True)
    at_rest = rate < spin.rest_omega and (state.held or float(np.linalg.norm(obs.velocity)) < spin.rest_speed)
    if state.stage == SPINNING and at_rest:
        events.append(TaskEvent(t, "stage", {"stage": RESTING}))
        state = state._replace(stage=RESTING, rest_since=t)
    elif state.stage == RESTING and not at_rest:
        events.append(TaskEvent(t, "stage", {"stage": SPINNING}))
        state = state._replace(stage=SPINNING, rest_since=None)
    if state.stage == RESTING and t - state.rest_since >= spin.hold_s - EPS:
        rested = state.rest_since - state.started
        events.append(TaskEvent(t, "completed", {"time_s": t - state.started, "time_to_rest_s": rested,
                                                 "flipped": state.flipped, "attempts": state.attempts}))
        state = state._replace(stage=COMPLETED, ended=t, time_to_rest=rested)
    return state, events


def displayed(state: StopSpinState, t: float) -> TaskDisplay:
    """What the stop of a spin shows at time ``t``: its stage (no places)."""
    return TaskDisplay(state.stage)


def measures(state: StopSpinState) -> dict:
    """The stop of a spin's own measures of a finished task (``time_to_rest_s``: None unless completed)."""
    return {"time_to_rest_s": state.time_to_rest, "flipped": state.flipped}
