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
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from microg.task.kind import (COUNT, EPS, FINAL, MAX_LAUNCH_SPEED, MAX_SPIN, NUMBER, STAGE, Aims, Difficulty, EventSpec,
                              Kind, Measure, Play, Stage, View, emit, grasped, hold_task, inside, start_and_time_out,
                              touched, before_timeout)

STAGES = (Stage("approach", "Catch the object as it floats to you", loose=True), Stage("catch", "Hold on to it")) + FINAL
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


@dataclass(frozen=True)
class CatchRules:
    """A catch's numbers (``[task.catch]``): the object leaves the task's start at ``launch_speed``
    (m/s) along ``direction`` (a unit vector, tracker frame) turning at ``spin`` (rad/s, tracker
    frame), and is caught once held for ``hold_s`` (s)."""

    launch_speed: float
    direction: tuple[float, float, float]
    spin: tuple[float, float, float]
    hold_s: float


def read(c, task) -> CatchRules:
    """``[task.catch]``: the launch (``launch_speed``, and ``direction`` or ``toward``: the point in the
    participant's hand zone it flies at), its ``spin`` and the ``hold_s`` that makes a catch."""
    speed = c.number("launch_speed", unit=" (m/s)", maximum=MAX_LAUNCH_SPEED)
    if ("direction" in c.data) == ("toward" in c.data):
        raise c.fail("direction", c.data.get("direction"), "give the launch either direction = [x, y, z] or "
                     "toward = [x, y, z] (a point of the hand zone), not both or neither")
    if "direction" in c.data:
        direction = np.asarray(c.vector("direction", maximum=None, unit=" (a direction, tracker frame)"))
        key = "direction"
    else:
        toward = c.vector("toward")
        if not inside(toward, task):
            raise c.fail("toward", list(toward), "lies outside the workspace (task.workspace_min .. workspace_max)")
        direction, key = np.subtract(toward, task.start), "toward"
    length = float(np.linalg.norm(direction))
    if length < 1e-9:
        raise c.fail(key, c.data[key], "gives no direction (a zero vector, or the task's start itself)")
    catch = CatchRules(launch_speed=speed, direction=tuple(float(d) for d in direction / length),
                       spin=c.vector("spin", default=[0.0, 0.0, 0.0], maximum=MAX_SPIN, unit=" (rad/s, tracker frame)"),
                       hold_s=c.number("hold_s", 1.0, unit=" (seconds)"))
    before_timeout(c, "hold_s", catch.hold_s, task, "no catch could be completed")
    c.done()
    return catch


def least_time(rules) -> tuple[str, float]:
    return "task.catch.hold_s", rules.catch.hold_s


def start_motion(rules):
    """The launch: ``launch_speed`` along ``direction``, turning at ``spin``."""
    catch = rules.catch
    return tuple(catch.launch_speed * d for d in catch.direction), catch.spin


def fill_rules(rules, record) -> None:
    record["hold_s"] = rules.catch.hold_s


def aims(rules) -> Aims:
    return Aims(rules.places, rules.place_radius, rules.catch.hold_s, path=rules.catch.direction)


KIND = Kind(
    name="catch", title="Catch", stages=STAGES, events=EVENTS,
    state=[("caught_since", "f8"), ("touched", "u1"), ("untouched_since", "f8"), ("time_to_catch", "f8")],
    rules=[("hold_s", "f8")], judge=judge, fill_rules=fill_rules, aims=aims, least_time=least_time,
    attempts="touches that did not hold",
    measures=(Measure("time_to_catch_s", "float64", "s", "time to catch", "a catch's time from its first frame to "
                      "the grasp that caught the object; empty unless a catch was completed", "time_to_catch"),),
    play=Play(approach="intercept", take="grasp", then="keep", squeeze="path"),
    view=View(path=lambda rules: rules.catch.direction, taken="taken", done="caught"),
    table="catch", read=read, start_motion=start_motion,
    difficulty={"catch.speed": Difficulty(lambda r: r.catch.launch_speed,
                                          lambda r, v: r.with_numbers("catch", replace(r.catch, launch_speed=v)), 1,
                                          "m/s")},
    module=__name__)
