"""The catch: a launched object, drifting at the participant's hand zone, caught.

Rules (times are the observations' clock; the numbers are the protocol's ``[task.catch]``):

- *The launch.* The task's world starts the object at the task's start moving at ``launch_speed``
  along the launch's direction and turning at ``spin`` (``microg.study.Protocol.start_motion``);
  an object that leaves the workspace while not held goes back and is launched again (respawn).
- *Holding* as in every task (``microg.task.kind.hold``: ``grasp_settle_s``, ``drop_grace_s``).
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

import math

from numba import njit

from microg.task.kind import (COUNT, EPS, FINAL, NUMBER, STAGE, Aims, EventSpec, Kind, Measure, Play, Stage, emit,
                              grasped, hold_task, start_and_time_out, touched)

STAGES = (Stage("approach", "Catch the object.", loose=True), Stage("catch", "Hold on to it.")) + FINAL
_APPROACH, _CATCH, _COMPLETED, _TIMEOUT = range(len(STAGES))
EVENTS = (EventSpec("stage", (("stage", STAGE),)), EventSpec("timeout", (("stage", STAGE),)),
          EventSpec("hold", (("since", NUMBER),)),
          EventSpec("completed", (("time_s", NUMBER), ("time_to_catch_s", NUMBER), ("attempts", COUNT))),
          EventSpec("drop", (("since", NUMBER), ("stage", STAGE), ("attempts", COUNT))))
_STAGE, _TIMEOUT_EVENT, _HOLD, _COMPLETED_EVENT, _DROP = range(len(EVENTS))


@njit(cache=True)
def judge(task, rules, seen, events):
    """One frame of the catch (rules in the module docstring); returns the events written."""
    if task.stage >= _COMPLETED:
        return 0
    t = seen.t
    n, out = start_and_time_out(task, t, rules, events, 0, _STAGE, _TIMEOUT_EVENT, _TIMEOUT)
    if out:
        return n
    n = _touch(task, rules, t, seen, events, n)
    began, ended = hold_task(task, t, grasped(seen), rules)
    if not math.isnan(began):
        n = emit(events, n, _HOLD, t, began)
        n = emit(events, n, _STAGE, t, _CATCH)
        task.stage, task.caught_since = _CATCH, began
    elif not math.isnan(ended) and task.stage == _CATCH:
        n = emit(events, n, _STAGE, t, _APPROACH)
        task.stage, task.caught_since = _APPROACH, math.nan
    if task.stage == _CATCH and t - task.caught_since >= rules.hold_s - EPS:
        caught = task.caught_since - task.started
        n = emit(events, n, _COMPLETED_EVENT, t, t - task.started, caught, task.attempts)
        task.stage, task.ended, task.time_to_catch = _COMPLETED, t, caught
    return n


@njit(cache=True)
def _touch(task, rules, t, seen, events, n):
    """The touch after a frame: begun on a contact, ended (a drop) after ``drop_grace_s`` without one."""
    if touched(seen) or task.held:
        task.touched, task.untouched_since = True, math.nan
        return n
    if not task.touched:
        return n
    since = t if math.isnan(task.untouched_since) else task.untouched_since
    if t - since < rules.drop_grace_s - EPS:
        task.untouched_since = since
        return n
    task.attempts += 1
    task.touched, task.untouched_since = False, math.nan
    return emit(events, n, _DROP, t, since, task.stage, task.attempts)


def fill_rules(rules, record) -> None:
    record["hold_s"] = rules.catch.hold_s


def aims(rules) -> Aims:
    return Aims(rules.places, rules.place_radius, rules.catch.hold_s, path=rules.catch.direction)


KIND = Kind(
    name="catch", title="Catch", stages=STAGES, events=EVENTS,
    state=[("caught_since", "f8"), ("touched", "u1"), ("untouched_since", "f8"), ("time_to_catch", "f8")],
    rules=[("hold_s", "f8")], judge=judge, fill_rules=fill_rules, aims=aims, attempts="touches that did not hold",
    measures=(Measure("time_to_catch_s", "float64", "s", "a catch's seconds from its first frame to the grasp that "
                      "caught the object; empty unless a catch was completed", "time_to_catch"),),
    play=Play(approach="intercept", take="grasp", then="keep", squeeze="path"), module=__name__)
