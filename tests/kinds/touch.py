"""A task kind defined in the tests alone: touch the object with the index fingertip and keep it
touching for ``hold_s``. It proves that a kind is one module that joins microg's registry with no
edit to microg itself (``microg.task.register``; the tests register it only while they run, so the
other tests see the shipped kinds alone).

Rules (the numbers are the protocol's ``[task.touch]``):

- *Reach* (the first stage): until an index fingertip (either hand's distal index phalanx) touches
  the object; then *touching* from that frame.
- *Completed* once an index fingertip has touched it for ``hold_s`` without a break. **Time to
  touch** runs from the task's first frame to the touch that completed it.
- *Attempts*: touches that broke off before the hold was done (back to reach).
- *Timeout*: unfinished ``timeout_s`` after the first frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from microg.skeleton import slot
from microg.task.kind import (COUNT, EPS, FINAL, NUMBER, STAGE, Aims, EventSpec, Kind, Measure, Play, Stage, View, emit,
                              start_and_time_out, before_timeout)

STAGES = (Stage("reach", "Touch the object with your index fingertip", loose=True),
          Stage("touching", "Keep touching it")) + FINAL
_REACH, _TOUCHING, _COMPLETED, _TIMEOUT = range(len(STAGES))
EVENTS = (EventSpec("stage", (("stage", STAGE),)), EventSpec("timeout", (("stage", STAGE),)),
          EventSpec("touch_lost", (("since", NUMBER), ("attempts", COUNT))),
          EventSpec("completed", (("time_s", NUMBER), ("time_to_touch_s", NUMBER), ("attempts", COUNT))))
_STAGE, _TIMEOUT_EVENT, _LOST, _COMPLETED_EVENT = range(len(EVENTS))
TIPS = (slot("left", 1, 3), slot("right", 1, 3))
"""The physics' slots of the two index fingertips."""


@njit(cache=True)
def judge(task, rules, seen, events):
    if task.stage >= _COMPLETED:
        return 0
    t = seen.t
    n, out = start_and_time_out(task, t, rules, events, 0, _STAGE, _TIMEOUT_EVENT, _TIMEOUT)
    if out:
        return n
    tip = seen.touching[TIPS[0]] != 0 or seen.touching[TIPS[1]] != 0
    if tip and task.stage == _REACH:
        task.stage, task.touch_since = _TOUCHING, t
        n = emit(events, n, _STAGE, t, _TOUCHING)
    elif not tip and task.stage == _TOUCHING:
        task.attempts += 1
        n = emit(events, n, _LOST, t, task.touch_since, task.attempts)
        n = emit(events, n, _STAGE, t, _REACH)
        task.stage, task.touch_since = _REACH, math.nan
    if task.stage == _TOUCHING and t - task.touch_since >= rules.hold_s - EPS:
        touched = task.touch_since - task.started
        n = emit(events, n, _COMPLETED_EVENT, t, t - task.started, touched, task.attempts)
        task.stage, task.ended, task.time_to_touch = _COMPLETED, t, touched
    return n


@dataclass(frozen=True)
class TouchRules:
    """The touch's number: how long (s) the fingertip must keep touching."""

    hold_s: float


def read(table, task) -> TouchRules:
    touch = TouchRules(hold_s=table.number("hold_s", unit=" (seconds)"))
    before_timeout(table, "hold_s", touch.hold_s, task)
    table.done()
    return touch


def fill_rules(rules, record) -> None:
    record["hold_s"] = rules.touch.hold_s


KIND = Kind(
    name="touch", title="Touch", stages=STAGES, events=EVENTS, state=[("touch_since", "f8"), ("time_to_touch", "f8")],
    rules=[("hold_s", "f8")], judge=judge, fill_rules=fill_rules,
    aims=lambda rules: Aims(rules.places, rules.place_radius, rules.touch.hold_s),
    least_time=lambda rules: ("task.touch.hold_s", rules.touch.hold_s), attempts="touches that broke off",
    measures=(Measure("time_to_touch_s", "float64", "s", "time to touch", "a touch's time from its first frame to the "
                      "touch that completed it; empty unless a touch was completed", "time_to_touch"),),
    play=Play(approach="reach", take="touch", then="keep"), view=View(taken="touched", done="held"),
    table="touch", read=read, module=__name__)
