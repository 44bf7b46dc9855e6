"""The handover as a state machine: the object taken by one hand, passed to the other, and put in a
place zone with it.

``advance(state, observation, rules)`` takes what the world shows at one frame and returns the new
state and the events that happened, as ``microg.task.stages`` does for the pick-and-place; the
numbers are ``rules.handover`` (a protocol's ``[task.handover]``) and the task's limits. It needs
both hands tracked: the observation says which hands hold the object (``grasped_by``).

Rules (times are the observations' clock, places the tracker frame):

- *Holding* as in every task (``microg.task.holding``: ``grasp_settle_s``, ``drop_grace_s``), each
  hand's on its own.
- *Take* (the first stage): ends when the ``first_hand`` holds the object; then *pass*.
- *Pass*: ends when the other hand holds the object and the first hand's hold has ended (the
  first hand let go of it): the handover; then *place*. Its **transfer time**
  (``transfer_time_s``) runs from the other hand's hold beginning to the first hand's ending; it is
  negative when the first hand's grasp ended before the other's began, within ``drop_grace_s`` (a
  toss the holds' grace joins).
- *Place*: completed once the other hand alone has held the object inside the place zone (a sphere
  of ``radius`` about ``place``) for ``hold_s``. **Completion time** runs from the task's first
  frame to then.
- *A drop*: the object held by neither hand (a hold ended with no other hold on). It counts as an
  attempt and the task goes back to *take*.
- **Both held** (``both_held_s``): the time both hands held the object, over the whole task (the
  sum of the frame intervals that began with both holds on).
- *Timeout*: a task still unfinished ``timeout_s`` after its first frame ends as not completed.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from microg.skeleton import SIDES

from .holding import EPS, Holding, Placeless, hold
from .observation import Observation
from .rules import TaskRules
from .stages import COMPLETED, TIMEOUT, TaskDisplay, TaskEvent

TAKE, PASS, PLACE = "take", "pass", "place"
STAGES = (TAKE, PASS, PLACE, COMPLETED, TIMEOUT)


class _HandoverFields(NamedTuple):
    stage: str = TAKE
    started: float | None = None
    ended: float | None = None
    hands: tuple[Holding, Holding] = (Holding(), Holding())
    """Each hand's hold (``SIDES`` order)."""
    passed_since: float | None = None
    """When the other hand's hold began during the pass (None before)."""
    in_place_since: float | None = None
    """When the other hand, alone, last came to hold the object inside the place zone."""
    last_t: float | None = None
    """The frame before's time."""
    both_held: float = 0.0
    attempts: int = 0
    """Drops."""
    transfer_time: float | None = None
    """s: the last handover's (None before one)."""


class HandoverState(Placeless, _HandoverFields):
    """A handover's state: its stage, each hand's hold, the pass and the time both hands held it."""

    __slots__ = ()

    @property
    def holding(self) -> Holding:
        """The object held by either hand (what the session and the frame log read as held)."""
        return Holding(any(h.held for h in self.hands))


def advance(state: HandoverState, obs: Observation, rules: TaskRules) -> tuple[HandoverState, list[TaskEvent]]:
    """One frame of the handover (rules in the module docstring)."""
    if state.finished:
        return state, []
    t, events, handover = float(obs.t), [], rules.handover
    first = SIDES.index(handover.first_hand)
    second = 1 - first
    if state.started is None:
        state = state._replace(started=t)
        events.append(TaskEvent(t, "stage", {"stage": TAKE}))
    if all(h.held for h in state.hands):  # both held the object over the interval since the frame before
        state = state._replace(both_held=state.both_held + t - state.last_t)
    if t - state.started >= rules.timeout_s - EPS:
        events.append(TaskEvent(t, "timeout", {"stage": state.stage}))
        return state._replace(stage=TIMEOUT, ended=t), events
    by = np.zeros(len(SIDES), dtype=bool) if obs.grasped_by is None else np.asarray(obs.grasped_by, dtype=bool)
    hands, changes = zip(*(hold(h, t, bool(g), rules) for h, g in zip(state.hands, by)))
    state = state._replace(hands=tuple(hands))
    for side, change in enumerate(changes):
        if change.began is not None:
            events.append(TaskEvent(t, "hold", {"since": change.began, "hand": SIDES[side]}))
    if not any(h.held for h in hands) and any(c.ended is not None for c in changes) and state.stage != TAKE:
        attempts = state.attempts + 1
        events.append(TaskEvent(t, "drop", {"stage": state.stage, "attempts": attempts}))
        events.append(TaskEvent(t, "stage", {"stage": TAKE}))
        state = state._replace(stage=TAKE, attempts=attempts, passed_since=None, in_place_since=None)
    if state.stage == TAKE and hands[first].held:
        events.append(TaskEvent(t, "stage", {"stage": PASS}))
        state = state._replace(stage=PASS, passed_since=None)
    if state.stage == PASS:
        if changes[second].ended is not None:
            state = state._replace(passed_since=None)
        if hands[second].held and state.passed_since is None:
            state = state._replace(passed_since=changes[second].began if changes[second].began is not None else t)
        if state.passed_since is not None and changes[first].ended is not None:
            transfer = changes[first].ended - state.passed_since
            events.append(TaskEvent(t, "handover", {"transfer_time_s": transfer}))
            events.append(TaskEvent(t, "stage", {"stage": PLACE}))
            state = state._replace(stage=PLACE, transfer_time=transfer)
    if state.stage == PLACE:
        inside = float(np.linalg.norm(np.subtract(obs.position, handover.place))) <= handover.radius
        alone = hands[second].held and not hands[first].held
        since = (state.in_place_since if state.in_place_since is not None else t) if inside and alone else None
        state = state._replace(in_place_since=since)
        if since is not None and t - since >= handover.hold_s - EPS:
            events.append(TaskEvent(t, "completed", {"time_s": t - state.started, "attempts": state.attempts,
                                                     "transfer_time_s": state.transfer_time,
                                                     "both_held_s": state.both_held}))
            return state._replace(stage=COMPLETED, ended=t), events
    return state._replace(last_t=t), events


def displayed(state: HandoverState, t: float) -> TaskDisplay:
    """What the handover shows at time ``t``: its stage (no places)."""
    return TaskDisplay(state.stage)


def measures(state: HandoverState) -> dict:
    """The handover's own measures of a finished task (``transfer_time_s``: None before a handover)."""
    return {"transfer_time_s": state.transfer_time, "both_held_s": state.both_held}
