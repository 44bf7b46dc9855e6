"""The send: the object picked up and released so that it drifts to a target zone, where a
colleague catches it.

Rules (times are the observations' clock, places the tracker frame; the numbers are the protocol's
``[task.send]``; zero gravity, so a released object drifts on a straight line):

- *Holding* as in every task (``microg.task.kind.hold``: ``grasp_settle_s``, ``drop_grace_s``).
- *Pick up* (the first stage): ends when the object is held; then *carry* while it is held.
- *The release*: a hold that ends is a send. It was released where and as it moved at the first
  frame it was no longer grasped (the hold's end); the *drift* stage follows.
- *Arrival*: the first drifting frame whose path from the frame before (a straight line between
  the two frames) enters the target zone (a sphere of ``radius`` about ``target``) completes the
  task: the colleague catches it there and the task stops it; so does a release inside the zone.
- *A miss*: a drifting object outside the zone that moves away from the target (its velocity
  points away from the target's centre) has passed its closest approach: the send missed, and the
  stage goes back to pick up. A drifting object held again before it arrives is a miss too. The
  *closest approach* is the smallest distance from the target's centre of the drift's path (each
  frame's straight line from the frame before).
- *Attempts* are the sends that missed.
- **Send error** (``send_error_m``): how far from the target's centre the send was aimed, the
  closest approach to the centre of the drift's straight line: for an arrival, the line of its
  last path continued through the zone (every entry point on the zone's surface is ``radius``
  from the centre, so the entry point itself would tell nothing; for a release inside the zone,
  the line from the release point along the release velocity); for a task that ends without an
  arrival, the last send's closest approach (None before a first send). **Release speed error**
  (``release_speed_error``): the last send's release speed minus the speed that would reach the
  target's centre from the release point in ``arrival_s`` (its distance / ``arrival_s``), m/s.
- *Completion time* runs from the task's first frame to the arrival.
- *Timeout*: a task still unfinished ``timeout_s`` after its first frame ends as not completed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from microg.task.kind import (COUNT, EPS, FINAL, MAX_DISTANCE, NUMBER, NUMBER_OR_NONE, STAGE, VECTOR, Aims, Difficulty,
                              EventSpec, Kind, Measure, Play, Stage, View, emit, grasped, hold_task, inside, length,
                              start_and_time_out, before_timeout)

STAGES = (Stage("pick_up", "Pick up the object", loose=True), Stage("carry", "Let it go so that it floats into the blue rings"),
          Stage("drift", "Watch it float")) + FINAL
_PICK_UP, _CARRY, _DRIFT, _COMPLETED, _TIMEOUT = range(len(STAGES))
EVENTS = (EventSpec("stage", (("stage", STAGE),)), EventSpec("timeout", (("stage", STAGE),)),
          EventSpec("hold", (("since", NUMBER),)),
          EventSpec("release", (("position", VECTOR), ("speed", NUMBER), ("release_speed_error", NUMBER))),
          EventSpec("miss", (("closest_m", NUMBER), ("attempts", COUNT))),
          EventSpec("completed", (("time_s", NUMBER), ("send_error_m", NUMBER),
                                  ("release_speed_error", NUMBER_OR_NONE), ("attempts", COUNT))))
_STAGE, _TIMEOUT_EVENT, _HOLD, _RELEASE, _MISS, _COMPLETED_EVENT = range(len(EVENTS))


@njit(cache=True)
def judge(task, rules, seen, events):
    """One frame of the send (rules in the module docstring); returns the events written."""
    if task.stage >= _COMPLETED:
        return 0
    t, position = seen.t, seen.position
    n, out = start_and_time_out(task, t, rules, events, 0, _STAGE, _TIMEOUT_EVENT, _TIMEOUT)
    if out:
        task.send_error = task.closest
        return n
    holding = grasped(seen)
    if task.held and not holding and not task.letting_go:
        task.release_position[:] = position
        task.release_velocity[:] = seen.velocity
        task.letting_go = True
    elif holding:
        task.letting_go = False
    began, ended = hold_task(task, t, holding, rules)
    if not math.isnan(began):
        if task.stage == _DRIFT:
            n = _missed(task, t, events, n)
        n = emit(events, n, _HOLD, t, began)
        n = emit(events, n, _STAGE, t, _CARRY)
        task.stage = _CARRY
    elif not math.isnan(ended):
        p, v = task.release_position, task.release_velocity
        away = _distance(p, rules.target)
        speed = length(v)
        error = speed - away / rules.arrival_s
        n = emit(events, n, _RELEASE, t, p[0], p[1], p[2], speed, error)
        n = emit(events, n, _STAGE, t, _DRIFT)
        task.stage, task.letting_go, task.release_speed_error, task.closest = _DRIFT, False, error, away
        if away <= rules.radius:
            return _arrived(task, t, _aim(p, v, rules.target), events, n)
        task.last_position[:] = p
    if task.stage == _DRIFT:
        n = _drift(task, rules, t, seen, events, n)
    task.last_position[:] = position
    return n


@njit(cache=True)
def _drift(task, rules, t, seen, events, n):
    """A drifting frame: the arrival, the closest approach so far, or the miss."""
    start, end = task.last_position, seen.position
    if _entry(start, end, rules.target, rules.radius):
        path = (end[0] - start[0], end[1] - start[1], end[2] - start[2])
        return _arrived(task, t, _aim(start, path, rules.target), events, n)
    task.closest = min(task.closest, _closest(start, end, rules.target))
    away = 0.0
    for i in range(3):
        away += (end[i] - rules.target[i]) * seen.velocity[i]
    if away > 0:
        n = _missed(task, t, events, n)
        task.stage = _PICK_UP
        n = emit(events, n, _STAGE, t, _PICK_UP)
    return n


@njit(cache=True)
def _missed(task, t, events, n):
    task.attempts += 1
    return emit(events, n, _MISS, t, task.closest, task.attempts)


@njit(cache=True)
def _arrived(task, t, error, events, n):
    """The colleague catches the object: the task is completed."""
    n = emit(events, n, _COMPLETED_EVENT, t, t - task.started, error, task.release_speed_error, task.attempts)
    task.stage, task.ended, task.send_error = _COMPLETED, t, error
    return n


@njit(cache=True)
def _distance(a, b):
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


@njit(cache=True)
def _entry(start, end, centre, radius):
    """Whether the straight path from ``start`` to ``end`` enters the sphere."""
    d = (end[0] - start[0], end[1] - start[1], end[2] - start[2])
    f = (start[0] - centre[0], start[1] - centre[1], start[2] - centre[2])
    a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    b = 2 * (f[0] * d[0] + f[1] * d[1] + f[2] * d[2])
    c = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - radius * radius
    if c <= 0:
        return True
    if a == 0 or b * b - 4 * a * c < 0:
        return False
    return 0 <= (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a) <= 1


@njit(cache=True)
def _along(start, direction, centre, clip):
    """The smallest distance from ``centre`` of the line from ``start`` along ``direction`` (its ray,
    or with ``clip`` its segment)."""
    f = (centre[0] - start[0], centre[1] - start[1], centre[2] - start[2])
    dd = direction[0] ** 2 + direction[1] ** 2 + direction[2] ** 2
    s = 0.0
    if dd > 0:
        s = max(0.0, (f[0] * direction[0] + f[1] * direction[1] + f[2] * direction[2]) / dd)
        if clip:
            s = min(s, 1.0)
    return math.sqrt((f[0] - s * direction[0]) ** 2 + (f[1] - s * direction[1]) ** 2 + (f[2] - s * direction[2]) ** 2)


@njit(cache=True)
def _aim(start, direction, centre):
    """The smallest distance from ``centre`` of the ray from ``start`` along ``direction``."""
    return _along(start, direction, centre, False)


@njit(cache=True)
def _closest(start, end, centre):
    """The smallest distance from ``centre`` of the straight path from ``start`` to ``end``."""
    return _along(start, (end[0] - start[0], end[1] - start[1], end[2] - start[2]), centre, True)


@dataclass(frozen=True)
class SendRules:
    """A send's numbers (``[task.send]``): the object released so that it drifts into the target zone,
    a sphere of ``radius`` (m) about ``target`` (tracker frame), where a colleague catches it;
    ``arrival_s`` (s) is how long the drift from the release point to the target's centre should take
    (the right release speed)."""

    target: tuple[float, float, float]
    radius: float
    arrival_s: float


def read(s, task) -> SendRules:
    """``[task.send]``: the target zone (``target``, its ``radius``) the object must drift into, and
    ``arrival_s``, how long the drift from the release should take."""
    send = SendRules(target=s.vector("target"), radius=s.number("radius", unit=" (m)", maximum=MAX_DISTANCE),
                     arrival_s=s.number("arrival_s", unit=" (seconds)"))
    if not inside(send.target, task):
        raise s.fail("target", list(send.target), "lies outside the workspace (task.workspace_min .. workspace_max)")
    apart = float(np.linalg.norm(np.subtract(send.target, task.start)))
    if apart <= send.radius:
        raise s.fail("target", list(send.target), f"is {apart:g} m from task.start = {list(task.start)}, within its "
                     f"radius = {send.radius:g} m: the object would start in the zone, with nothing to send")
    before_timeout(s, "arrival_s", send.arrival_s, task, "no send could arrive in time")
    s.done()
    return send


def least_time(rules) -> tuple[str, float]:
    return "task.send.arrival_s", rules.send.arrival_s


def _distance_of(rules) -> float:
    """How far (m) the target's centre lies from the task's start: what a send's staircase adapts."""
    return float(np.linalg.norm(np.subtract(rules.send.target, rules.start)))


