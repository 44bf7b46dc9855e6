"""The stop of a spin: an object floating and turning, brought to rest.

Rules (times are the observations' clock; omega is the object's angular velocity; the numbers are
the protocol's ``[task.stop_spin]``):

- *The spin.* The task's world starts the object at the task's start turning at ``spin_rate``
  about ``spin_axis``, an axis of the object's own frame (``microg.study.Protocol.start_motion``).
- *Holding* as in every task (``microg.task.kind.hold``: ``grasp_settle_s``, ``drop_grace_s``).
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

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from microg.sim.rotation import quat_to_matrix
from microg.task.kind import (COUNT, EPS, FINAL, FLAG, MAX_LAUNCH_SPEED, MAX_SPIN, NUMBER, STAGE, VECTOR, Aims,
                              Difficulty, EventSpec, Kind, Measure, Play, Stage, View, emit, grasped, hold_task, length,
                              start_and_time_out, touched, before_timeout)

FREE_DV = 1e-4
"""m/s: an object whose centre's velocity changed more than this from one frame to the next was
touched (a free object in weightlessness keeps it to round-off)."""
STAGES = (Stage("spinning", "Take hold of it and stop it turning"), Stage("resting", "Keep it still")) + FINAL
_SPINNING, _RESTING, _COMPLETED, _TIMEOUT = range(len(STAGES))
EVENTS = (EventSpec("stage", (("stage", STAGE),)), EventSpec("timeout", (("stage", STAGE),)),
          EventSpec("hold", (("since", NUMBER),)),
          EventSpec("drop", (("since", NUMBER), ("stage", STAGE), ("attempts", COUNT))),
          EventSpec("flip", (("omega", VECTOR),)),
          EventSpec("completed", (("time_s", NUMBER), ("time_to_rest_s", NUMBER), ("flipped", FLAG),
                                  ("attempts", COUNT))))
_STAGE, _TIMEOUT_EVENT, _HOLD, _DROP, _FLIP, _COMPLETED_EVENT = range(len(EVENTS))


@njit(cache=True)
def judge(task, rules, seen, events):
    """One frame of the stop of a spin (rules in the module docstring); returns the events written."""
    if task.stage >= _COMPLETED:
        return 0
    t = seen.t
    n, out = start_and_time_out(task, t, rules, events, 0, _STAGE, _TIMEOUT_EVENT, _TIMEOUT)
    if out:
        return n
    began, ended = hold_task(task, t, grasped(seen), rules)
    if not math.isnan(began):
        n = emit(events, n, _HOLD, t, began)
    elif not math.isnan(ended):
        task.attempts += 1
        n = emit(events, n, _DROP, t, ended, task.stage, task.attempts)
    omega, velocity = seen.angular_velocity, seen.velocity
    rate = length(omega)
    steady = True
    if task.has_last_velocity:
        dv = (velocity[0] - task.last_velocity[0], velocity[1] - task.last_velocity[1],
              velocity[2] - task.last_velocity[2])
        steady = length(dv) < FREE_DV
    free = steady and not touched(seen)
    task.last_velocity[:] = velocity
    task.has_last_velocity = True
    if not free or rate < rules.rest_omega:
        task.has_free_axis = False
    elif not task.flipped:
        own = quat_to_matrix(seen.orientation).T @ omega
        if not task.has_free_axis:
            task.free_axis[:] = own
            task.has_free_axis = True
        if own[0] * task.free_axis[0] + own[1] * task.free_axis[1] + own[2] * task.free_axis[2] < 0.0:
            n = emit(events, n, _FLIP, t, own[0], own[1], own[2])
            task.flipped = True
    at_rest = rate < rules.rest_omega and (task.held or length(velocity) < rules.rest_speed)
    if task.stage == _SPINNING and at_rest:
        n = emit(events, n, _STAGE, t, _RESTING)
        task.stage, task.rest_since = _RESTING, t
    elif task.stage == _RESTING and not at_rest:
        n = emit(events, n, _STAGE, t, _SPINNING)
        task.stage, task.rest_since = _SPINNING, math.nan
    if task.stage == _RESTING and t - task.rest_since >= rules.hold_s - EPS:
        rested = task.rest_since - task.started
        n = emit(events, n, _COMPLETED_EVENT, t, t - task.started, rested, task.flipped, task.attempts)
        task.stage, task.ended, task.time_to_rest = _COMPLETED, t, rested
    return n


@dataclass(frozen=True)
class StopSpinRules:
    """A stop of a spin's numbers (``[task.stop_spin]``): the object floats at the task's start turning
    at ``spin_rate`` (rad/s) about ``spin_axis`` (a unit vector in the object's own frame: an
    intermediate axis makes it flip); it is at rest once it turns slower than ``rest_omega`` (rad/s)
    while held or moving slower than ``rest_speed`` (m/s), and stopped once at rest for ``hold_s`` (s)."""

    spin_axis: tuple[float, float, float]
    spin_rate: float
    rest_omega: float
    rest_speed: float
    hold_s: float


def read(s, task) -> StopSpinRules:
    """``[task.stop_spin]``: the spin (``spin_axis`` in the object's frame, ``spin_rate``) and what
    counts as stopped (``rest_omega``, ``rest_speed``, ``hold_s``)."""
    axis = np.asarray(s.vector("spin_axis", maximum=None, unit=" (a direction in the object's frame)"))
    if float(np.linalg.norm(axis)) < 1e-9:
        raise s.fail("spin_axis", s.data["spin_axis"], "gives no direction (a zero vector)")
    spin = StopSpinRules(spin_axis=tuple(float(a) for a in axis / np.linalg.norm(axis)),
                         spin_rate=s.number("spin_rate", unit=" (rad/s)", maximum=MAX_SPIN),
                         rest_omega=s.number("rest_omega", unit=" (rad/s)", maximum=MAX_SPIN),
                         rest_speed=s.number("rest_speed", 0.02, unit=" (m/s)", maximum=MAX_LAUNCH_SPEED),
                         hold_s=s.number("hold_s", 1.0, unit=" (seconds)"))
    if spin.rest_omega >= spin.spin_rate:
        raise s.fail("rest_omega", spin.rest_omega, f"must be below spin_rate = {spin.spin_rate:g} rad/s (else the "
                     "object starts at rest)")
    before_timeout(s, "hold_s", spin.hold_s, task, "no stop could be completed")
    s.done()
    return spin


def least_time(rules) -> tuple[str, float]:
    return "task.stop_spin.hold_s", rules.stop_spin.hold_s


def start_motion(rules):
    """The spin: ``spin_rate`` about the body axis ``spin_axis``, turned by the task's start orientation."""
    spin = rules.stop_spin
    axis = quat_to_matrix(np.asarray(rules.start_orientation, dtype=float)) @ np.asarray(spin.spin_axis)
    return (0.0, 0.0, 0.0), tuple(float(spin.spin_rate * a) for a in axis)


def fill_rules(rules, record) -> None:
    spin = rules.stop_spin
    record["rest_omega"], record["rest_speed"], record["hold_s"] = spin.rest_omega, spin.rest_speed, spin.hold_s


def aims(rules) -> Aims:
    return Aims(rules.places, rules.place_radius, rules.stop_spin.hold_s)


KIND = Kind(
    name="stop_spin", title="Stop of a spin", stages=STAGES, events=EVENTS,
    state=[("rest_since", "f8"), ("flipped", "u1"), ("free_axis", "f8", (3,)), ("has_free_axis", "u1"),
           ("last_velocity", "f8", (3,)), ("has_last_velocity", "u1"), ("time_to_rest", "f8")],
    rules=[("rest_omega", "f8"), ("rest_speed", "f8"), ("hold_s", "f8")], judge=judge, fill_rules=fill_rules,
    aims=aims, least_time=least_time, attempts="drops",
    measures=(Measure("time_to_rest_s", "float64", "s", "time to rest", "a stop of a spin's time from its first frame "
                      "to the rest that completed it; empty unless a stop of a spin was completed", "time_to_rest"),
              Measure("flipped", "boolean", "", "flipped (proportion of tasks)", "whether a stop of a spin's object "
                      "turned over its spin axis (the intermediate-axis flip); empty for other kinds and for tasks "
                      "not finished", "flipped", proportion=True)),
    play=Play(approach="reach", take="grasp", then="keep"), view=View(taken="taken", done="at rest"),
    table="stop_spin", read=read, start_motion=start_motion,
    difficulty={"stop_spin.spin": Difficulty(lambda r: r.stop_spin.spin_rate,
                                             lambda r, v: r.with_numbers("stop_spin", replace(r.stop_spin, spin_rate=v)),
                                             1, "rad/s")},
    module=__name__)
