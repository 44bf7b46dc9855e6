"""The pick-and-place task as a state machine over its stages (paper, section 4.3).

``advance(state, observation, rules)`` takes what the world shows at one frame and returns the new
state and the events that happened. It is a pure function, so a live, replayed or simulated
participant drives the same rules, and a test can script the observations. The rules themselves
are compiled (``judge``, on plain records: ``TASK`` for the state, ``RULES`` for the numbers, an
``EVENT`` array for what happened), so that an in-silico study judges many tasks in compiled code
with the same code; ``advance`` is ``judge`` for Python's records. ``displayed(state, t)`` is
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
from typing import NamedTuple

import numpy as np
from numba import njit

from .observation import Observation
from .rules import TaskRules

MANIPULATION, MAINTENANCE, RELEASE, COMPLETED, TIMEOUT = "manipulation", "maintenance", "release", "completed", "timeout"
STAGES = (MANIPULATION, MAINTENANCE, RELEASE, COMPLETED, TIMEOUT)
"""The stages in order: a ``TASK`` record's ``stage`` is an index here."""
FINAL = (COMPLETED, TIMEOUT)
_MANIPULATION, _MAINTENANCE, _RELEASE, _COMPLETED, _TIMEOUT = range(len(STAGES))
_EPS = 1e-9
MAX_PLACES = 8
"""The most places a task may have."""
MAX_EVENTS = 8
"""The most events one frame can make (a drop in the maintenance stage makes three)."""
EVENTS = ("stage", "timeout", "hold", "completed", "release", "place_dark", "drop", "place_lit", "place_done")
(_STAGE, _TIMEOUT_EVENT, _HOLD, _COMPLETED_EVENT, _RELEASE_EVENT, _PLACE_DARK, _DROP, _PLACE_LIT,
 _PLACE_DONE) = range(len(EVENTS))

TASK = np.dtype([("stage", "i8"), ("started", "f8"), ("ended", "f8"), ("place", "i8"), ("lit_since", "f8"),
                 ("held", "?"), ("grasp_since", "f8"), ("loose_since", "f8"), ("attempts", "i8")], align=True)
"""The task's state as the compiled rules keep it (``TaskState``'s fields; NaN for None)."""
RULES = np.dtype([("places", "f8", (MAX_PLACES, 3)), ("n_places", "i8"), ("place_radius", "f8"), ("hold_s", "f8"),
                  ("timeout_s", "f8"), ("grasp_settle_s", "f8"), ("drop_grace_s", "f8"),
                  ("workspace_min", "f8", (3,)), ("workspace_max", "f8", (3,))], align=True)
"""The numbers the rules read (``TaskRules``)."""
EVENT = np.dtype([("kind", "i8"), ("t", "f8"), ("stage", "i8"), ("place", "i8"), ("since", "f8"), ("value", "f8"),
                  ("attempts", "i8")], align=True)
"""One event: its kind (an index into ``EVENTS``), its time, and the numbers its kind carries."""


class TaskEvent(NamedTuple):
    t: float
    kind: str
    data: dict


class TaskState(NamedTuple):
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


# -- the rules, compiled --------------------------------------------------------------------

@njit(cache=True)
def judge(task, rules, t, grasped, position, events):
    """One frame of the task (rules in the module docstring): the object's ``position`` and
    whether it is ``grasped`` at time ``t``; updates ``task`` and writes the frame's events into
    ``events``, returning how many."""
    if task.stage >= _COMPLETED:
        return 0
    n = 0
    if math.isnan(task.started):
        task.started = t
        n = _event(events, n, _STAGE, t, _MANIPULATION, -1, math.nan, math.nan, -1)
    if t - task.started >= rules.timeout_s - _EPS:
        n = _event(events, n, _TIMEOUT_EVENT, t, task.stage, task.place, math.nan, math.nan, -1)
        task.stage, task.ended, task.lit_since = _TIMEOUT, t, math.nan
        return n
    n = _update_hold(task, rules, t, grasped, events, n)
    if task.stage == _RELEASE and not task.held:
        n = _event(events, n, _COMPLETED_EVENT, t, -1, -1, math.nan, task.loose_since - task.started, task.attempts)
        task.stage, task.ended, task.loose_since = _COMPLETED, task.loose_since, math.nan
        return n
    if task.stage == _MANIPULATION and task.held:
        task.stage = _MAINTENANCE
        n = _event(events, n, _STAGE, t, _MAINTENANCE, task.place, math.nan, math.nan, -1)
    if task.stage == _MAINTENANCE:
        n = _update_place(task, rules, t, position, events, n)
    return n


@njit(cache=True)
def _event(events, n, kind, t, stage, place, since, value, attempts):
    e = events[n]
    e.kind, e.t, e.stage, e.place, e.since, e.value, e.attempts = kind, t, stage, place, since, value, attempts
    return n + 1


@njit(cache=True)
def _update_hold(task, rules, t, grasped, events, n):
    if grasped:
        task.loose_since = math.nan
        if not task.held:
            if math.isnan(task.grasp_since):
                task.grasp_since = t
            since = task.grasp_since
            if t - since >= rules.grasp_settle_s - _EPS:
                task.held, task.grasp_since = True, math.nan
                n = _event(events, n, _HOLD, t, -1, -1, since, math.nan, -1)
        return n
    task.grasp_since = math.nan
    if not task.held:
        return n
    if math.isnan(task.loose_since):
        task.loose_since = t
    since = task.loose_since
    if t - since < rules.drop_grace_s - _EPS:
        return n
    task.held = False
    if task.stage == _RELEASE:
        return _event(events, n, _RELEASE_EVENT, t, -1, -1, since, math.nan, -1)
    if not math.isnan(task.lit_since):
        n = _event(events, n, _PLACE_DARK, t, -1, task.place, math.nan, t - task.lit_since, -1)
    n = _event(events, n, _DROP, t, task.stage, task.place, since, math.nan, task.attempts + 1)
    if task.stage == _MAINTENANCE:
        n = _event(events, n, _STAGE, t, _MANIPULATION, task.place, math.nan, math.nan, -1)
    task.stage, task.attempts, task.lit_since, task.loose_since = _MANIPULATION, task.attempts + 1, math.nan, math.nan
    return n


