"""The pick-and-place task as a state machine over its stages (paper, section 4.3).

``advance(state, observation, rules)`` takes what the world shows at one frame and returns the new
state and the events that happened. It is a pure function, so a live, replayed or simulated
participant drives the same rules, and a test can script the observations. ``displayed(state, t)`` is
what the task shows the participant at that moment: the stage, the current place, its light and
its timer.

Rules (times are the observations' clock; a protocol's ``task`` table sets every number):

- *Holding.* The object is held once the physics reports it grasped for ``grasp_settle_s`` without
  a break; a hold ends once it is not grasped for ``drop_grace_s`` without a break. Shorter breaks
  are the flicker of contacts, not a drop. The hold is taken to have ended when the grasp went.
- *Manipulation* (stage 1): ends when the object is held.
- *Maintenance* (stage 2): the places are visited in order. When the held object's centre comes
  within ``place_radius`` of the current place, the place lights up and its timer starts; leaving
  the place (or losing the hold) puts it out and resets the timer. Once the timer reaches
  ``hold_s`` the place is done and the next one is current.
- *Release* (stage 3): after the last place, the task is completed when the hold ends (released
  or dropped, as the paper allows). Completion time runs from the task's first frame to then.
- *Attempts* are drops: a hold that ends before the release stage. The stage goes back to
  manipulation (pick it up again); places already done stay done. A clean run has 0 attempts.
- *Timeout*: a task still unfinished ``timeout_s`` after its first frame ends as not completed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from .observation import Observation
from .rules import TaskRules

MANIPULATION, MAINTENANCE, RELEASE, COMPLETED, TIMEOUT = "manipulation", "maintenance", "release", "completed", "timeout"
FINAL = (COMPLETED, TIMEOUT)
_EPS = 1e-9


@dataclass(frozen=True)
class TaskEvent:
    t: float
    kind: str
    data: dict


@dataclass(frozen=True)
class TaskState:
    stage: str = MANIPULATION
    started: float | None = None
    ended: float | None = None
    place: int = 0
    """Index of the current place; equals the number of places done."""
    lit_since: float | None = None
    held: bool = False
    grasp_since: float | None = None
    loose_since: float | None = None
    attempts: int = 0
    """Drops so far: holds lost before the release stage (the paper's attempts)."""

    @property
    def finished(self) -> bool:
        return self.stage in FINAL

    @property
    def completion_time(self) -> float | None:
        return self.ended - self.started if self.stage == COMPLETED else None

    def place_timer(self, t: float) -> float:
        """Seconds the current place has been lit at time ``t`` (0 when dark)."""
        return 0.0 if self.lit_since is None else t - self.lit_since


class TaskDisplay(NamedTuple):
    """What the participant sees of the task besides the scene: the place marks and their timer, as
    the paper's toolkit shows them ("the mark is highlighted and the timer is triggered"). A named
    tuple, like the other records made every frame (``Observation``, ``Moment``): immutable, and a
    third of a frozen dataclass's cost to make.

    ``stage`` is one of manipulation, maintenance, release, completed, timeout; ``place`` is the
    index of the current place (the number of places, once all are done); ``lit`` whether it is
    highlighted; ``timer_s`` how long it has been lit.
    """

    stage: str = MANIPULATION
    place: int = 0
    lit: bool = False
    timer_s: float = 0.0


def displayed(state: TaskState, t: float) -> TaskDisplay:
    """What the task shows at time ``t`` in ``state``."""
    return TaskDisplay(state.stage, state.place, state.lit_since is not None, state.place_timer(t))


def advance(state: TaskState, obs: Observation, rules: TaskRules) -> tuple[TaskState, list[TaskEvent]]:
    """One frame of the task (rules in the module docstring)."""
    if state.finished:
        return state, []
    t = obs.t
    events: list[TaskEvent] = []
    if state.started is None:
        state = replace(state, started=t)
        events.append(TaskEvent(t, "stage", {"stage": MANIPULATION}))
    if t - state.started >= rules.timeout_s - _EPS:
        events.append(TaskEvent(t, "timeout", {"stage": state.stage, "place": state.place}))
        return replace(state, stage=TIMEOUT, ended=t, lit_since=None), events

    state = _update_hold(state, obs, rules, events)
    if state.stage == RELEASE and not state.held:
        events.append(TaskEvent(t, "completed", {"time_s": state.loose_since - state.started,
                                                 "attempts": state.attempts}))
        return replace(state, stage=COMPLETED, ended=state.loose_since, loose_since=None), events
    if state.stage == MANIPULATION and state.held:
        state = replace(state, stage=MAINTENANCE)
        events.append(TaskEvent(t, "stage", {"stage": MAINTENANCE, "place": state.place}))
    if state.stage == MAINTENANCE:
        state = _update_place(state, obs, rules, events)
    return state, events


def _update_hold(state: TaskState, obs: Observation, rules: TaskRules, events: list[TaskEvent]) -> TaskState:
    t = obs.t
    if obs.grasped:
        if state.loose_since is not None:
            state = replace(state, loose_since=None)
        if not state.held:
            if state.grasp_since is None:
                state = replace(state, grasp_since=t)
            since = state.grasp_since
            if t - since >= rules.grasp_settle_s - _EPS:
                state = replace(state, held=True, grasp_since=None)
                events.append(TaskEvent(t, "hold", {"since": since}))
        return state
    if state.grasp_since is not None:
        state = replace(state, grasp_since=None)
    if not state.held:
        return state
    if state.loose_since is None:
        state = replace(state, loose_since=t)
    since = state.loose_since
    if t - since < rules.drop_grace_s - _EPS:
        return state
    state = replace(state, held=False)
    if state.stage == RELEASE:
        events.append(TaskEvent(t, "release", {"since": since}))
        return state
    if state.lit_since is not None:
        events.append(TaskEvent(t, "place_dark", {"place": state.place, "lit_s": t - state.lit_since}))
    events.append(TaskEvent(t, "drop", {"since": since, "stage": state.stage, "place": state.place,
                                        "attempts": state.attempts + 1}))
    if state.stage == MAINTENANCE:
        events.append(TaskEvent(t, "stage", {"stage": MANIPULATION, "place": state.place}))
    return replace(state, stage=MANIPULATION, attempts=state.attempts + 1, lit_since=None, loose_since=None)


def _update_place(state: TaskState, obs: Observation, rules: TaskRules, events: list[TaskEvent]) -> TaskState:
    t = obs.t
    offset = np.asarray(obs.position) - np.asarray(rules.places[state.place])
    inside = math.sqrt(offset.dot(offset)) <= rules.place_radius  # np.linalg.norm's arithmetic, without its checks
    if not (inside and state.held):
        if state.lit_since is not None:
            events.append(TaskEvent(t, "place_dark", {"place": state.place, "lit_s": t - state.lit_since}))
            state = replace(state, lit_since=None)
        return state
    if state.lit_since is None:
        events.append(TaskEvent(t, "place_lit", {"place": state.place}))
        return replace(state, lit_since=t)
    if t - state.lit_since < rules.hold_s - _EPS:
        return state
    events.append(TaskEvent(t, "place_done", {"place": state.place, "lit_s": t - state.lit_since}))
    state = replace(state, place=state.place + 1, lit_since=None)
    if state.place == len(rules.places):
        events.append(TaskEvent(t, "stage", {"stage": RELEASE}))
        state = replace(state, stage=RELEASE)
    return state
