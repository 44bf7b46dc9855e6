"""The pick-and-place (paper, section 4.3): the object picked up, held at each place in turn, let go.

Rules (times are the observations' clock; a protocol's ``task`` table sets every number):

- *Holding* as in every task (``microg.task.kind.hold``: ``grasp_settle_s``, ``drop_grace_s``).
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
from dataclasses import replace

from numba import njit

from microg.task.kind import (COUNT, EPS, FINAL, NUMBER, PLACE_OR_NONE, STAGE, Aims, Difficulty, EventSpec, Kind, Play,
                              Stage, View, emit, grasped, hold_task, start_and_time_out)

MAX_PLACES = 8
"""The most places a task may have."""
STAGES = (Stage("manipulation", "Pick up the object", loose=True),
          Stage("maintenance", "Carry it to the lit place and hold it there"),
          Stage("release", "Let go of the object", release=True)) + FINAL
_MANIPULATION, _MAINTENANCE, _RELEASE, _COMPLETED, _TIMEOUT = range(len(STAGES))
EVENTS = (EventSpec("stage", (("stage", STAGE), ("place", PLACE_OR_NONE))),
          EventSpec("timeout", (("stage", STAGE), ("place", COUNT))),
          EventSpec("hold", (("since", NUMBER),)),
          EventSpec("completed", (("time_s", NUMBER), ("attempts", COUNT))),
          EventSpec("release", (("since", NUMBER),)),
          EventSpec("place_dark", (("place", COUNT), ("lit_s", NUMBER))),
          EventSpec("drop", (("since", NUMBER), ("stage", STAGE), ("place", COUNT), ("attempts", COUNT))),
          EventSpec("place_lit", (("place", COUNT),)),
          EventSpec("place_done", (("place", COUNT), ("lit_s", NUMBER))))
(_STAGE, _TIMEOUT_EVENT, _HOLD, _COMPLETED_EVENT, _RELEASE_EVENT, _PLACE_DARK, _DROP, _PLACE_LIT,
 _PLACE_DONE) = range(len(EVENTS))


@njit(cache=True)
def judge(task, rules, seen, events):
    """One frame of the task (rules in the module docstring); returns the events written."""
    if task.stage >= _COMPLETED:
        return 0
    t = seen.t
    n, out = start_and_time_out(task, t, rules, events, 0, _STAGE, _TIMEOUT_EVENT, _TIMEOUT)
    if out:
        return n
    n = _update_hold(task, rules, t, grasped(seen), events, n)
    if task.stage == _RELEASE and not task.held:
        n = emit(events, n, _COMPLETED_EVENT, t, task.ended - task.started, task.attempts)
        task.stage = _COMPLETED
        return n
    if task.stage == _MANIPULATION and task.held:
        task.stage = _MAINTENANCE
        n = emit(events, n, _STAGE, t, _MAINTENANCE, task.place)
    if task.stage == _MAINTENANCE:
        n = _update_place(task, rules, t, seen.position, events, n)
    return n


@njit(cache=True)
def _update_hold(task, rules, t, grasped, events, n):
    """The hold; a hold that ends is the release in the release stage (its end the task's), a drop
    before it."""
    began, ended = hold_task(task, t, grasped, rules)
    if not math.isnan(began):
        return emit(events, n, _HOLD, t, began)
    if math.isnan(ended):
        return n
    if task.stage == _RELEASE:
        task.ended = ended
        return emit(events, n, _RELEASE_EVENT, t, ended)
    if not math.isnan(task.lit_since):
        n = emit(events, n, _PLACE_DARK, t, task.place, t - task.lit_since)
    n = emit(events, n, _DROP, t, ended, task.stage, task.place, task.attempts + 1)
    if task.stage == _MAINTENANCE:
        n = emit(events, n, _STAGE, t, _MANIPULATION, task.place)
    task.stage, task.attempts, task.lit_since = _MANIPULATION, task.attempts + 1, math.nan
    return n


@njit(cache=True)
def _update_place(task, rules, t, position, events, n):
    x = position[0] - rules.places[task.place, 0]
    y = position[1] - rules.places[task.place, 1]
    z = position[2] - rules.places[task.place, 2]
    inside = math.sqrt(x * x + y * y + z * z) <= rules.place_radius
    if not (inside and task.held):
        if not math.isnan(task.lit_since):
            n = emit(events, n, _PLACE_DARK, t, task.place, t - task.lit_since)
            task.lit_since = math.nan
        return n
    if math.isnan(task.lit_since):
        task.lit_since = t
        return emit(events, n, _PLACE_LIT, t, task.place)
    if t - task.lit_since < rules.hold_s - EPS:
        return n
    n = emit(events, n, _PLACE_DONE, t, task.place, t - task.lit_since)
    task.place, task.lit_since = task.place + 1, math.nan
    if task.place == rules.n_places:
        n = emit(events, n, _STAGE, t, _RELEASE)
        task.stage = _RELEASE
    return n


def least_time(rules) -> tuple[str, float]:
    return f"the {len(rules.places)} holds of task.hold_s", len(rules.places) * rules.hold_s


def fill_rules(rules, record) -> None:
    """The places, their radius and hold of a ``TaskRules`` into a rules record."""
    if len(rules.places) > MAX_PLACES:
        raise ValueError(f"task.places has {len(rules.places)} places: a task has at most {MAX_PLACES}")
    record["places"][:len(rules.places)] = rules.places
    record["n_places"], record["place_radius"], record["hold_s"] = len(rules.places), rules.place_radius, rules.hold_s


def aims(rules) -> Aims:
    return Aims(rules.places, rules.place_radius, rules.hold_s)


KIND = Kind(
    name="pick_and_place", title="Pick and place", stages=STAGES, events=EVENTS, state=[],
    rules=[("places", "f8", (MAX_PLACES, 3)), ("n_places", "i8"), ("place_radius", "f8"), ("hold_s", "f8")],
    judge=judge, fill_rules=fill_rules, aims=aims, least_time=least_time, attempts="drops",
    play=Play(approach="reach", take="grasp", then="carry"),
    view=View(places=True, taken="picked up", done="released"),
    difficulty={"place_radius": Difficulty(lambda r: r.place_radius, lambda r, v: replace(r, place_radius=v), -1, "m"),
                "hold_s": Difficulty(lambda r: r.hold_s, lambda r, v: replace(r, hold_s=v), 1, "s")},
    module=__name__)
