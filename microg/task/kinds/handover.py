"""The handover: the object taken by one hand, passed to the other, and put in a place zone with it.

Rules (times are the observations' clock, places the tracker frame; the numbers are the protocol's
``[task.handover]``). It needs both hands tracked: the observation says which hands hold the object
(``grasped_by``).

- *Holding* as in every task (``microg.task.kind.hold``: ``grasp_settle_s``, ``drop_grace_s``), each
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

import math
from dataclasses import dataclass

from numba import njit

from microg.skeleton import SIDES
from microg.task.kind import (COUNT, EPS, FINAL, HAND, MAX_DISTANCE, NUMBER, NUMBER_OR_NONE, STAGE, Aims, EventSpec,
                              Kind, Measure, Play, Stage, View, emit, hold, inside, start_and_time_out,
                              before_timeout)

STAGES = (Stage("take", "Pick up the object with your {first} hand", loose=True),
          Stage("pass", "Pass it to your {other} hand"), Stage("place", "Hold it in the blue rings with your {other} hand")) + FINAL
_TAKE, _PASS, _PLACE, _COMPLETED, _TIMEOUT = range(len(STAGES))
EVENTS = (EventSpec("stage", (("stage", STAGE),)), EventSpec("timeout", (("stage", STAGE),)),
          EventSpec("hold", (("since", NUMBER), ("hand", HAND))),
          EventSpec("drop", (("stage", STAGE), ("attempts", COUNT))),
          EventSpec("handover", (("transfer_time_s", NUMBER),)),
          EventSpec("completed", (("time_s", NUMBER), ("attempts", COUNT), ("transfer_time_s", NUMBER_OR_NONE),
                                  ("both_held_s", NUMBER))))
_STAGE, _TIMEOUT_EVENT, _HOLD, _DROP, _HANDOVER, _COMPLETED_EVENT = range(len(EVENTS))


@njit(cache=True)
def judge(task, rules, seen, events):
    """One frame of the handover (rules in the module docstring); returns the events written."""
    if task.stage >= _COMPLETED:
        return 0
    t = seen.t
    first, second = rules.first_hand, 1 - rules.first_hand
    if task.hand_held[0] and task.hand_held[1]:  # both held the object over the interval since the frame before
        task.both_held += t - task.last_t
    n, out = start_and_time_out(task, t, rules, events, 0, _STAGE, _TIMEOUT_EVENT, _TIMEOUT)
    if out:
        return n
    began, ended = (math.nan, math.nan), (math.nan, math.nan)
    for side in range(2):
        held, task.hand_grasp_since[side], task.hand_loose_since[side], b, e = hold(
            task.hand_held[side], task.hand_grasp_since[side], task.hand_loose_since[side], t,
            seen.grasped_by[side] != 0, rules)
        task.hand_held[side] = held
        began = (b, began[1]) if side == 0 else (began[0], b)
        ended = (e, ended[1]) if side == 0 else (ended[0], e)
        if not math.isnan(b):
            n = emit(events, n, _HOLD, t, b, side)
    task.held = task.hand_held[0] or task.hand_held[1]
    if not task.held and not (math.isnan(ended[0]) and math.isnan(ended[1])) and task.stage != _TAKE:
        task.attempts += 1
        n = emit(events, n, _DROP, t, task.stage, task.attempts)
        n = emit(events, n, _STAGE, t, _TAKE)
        task.stage, task.passed_since, task.in_place_since = _TAKE, math.nan, math.nan
    if task.stage == _TAKE and task.hand_held[first]:
        n = emit(events, n, _STAGE, t, _PASS)
        task.stage, task.passed_since = _PASS, math.nan
    if task.stage == _PASS:
        if not math.isnan(ended[second]):
            task.passed_since = math.nan
        if task.hand_held[second] and math.isnan(task.passed_since):
            task.passed_since = began[second] if not math.isnan(began[second]) else t
        if not math.isnan(task.passed_since) and not math.isnan(ended[first]):
            transfer = ended[first] - task.passed_since
            n = emit(events, n, _HANDOVER, t, transfer)
            n = emit(events, n, _STAGE, t, _PLACE)
            task.stage, task.transfer_time = _PLACE, transfer
    if task.stage == _PLACE:
        d = math.sqrt((seen.position[0] - rules.place[0]) ** 2 + (seen.position[1] - rules.place[1]) ** 2
                      + (seen.position[2] - rules.place[2]) ** 2)
        if d <= rules.radius and task.hand_held[second] and not task.hand_held[first]:
            if math.isnan(task.in_place_since):
                task.in_place_since = t
            if t - task.in_place_since >= rules.hold_s - EPS:
                n = emit(events, n, _COMPLETED_EVENT, t, t - task.started, task.attempts, task.transfer_time,
                         task.both_held)
                task.stage, task.ended = _COMPLETED, t
                return n
        else:
            task.in_place_since = math.nan
    task.last_t = t
    return n


@dataclass(frozen=True)
class HandoverRules:
    """A handover's numbers (``[task.handover]``): the object taken by the ``first_hand`` (``left`` or
    ``right``), passed to the other hand, and held by that hand alone inside the place zone, a sphere
    of ``radius`` (m) about ``place`` (tracker frame), for ``hold_s`` (s)."""

    first_hand: str
    place: tuple[float, float, float]
    radius: float
    hold_s: float


def read(h, task) -> HandoverRules:
    """``[task.handover]``: the hand that takes the object first (``first_hand``) and the place zone
    the other hand holds it in (``place``, its ``radius``) for ``hold_s``."""
    handover = HandoverRules(first_hand=h.text("first_hand", "right", choices=SIDES), place=h.vector("place"),
                             radius=h.number("radius", unit=" (m)", maximum=MAX_DISTANCE),
                             hold_s=h.number("hold_s", 1.0, unit=" (seconds)"))
    if not inside(handover.place, task):
        raise h.fail("place", list(handover.place), "lies outside the workspace (task.workspace_min .. workspace_max)")
    before_timeout(h, "hold_s", handover.hold_s, task, "no handover could be completed")
    h.done()
    return handover


def least_time(rules) -> tuple[str, float]:
    return "task.handover.hold_s", rules.handover.hold_s


def fill_rules(rules, record) -> None:
    handover = rules.handover
    record["first_hand"] = SIDES.index(handover.first_hand)
    record["place"], record["radius"], record["hold_s"] = handover.place, handover.radius, handover.hold_s


def aims(rules) -> Aims:
    handover = rules.handover
    return Aims((handover.place,), handover.radius, handover.hold_s, first_hand=handover.first_hand)


KIND = Kind(
    name="handover", title="Handover", stages=STAGES, events=EVENTS,
    state=[("hand_held", "u1", (2,)), ("hand_grasp_since", "f8", (2,)), ("hand_loose_since", "f8", (2,)),
           ("passed_since", "f8"), ("in_place_since", "f8"), ("last_t", "f8"), ("both_held", "f8"),
           ("transfer_time", "f8")],
    rules=[("first_hand", "i8"), ("place", "f8", (3,)), ("radius", "f8"), ("hold_s", "f8")], judge=judge,
    fill_rules=fill_rules, aims=aims, least_time=least_time, attempts="drops", initial={"both_held": 0.0},
    measures=(Measure("transfer_time_s", "float64", "s", "transfer time", "a handover's time from the second hand's "
                      "hold beginning to the first hand letting go (the last handover's; negative: the first let go "
                      "that long before the second took it, within drop_grace_s); empty for other kinds and before a "
                      "handover", "transfer_time", signed=True),
              Measure("both_held_s", "float64", "s", "time both hands held it", "a handover's time during which both "
                      "hands held the object; empty for other kinds", "both_held")),
    play=Play(approach="reach", take="grasp", then="hand_over"),
    view=View(zone=lambda rules: (rules.handover.place, rules.handover.radius),
              first_hand=lambda rules: rules.handover.first_hand, taken="taken", done="placed"),
    table="handover", read=read, module=__name__)
