"""The send as a state machine: the object picked up and released so that it drifts to a target zone,
where a colleague catches it.

``advance(state, observation, rules)`` takes what the world shows at one frame and returns the new
state and the events that happened, as ``microg.task.stages`` does for the pick-and-place; the
numbers are ``rules.send`` (a protocol's ``[task.send]``) and the task's limits.

Rules (times are the observations' clock, places the tracker frame; zero gravity, so a released
object drifts on a straight line):

- *Holding* as in every task (``microg.task.holding``: ``grasp_settle_s``, ``drop_grace_s``).
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

from typing import NamedTuple

import numpy as np

from .holding import EPS, Holding, Placeless, hold
from .observation import Observation
from .rules import TaskRules
from .stages import COMPLETED, TIMEOUT, TaskDisplay, TaskEvent

PICK_UP, CARRY, DRIFT = "pick_up", "carry", "drift"
STAGES = (PICK_UP, CARRY, DRIFT, COMPLETED, TIMEOUT)


class Release(NamedTuple):
    """Where and how fast the object moved at the first frame it was no longer grasped."""

    position: tuple[float, float, float]
    velocity: tuple[float, float, float]


class _SendFields(NamedTuple):
    stage: str = PICK_UP
    started: float | None = None
    ended: float | None = None
    holding: Holding = Holding()
    letting_go: Release | None = None
    """The object as the current hold's grasp went (None while grasped, or not held)."""
    release_speed_error: float | None = None
    """m/s: the last send's release speed minus the speed that reaches the target in ``arrival_s``."""
    last_position: tuple[float, float, float] | None = None
    """The object's centre at the frame before (the drift's path runs from it)."""
    closest: float | None = None
    """m: the closest approach of the current or last send so far."""
    attempts: int = 0
    """Sends that missed."""
    send_error: float | None = None
    """m: the entry point's distance from the target's centre (the last miss's closest approach)."""


class SendState(Placeless, _SendFields):
    """A send's state: its stage, its hold, the release and the drift's closest approach."""

    __slots__ = ()


def advance(state: SendState, obs: Observation, rules: TaskRules) -> tuple[SendState, list[TaskEvent]]:
    """One frame of the send (rules in the module docstring)."""
    if state.finished:
        return state, []
    t, events = float(obs.t), []
    position = tuple(float(x) for x in obs.position)
    if state.started is None:
        state = state._replace(started=t)
        events.append(TaskEvent(t, "stage", {"stage": PICK_UP}))
    if t - state.started >= rules.timeout_s - EPS:
        events.append(TaskEvent(t, "timeout", {"stage": state.stage}))
        return state._replace(stage=TIMEOUT, ended=t, send_error=state.closest), events
    grasped = bool(obs.grasped)
    if state.held and not grasped and state.letting_go is None:
        state = state._replace(letting_go=Release(position, tuple(float(v) for v in obs.velocity)))
    elif grasped:
        state = state._replace(letting_go=None)
    holding, change = hold(state.holding, t, grasped, rules)
    state = state._replace(holding=holding)
    if change.began is not None:
        if state.stage == DRIFT:
            state = _missed(state, t, events)
        events.append(TaskEvent(t, "hold", {"since": change.began}))
        events.append(TaskEvent(t, "stage", {"stage": CARRY}))
        state = state._replace(stage=CARRY)
    elif change.ended is not None:
        release = state.letting_go
        send = rules.send
        due = np.linalg.norm(np.subtract(release.position, send.target)) / send.arrival_s
        speed = float(np.linalg.norm(release.velocity))
        events.append(TaskEvent(t, "release", {"position": list(release.position), "speed": speed,
                                               "release_speed_error": speed - due}))
        events.append(TaskEvent(t, "stage", {"stage": DRIFT}))
        state = state._replace(stage=DRIFT, letting_go=None, release_speed_error=speed - due,
                               closest=float(np.linalg.norm(np.subtract(release.position, send.target))))
        if state.closest <= send.radius:
            return _arrived(state, t, _aim(release.position, release.velocity, send.target), events), events
        state = state._replace(last_position=release.position)
    if state.stage == DRIFT:
        state = _drift(state, obs, position, rules, events)
    return state._replace(last_position=position), events


def _drift(state: SendState, obs: Observation, position, rules: TaskRules, events: list[TaskEvent]) -> SendState:
    """A drifting frame: the arrival, the closest approach so far, or the miss."""
    send = rules.send
    t = float(obs.t)
    if _entry(state.last_position, position, send.target, send.radius):
        return _arrived(state, t, _aim(state.last_position, np.subtract(position, state.last_position), send.target),
                        events)
    closest = min(state.closest, _closest(state.last_position, position, send.target))
    state = state._replace(closest=closest)
    if float(np.dot(np.subtract(position, send.target), obs.velocity)) > 0:
        state = _missed(state, t, events)._replace(stage=PICK_UP)
        events.append(TaskEvent(t, "stage", {"stage": PICK_UP}))
    return state


def _missed(state: SendState, t: float, events: list[TaskEvent]) -> SendState:
    attempts = state.attempts + 1
    events.append(TaskEvent(t, "miss", {"closest_m": state.closest, "attempts": attempts}))
    return state._replace(attempts=attempts)


def _arrived(state: SendState, t: float, error: float, events: list[TaskEvent]) -> SendState:
    """The colleague catches the object: the task is completed."""
    events.append(TaskEvent(t, "completed", {"time_s": t - state.started, "send_error_m": error,
                                             "release_speed_error": state.release_speed_error,
                                             "attempts": state.attempts}))
    return state._replace(stage=COMPLETED, ended=t, send_error=error)


def _entry(start, end, centre, radius: float) -> bool:
    """Whether the straight path from ``start`` to ``end`` enters the sphere."""
    d, f = np.subtract(end, start), np.subtract(start, centre)
    a, b, c = float(d @ d), float(2 * f @ d), float(f @ f - radius * radius)
    if c <= 0:
        return True
    if a == 0 or b * b - 4 * a * c < 0:
        return False
    return 0 <= (-b - np.sqrt(b * b - 4 * a * c)) / (2 * a) <= 1


def _aim(start, direction, centre) -> float:
    """The smallest distance from ``centre`` of the ray from ``start`` along ``direction``."""
    d, f = np.asarray(direction, float), np.subtract(centre, start)
    s = max(0.0, float(f @ d / (d @ d))) if d @ d > 0 else 0.0
    return float(np.linalg.norm(f - s * d))


def _closest(start, end, centre) -> float:
    """The smallest distance from ``centre`` of the straight path from ``start`` to ``end``."""
    d, f = np.subtract(end, start), np.subtract(centre, start)
    s = float(np.clip(f @ d / (d @ d), 0.0, 1.0)) if d @ d > 0 else 0.0
    return float(np.linalg.norm(f - s * d))


def displayed(state: SendState, t: float) -> TaskDisplay:
    """What the send shows at time ``t``: its stage (no places)."""
    return TaskDisplay(state.stage)


def measures(state: SendState) -> dict:
    """The send's own measures of a finished task (None before a first send)."""
    return {"send_error_m": state.send_error, "release_speed_error": state.release_speed_error}
