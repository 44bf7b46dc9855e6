"""The catch as a state machine: a launched object, drifting at the participant's hand zone, caught.

``advance(state, observation, rules)`` takes what the world shows at one frame and returns the new
state and the events that happened, as ``microg.task.stages`` does for the pick-and-place; the
numbers are ``rules.catch`` (a protocol's ``[task.catch]``) and the task's limits.

Rules (times are the observations' clock):

- *The launch.* The task's world starts the object at the task's start moving at ``launch_speed``
  along the launch's direction and turning at ``spin`` (``microg.study.Protocol.start_motion``);
  an object that leaves the workspace while not held goes back and is launched again (``respawn``).
- *Holding* as in every task (``microg.task.holding``: ``grasp_settle_s``, ``drop_grace_s``).
- *Approach* (the first stage): ends when the object is held; the *catch* stage runs from when its
  grasp began. A hold that ends in the catch stage goes back to approach.
- *Completed* once the object has been held ``hold_s`` in the catch stage. **Completion time**
  runs from the task's first frame to then; **time to catch** to when that hold's grasp began.
- *Attempts* are drops: touches that did not hold. A touch begins when a phalanx touches the
  object (or it is grasped) and ends once nothing has touched it for ``drop_grace_s``; a touch
  that ends before the task is completed is a drop.
- *Timeout*: a task still unfinished ``timeout_s`` after its first frame ends as not completed
  (the object was never caught).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .holding import EPS, Holding, Placeless, hold
from .observation import Observation
from .rules import TaskRules
from .stages import COMPLETED, TIMEOUT, TaskDisplay, TaskEvent

APPROACH, CATCH = "approach", "catch"
STAGES = (APPROACH, CATCH, COMPLETED, TIMEOUT)


class _CatchFields(NamedTuple):
    stage: str = APPROACH
    started: float | None = None
    ended: float | None = None
    holding: Holding = Holding()
    caught_since: float | None = None
    """When the grasp of the current hold began (None outside the catch stage)."""
    touched: bool = False
    """A touch is going on."""
    untouched_since: float | None = None
    attempts: int = 0
    """Drops so far: touches that did not hold."""
    time_to_catch: float | None = None
    """s from the first frame to the grasp that made the catch (None unless completed)."""


class CatchState(Placeless, _CatchFields):
    """A catch's state: its stage, its hold, its touches and drops."""

    __slots__ = ()


def advance(state: CatchState, obs: Observation, rules: TaskRules) -> tuple[CatchState, list[TaskEvent]]:
    """One frame of the catch (rules in the module docstring)."""
    if state.finished:
        return state, []
    t, events = float(obs.t), []
    if state.started is None:
        state = state._replace(started=t)
        events.append(TaskEvent(t, "stage", {"stage": APPROACH}))
    if t - state.started >= rules.timeout_s - EPS:
        events.append(TaskEvent(t, "timeout", {"stage": state.stage}))
        return state._replace(stage=TIMEOUT, ended=t), events
    state = _touch(state, obs, rules, events)
    holding, change = hold(state.holding, t, bool(obs.grasped), rules)
    state = state._replace(holding=holding)
    if change.began is not None:
        events.append(TaskEvent(t, "hold", {"since": change.began}))
        events.append(TaskEvent(t, "stage", {"stage": CATCH}))
        state = state._replace(stage=CATCH, caught_since=change.began)
    elif change.ended is not None and state.stage == CATCH:
        events.append(TaskEvent(t, "stage", {"stage": APPROACH}))
        state = state._replace(stage=APPROACH, caught_since=None)
    if state.stage == CATCH and t - state.caught_since >= rules.catch.hold_s - EPS:
        caught = state.caught_since - state.started
        events.append(TaskEvent(t, "completed", {"time_s": t - state.started, "time_to_catch_s": caught,
                                                 "attempts": state.attempts}))
        state = state._replace(stage=COMPLETED, ended=t, time_to_catch=caught)
    return state, events


def _touch(state: CatchState, obs: Observation, rules: TaskRules, events: list[TaskEvent]) -> CatchState:
    """The touch after a frame: begun on a contact, ended (a drop) after ``drop_grace_s`` without one."""
    contact = bool(obs.grasped) or state.held or (obs.touching is not None and bool(np.any(obs.touching)))
    if contact:
        return state._replace(touched=True, untouched_since=None)
    if not state.touched:
        return state
    t = float(obs.t)
    since = t if state.untouched_since is None else state.untouched_since
    if t - since < rules.drop_grace_s - EPS:
        return state._replace(untouched_since=since)
    attempts = state.attempts + 1
    events.append(TaskEvent(t, "drop", {"since": since, "stage": state.stage, "attempts": attempts}))
    return state._replace(touched=False, untouched_since=None, attempts=attempts)


def displayed(state: CatchState, t: float) -> TaskDisplay:
    """What the catch shows at time ``t``: its stage (no places)."""
    return TaskDisplay(state.stage)


def measures(state: CatchState) -> dict:
    """The catch's own measures of a finished task (``time_to_catch_s``: None unless caught)."""
    return {"time_to_catch_s": state.time_to_catch}