def _at_distance(rules, distance: float):
    """``rules`` with the target moved along its line from the start to ``distance`` (m)."""
    way = np.subtract(rules.send.target, rules.start)
    target = tuple(float(v) for v in np.add(rules.start, way * (distance / np.linalg.norm(way))))
    return rules.with_numbers("send", replace(rules.send, target=target))


def fill_rules(rules, record) -> None:
    send = rules.send
    record["target"], record["radius"], record["arrival_s"] = send.target, send.radius, send.arrival_s


def aims(rules) -> Aims:
    send = rules.send
    return Aims(rules.places, rules.place_radius, rules.hold_s, send.target, send.arrival_s,
                tuple(t - s for t, s in zip(send.target, rules.start)))


KIND = Kind(
    name="send", title="Send", stages=STAGES, events=EVENTS,
    state=[("letting_go", "u1"), ("release_position", "f8", (3,)), ("release_velocity", "f8", (3,)),
           ("release_speed_error", "f8"), ("last_position", "f8", (3,)), ("closest", "f8"), ("send_error", "f8")],
    rules=[("target", "f8", (3,)), ("radius", "f8"), ("arrival_s", "f8")], judge=judge, fill_rules=fill_rules,
    aims=aims, least_time=least_time, attempts="misses",
    measures=(Measure("send_error_m", "float64", "m", "send error", "a send's closest approach to the target's "
                      "centre of the drift's straight line (the last send's, for a task that ended without an "
                      "arrival); empty for other kinds and before a first send", "send_error"),
              Measure("release_speed_error", "float64", "m/s", "release speed error", "a send's release speed minus "
                      "the speed that reaches the target in arrival_s (negative: too slow); empty for other kinds and "
                      "before a first send", "release_speed_error", signed=True)),
    play=Play(approach="reach", take="grasp", then="push", squeeze="path"),
    view=View(zone=lambda rules: (rules.send.target, rules.send.radius), taken="picked up", done="arrived"),
    table="send", read=read, difficulty={"send.distance": Difficulty(_distance_of, _at_distance, 1, "m")},
    module=__name__)