@njit(cache=True)
def _update_place(task, rules, t, position, events, n):
    x = position[0] - rules.places[task.place, 0]
    y = position[1] - rules.places[task.place, 1]
    z = position[2] - rules.places[task.place, 2]
    inside = math.sqrt(x * x + y * y + z * z) <= rules.place_radius
    if not (inside and task.held):
        if not math.isnan(task.lit_since):
            n = _event(events, n, _PLACE_DARK, t, -1, task.place, math.nan, t - task.lit_since, -1)
            task.lit_since = math.nan
        return n
    if math.isnan(task.lit_since):
        task.lit_since = t
        return _event(events, n, _PLACE_LIT, t, -1, task.place, math.nan, math.nan, -1)
    if t - task.lit_since < rules.hold_s - _EPS:
        return n
    n = _event(events, n, _PLACE_DONE, t, -1, task.place, math.nan, t - task.lit_since, -1)
    task.place, task.lit_since = task.place + 1, math.nan
    if task.place == rules.n_places:
        n = _event(events, n, _STAGE, t, _RELEASE, -1, math.nan, math.nan, -1)
        task.stage = _RELEASE
    return n


# -- the rules for Python's records ---------------------------------------------------------

def rules_record(rules: TaskRules, out=None):
    """``rules`` as a ``RULES`` record (into ``out`` when given)."""
    if len(rules.places) > MAX_PLACES:
        raise ValueError(f"task.places has {len(rules.places)} places: a task has at most {MAX_PLACES}")
    out = np.zeros(1, RULES)[0] if out is None else out
    out["places"][:len(rules.places)] = rules.places
    out["n_places"], out["place_radius"], out["hold_s"] = len(rules.places), rules.place_radius, rules.hold_s
    out["timeout_s"], out["grasp_settle_s"], out["drop_grace_s"] = rules.timeout_s, rules.grasp_settle_s, \
        rules.drop_grace_s
    out["workspace_min"], out["workspace_max"] = rules.workspace_min, rules.workspace_max
    return out


def rules_of(rules: TaskRules):
    """``rules`` as its ``RULES`` record, made once per ``TaskRules``."""
    cached = _RULES.get(id(rules))
    if cached is None or cached[0] is not rules:
        cached = _RULES[id(rules)] = (rules, rules_record(rules))
    return cached[1]


_RULES: dict[int, tuple[TaskRules, np.void]] = {}
"""Each ``TaskRules`` as its record, made once (a task's rules are judged every frame)."""


def _none(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


def _nan(value: float | None) -> float:
    return math.nan if value is None else value


def state_of(task) -> TaskState:
    """A ``TASK`` record as a ``TaskState``."""
    return TaskState(STAGES[int(task["stage"])], _none(task["started"]), _none(task["ended"]), int(task["place"]),
                     _none(task["lit_since"]), bool(task["held"]), _none(task["grasp_since"]),
                     _none(task["loose_since"]), int(task["attempts"]))


def event_of(event) -> TaskEvent:
    """An ``EVENT`` record as a ``TaskEvent`` (its data as the task's log has it)."""
    kind, t = EVENTS[int(event["kind"])], float(event["t"])
    stage, place, since, value = int(event["stage"]), int(event["place"]), float(event["since"]), float(event["value"])
    if kind == "stage":
        data = {"stage": STAGES[stage]} if place < 0 else {"stage": STAGES[stage], "place": place}
    elif kind == "timeout":
        data = {"stage": STAGES[stage], "place": place}
    elif kind in ("hold", "release"):
        data = {"since": since}
    elif kind == "completed":
        data = {"time_s": value, "attempts": int(event["attempts"])}
    elif kind in ("place_dark", "place_done"):
        data = {"place": place, "lit_s": value}
    elif kind == "drop":
        data = {"since": since, "stage": STAGES[stage], "place": place, "attempts": int(event["attempts"])}
    else:
        data = {"place": place}
    return TaskEvent(t, kind, data)


def advance(state: TaskState, obs: Observation, rules: TaskRules) -> tuple[TaskState, list[TaskEvent]]:
    """One frame of the task (rules in the module docstring): ``judge`` on ``state`` as a record."""
    if state.stage in FINAL:
        return state, []
    task, events = np.zeros(1, TASK)[0], np.zeros(MAX_EVENTS, EVENT)
    task["stage"], task["started"], task["ended"], task["place"] = STAGES.index(state.stage), _nan(state.started), \
        _nan(state.ended), state.place
    task["lit_since"], task["held"], task["grasp_since"] = _nan(state.lit_since), state.held, _nan(state.grasp_since)
    task["loose_since"], task["attempts"] = _nan(state.loose_since), state.attempts
    position = np.asarray(obs.position, dtype=np.float64)
    n = judge(task, rules_of(rules), float(obs.t), bool(obs.grasped), position, events)
    return state_of(task), [event_of(e) for e in events[:n]]
