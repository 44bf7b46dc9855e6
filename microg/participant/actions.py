"""What the simulated participant does each frame: one pure function per action, and their table.

The participant's state is plain, immutable data (``ParticipantState``). Each frame it perceives
the task (``Seen``: its own clock, the object's pose, which of its phalanges touch the object,
whether its hand holds it, the task's display) and the function of its current action returns
the next state; ``ACTIONS`` says which function that is. The actions, in the order a clean run
goes through them:

    wait -> reach -> descend -> close -> squeeze -> lift -> carry -> hold (once per place, with
    corrective carries) -> open -> retreat -> watch -> done

plus ``wait_for_object`` (the object is out of reach) and ``retry`` (a failed grasp or a drop:
open, back off, reach again). Random draws come from the generators in ``Player.streams``, the
one mutable part of the state: every other field is replaced, never changed (a grasp and its
template do remember the last pose and posture they worked out, which saves work and changes
nothing).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.spatial.transform import Rotation

from microg.sim.rotation import quat_multiply, quat_to_matrix
from microg.task import FINAL, MANIPULATION, RELEASE, TaskDisplay
from .grasp import CLOSURES, GraspTemplate, plan_grasp
from .motion import Movement, Pose, movement_time
from .noise import FrameTiming, NormalStream, TrackingNoise, Tremor
from .plan import TaskPlan
from .anatomy import REST
from .skill import SkillProfile

BELIEVED_STIFFNESS = 100.0
"""N/m per pressed phalanx: what the participant has learned a press feels like (the paper's gamma);
its belief is off by the profile's ``stiffness_belief_sd``."""
MIN_SQUEEZE = 0.002
"""The least extra closure (m) after the grasp is felt, whatever the load."""
SLIP_DISTANCE = 0.004
"""Object movement in the hand (m) that the participant notices as a slip."""
SLIP_SQUEEZE = 0.003
"""Extra closure (m) after a noticed slip."""
DROP_CONFIRM_S = 0.1
"""How long the object must be out of the grasp before the participant treats it as dropped."""
DROP_DISTANCE = 0.015
"""How far (m) the object must have left its place in the hand to count as dropped."""
LOST_DISTANCE = 0.03
"""While closing, an object this far (m) from where it was when closing began has got away."""
OPEN_S = 0.25
"""Time to open the grip (s)."""
SETTLE_S = 0.1
"""Pause after the squeeze before carrying (s)."""
REACH_RADIUS = 0.40
"""The participant reaches for objects within this distance (m) of the hand's start; beyond it waits."""
LIFT_OFFSET = np.array([0.0, 0.04, 0.0])
"""The participant first lifts a grasped object straight up this far (m), then carries it."""
RETREAT_OFFSET = np.array([0.0, 0.08, 0.06])
"""Where the hand goes after releasing, in the hand frame relative to where it let go (m): back
and out of the back of the hand (up from a side grasp, down and out from under a clamped plate)."""
RETREAT_S = 0.2
"""The hand withdraws quickly (s): fast enough (peak acceleration 1.4 g) that an object resting
on an open, palm-up hand is left behind rather than carried along."""
RELEASED_DISTANCE = 0.10
"""After letting go, the participant waits until the object is this far (m) from its palm."""
WATCH_S = 1.0
"""... or this long (s) before backing off again."""
PEAK_ACCELERATION = 5.77
"""Peak acceleration of a minimum-jerk movement over D / T^2."""

WAIT, WAIT_FOR_OBJECT, REACH, DESCEND, CLOSE = "wait", "wait_for_object", "reach", "descend", "close"
SQUEEZE, LIFT, CARRY, HOLD, OPEN, RETREAT, WATCH = "squeeze", "lift", "carry", "hold", "open", "retreat", "watch"
RETRY, DONE = "retry", "done"
HOLDING = (LIFT, CARRY, HOLD)
"""The actions in which the object is in the hand."""


def _distance(a: np.ndarray, b: np.ndarray) -> float:
    """|a - b| of 3-vectors, in floats: numpy's arithmetic (``v @ v`` sums in order), without its
    cost per call on three elements."""
    (ax, ay, az), (bx, by, bz) = a.tolist(), b.tolist()
    x, y, z = ax - bx, ay - by, az - bz
    return math.sqrt(x * x + y * y + z * z)


def _length(v: np.ndarray) -> float:
    """|v| of a 3-vector (``_distance`` from the origin: x - 0.0 is x)."""
    return _distance(v, _ORIGIN)


_ORIGIN = np.zeros(3)


@dataclass(frozen=True, eq=False)
class Streams:
    """The seed's random streams, one per kind of draw, so that one kind does not shift another."""

    timing: np.random.Generator
    """Frame intervals."""
    decisions: np.random.Generator
    """Pauses, aim errors, the believed stiffness, the hold clock's rate."""
    tremor: NormalStream
    noise: NormalStream


@dataclass(frozen=True, eq=False)
class Player:
    """What stays the same through a task: the plan, the skill, the frame timing, where the hand
    waits, which phalanx slots are its own, and the random streams."""

    plan: TaskPlan
    skill: SkillProfile
    timing: FrameTiming
    time_limit_s: float
    """The participant stops after this long (s) on its own clock."""
    home: np.ndarray
    """Where the hand waits at the start (m)."""
    slots: slice
    """The own hand's slots among the physics' 40 phalanx slots."""
    thumb: np.ndarray
    """(20,) True for the own hand's thumb slots."""
    fingers: np.ndarray
    """(20,) True for its other slots."""
    streams: Streams
    mirror: float
    """-1.0 for a left hand, 1.0 for a right (the skeleton is a right hand's)."""
    caution: float
    """Every movement with this object takes this many times longer (1 + ``shape_caution`` x the log
    of its elongation: the cube 1, the flat and long cuboids more)."""


@dataclass(frozen=True, eq=False)
class Grasp:
    """One attempt's grasp: the planned template, the hand's orientation relative to the object
    (the template's, as a quaternion) and the attempt's aim error (m)."""

    template: GraspTemplate
    orientation: np.ndarray
    aim: np.ndarray
    last: list = field(default_factory=lambda: [None, None], repr=False)
    """The last grasp pose worked out and what it was worked out from (``_grasp_pose``): an object
    at rest is seen at the same pose frame after frame while the hand reaches for it."""


@dataclass(frozen=True, eq=False)
class ParticipantState:
    """The participant at one frame; ``advance`` gives the next."""

    player: Player
    pose: Pose
    """The intended hand (tremor and tracking noise come on top)."""
    tremor: Tremor
    noise: TrackingNoise
    go_at: float
    """When the first reach starts (s, own clock)."""
    time: float | None = None
    """Its own clock (s): None before the first frame."""
    action: str = WAIT
    since: float = 0.0
    """When the action began (s)."""
    movement: Movement | None = None
    grasp: Grasp | None = None
    closure: float = 0.0
    """How far (m) the pressing phalanges are closed past the faces they touch (negative: short of them)."""
    grip: float = 0.0
    """The closure the squeeze aims for (m)."""
    place: int = 0
    """The place it is carrying to or holding at; the number of places once all are done."""
    attempts: int = 0
    """Drops the participant saw (its own count of attempts; the task keeps the official one)."""
    in_hand: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """Where the object sat in the hand when the grip settled (or after the last slip), hand frame (m)."""
    close_origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """Where the object was when closing began (m)."""
    released_since: float | None = None
    """Since when the object has been out of the grasp and displaced (s)."""
    hold_clock: float = 0.0
    """Its own reckoning of the time held at the place (s), without a display."""
    clock_rate: float = 1.0
    """How fast that clock runs in this hold."""
    dark_since: float | None = None
    """Since when the displayed place it holds at has been dark (s)."""

    def changed(self, **changes) -> ParticipantState:
        """This state with ``changes``: ``dataclasses.replace`` without its look at every field on
        each call (a state has no checks to rerun), at a fifth of its cost; a frame makes a few."""
        fields = self.__dict__.copy()
        count = len(fields)
        fields.update(changes)
        if len(fields) != count:
            raise TypeError(f"ParticipantState has no field {min(changes.keys() - self.__dict__.keys())!r}")
        state = object.__new__(ParticipantState)
        object.__setattr__(state, "__dict__", fields)
        return state


class Seen(NamedTuple):
    """One frame as the participant perceives it (a named tuple: made every frame, it costs a
    third of a frozen dataclass)."""

    t: float
    """Its own clock (s)."""
    dt: float
    """Time since the last frame (s)."""
    position: np.ndarray
    """The object's centre (m)."""
    orientation: np.ndarray
    touching: np.ndarray
    """(20,) True for each of its own hand's phalanx slots touching the object."""
    grasped: bool
    """The object is grasped (the physics' rule), with its own thumb and another digit on it."""
    display: TaskDisplay | None
    """What the task shows; None: it judges the task from the scene and its own clock."""


# -- helpers every action shares ------------------------------------------------------------

def pause(player: Player, extra_s: float = 0.0) -> float:
    """Reaction time plus hesitation before a new movement (s), plus an exponential pause of mean
    ``extra_s`` (a new object, a drop)."""
    skill = player.skill
    draws = player.streams.decisions
    extra = draws.exponential(extra_s) if extra_s > 0 else 0.0
    if skill.hesitation_s == 0:
        return skill.reaction_s + extra
    return skill.reaction_s + draws.exponential(skill.hesitation_s) + extra


def _movement_time(player: Player, distance: float, tolerance: float) -> float:
    """Fitts' law with the participant's constants, slowed by its caution with this object (s)."""
    skill = player.skill
    return player.caution * movement_time(distance, tolerance, skill.movement_intercept, skill.movement_slope)


def _enter(s: ParticipantState, action: str, t: float, **changes) -> ParticipantState:
    return s.changed(action=action, since=t, **changes)


def _closing(s: ParticipantState, seen: Seen, limit: float = math.inf, palm: Pose | None = None) -> ParticipantState:
    """The grip closed one frame further at the profile's speed, up to ``limit`` (m); the palm
    where ``palm`` puts it (default: where it is)."""
    closure = min(s.closure + s.player.skill.closing_speed * seen.dt, limit)
    palm = s.pose if palm is None else palm
    return s.changed(closure=closure, pose=Pose(palm.position, palm.orientation, s.grasp.template.posture(closure)))


def _grasp_pose(grasp: Grasp, closure: float, seen: Seen, approach: bool) -> Pose:
    """Where the hand grasps the object as seen now (with this attempt's aim error); ``approach``:
    the pre-grasp pose, backed off along the template's approach."""
    key = (float(closure).hex(), approach, seen.position.tobytes(), seen.orientation.tobytes())
    if key == grasp.last[0]:
        return grasp.last[1]
    template = grasp.template
    palm, rotation = template.hand_pose(seen.position, quat_to_matrix(seen.orientation))
    palm = palm + grasp.aim
    if approach:
        palm = palm + rotation @ template.approach
    pose = Pose(palm, quat_multiply(seen.orientation, grasp.orientation), template.posture(closure))
    grasp.last[:] = key, pose
    return pose


def _object_in_hand(pose: Pose, seen: Seen) -> np.ndarray:
    """The seen object's centre in the intended hand frame."""
    in_hand = np.empty(3)
    _to_hand_frame(pose.orientation, pose.position, seen.position, in_hand)
    return in_hand


@njit(cache=True)
def _to_hand_frame(orientation, position, point, out):
    """``quat_to_matrix(orientation).T @ (point - position)`` into ``out``, with numpy's arithmetic
    (compiled: a frame with the object in the hand takes one)."""
    rotation = quat_to_matrix(orientation)
    x, y, z = point[0] - position[0], point[1] - position[1], point[2] - position[2]
    for i in range(3):
        out[i] = rotation[0, i] * x + rotation[1, i] * y + rotation[2, i] * z


def _destination(s: ParticipantState) -> np.ndarray:
    """The current place, or after the last one the release position."""
    plan = s.player.plan
    if s.place < len(plan.rules.places):
        return np.asarray(plan.rules.places[s.place])
    return np.asarray(plan.release_position)


def _carry_time(player: Player, distance: float) -> float:
    tolerance = player.skill.place_accept * player.plan.rules.place_radius
    return player.skill.carry_slowdown * _movement_time(player, distance, tolerance)


def _squeeze_depth(s: ParticipantState, seen: Seen) -> float:
    """Extra closure (m) that holds the expected load: the grip force safety x m (g + a) / (2 mu)
    per side, through the believed stiffness of the phalanges pressing on each side."""
    player, plan = s.player, s.player.plan
    thumb = max(int((seen.touching & player.thumb).sum()), 1)
    others = max(int((seen.touching & player.fingers).sum()), 1)
    target = np.asarray(plan.rules.places[min(s.place, len(plan.rules.places) - 1)])
    distance = _distance(target, seen.position)
    duration = _carry_time(player, distance)
    gravity = _length(np.asarray(plan.gravity, dtype=np.float64))
    load = float(plan.object.mass) * (gravity + PEAK_ACCELERATION * distance / duration ** 2)
    force = player.skill.grip_safety * load / (2.0 * max(float(plan.object.material.static_friction), 0.1))
    belief = player.streams.decisions.normal(0.0, player.skill.stiffness_belief_sd)
    stiffness = BELIEVED_STIFFNESS * math.exp(belief)
    return max(force * (thumb + others) / (2.0 * stiffness * thumb * others), MIN_SQUEEZE)


def _check_drop(s: ParticipantState, seen: Seen, displaced: bool) -> tuple[ParticipantState, bool]:
    """Whether the object has been out of the grasp for ``DROP_CONFIRM_S``, ``displaced`` from its
    place in the hand all along; a drop starts a retry."""
    if not displaced or seen.grasped:
        return (s if s.released_since is None else s.changed(released_since=None)), False
    since = seen.t if s.released_since is None else s.released_since
    if seen.t - since >= DROP_CONFIRM_S:
        return _begin_retry(s.changed(attempts=s.attempts + 1, released_since=None), seen.t, dropped=True), True
    return s.changed(released_since=since), False


def _keep_grip(s: ParticipantState, seen: Seen) -> tuple[ParticipantState, bool]:
    """Keep the grip: squeeze more after a visible slip; True with a drop (the object out of the
    grasp and ``DROP_DISTANCE`` from its place in the hand)."""
    in_hand = _object_in_hand(s.pose, seen)
    moved = _distance(in_hand, s.in_hand)
    s, dropped = _check_drop(s, seen, moved > DROP_DISTANCE)
    if dropped:
        return s, True
    if moved > SLIP_DISTANCE and seen.grasped:
        s = s.changed(grip=min(s.grip + SLIP_SQUEEZE, CLOSURES[-1]), in_hand=in_hand)
    return s, False


def _move_holding(s: ParticipantState, seen: Seen) -> tuple[ParticipantState, bool]:
    """Carry the hand along its movement with the object in it; True when the movement ended
    with the object held."""
    s, dropped = _keep_grip(_closing(s, seen, s.grip, palm=s.movement.at(seen.t)), seen)
    return s, not dropped and s.movement.progress(seen.t) >= 1.0


# -- starting a movement --------------------------------------------------------------------

def _begin_reach(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Plan a grasp of the object as it lies now and reach for its pre-grasp pose."""
    player, skill, t = s.player, s.player.skill, seen.t
    if _distance(seen.position, player.home) > REACH_RADIUS:
        return _enter(s, WAIT_FOR_OBJECT, t)
    spec = player.plan.object
    template = plan_grasp(spec.shape, spec.half_extents, seen.orientation, player.plan.hand)
    orientation = Rotation.from_matrix(template.hand_in_object).as_quat(scalar_first=True)
    grasp = Grasp(template, orientation, player.streams.decisions.normal(0.0, skill.aim_sd, 3))
    closure = -skill.preshape_margin
    target = _grasp_pose(grasp, closure, seen, approach=True)
    duration = _movement_time(player, _distance(target.position, s.pose.position), skill.preshape_margin)
    return _enter(s, REACH, t, grasp=grasp, closure=closure, movement=Movement(s.pose, target, t, duration))


def _begin_carry(s: ParticipantState, seen: Seen, delay: float) -> ParticipantState:
    """Carry the object to the current destination (with an aim error), after ``delay`` (s)."""
    player = s.player
    offset = seen.position - s.pose.position
    goal = _destination(s) + player.streams.decisions.normal(0.0, player.skill.aim_sd, 3)
    start = s.pose
    duration = _carry_time(player, _distance(goal, seen.position))
    end = Pose(goal - offset, start.orientation, start.posture)
    return _enter(s, CARRY, seen.t, movement=Movement(start, end, seen.t + delay, duration))


def _begin_retry(s: ParticipantState, t: float, dropped: bool = False) -> ParticipantState:
    """Open the hand and back off, then reach for the object again where it is; after a drop the
    hand first stays where it is for a pause (``drop_pause_s``)."""
    player = s.player
    start, template, margin = s.pose, s.grasp.template, player.skill.preshape_margin
    back = start.position + quat_to_matrix(start.orientation) @ template.approach
    end = Pose(back, start.orientation, template.posture(-margin))
    wait = pause(player, player.skill.drop_pause_s) - player.skill.reaction_s if dropped else 0.0
    return _enter(s, RETRY, t, closure=-margin,
                  movement=Movement(start, end, t + wait, OPEN_S + player.skill.reaction_s))


def _begin_open(s: ParticipantState, t: float) -> ParticipantState:
    """Let go: open the grip where the hand is."""
    start = s.pose
    end = Pose(start.position, start.orientation, s.grasp.template.posture(-s.player.skill.preshape_margin))
    return _enter(s, OPEN, t, movement=Movement(start, end, t, OPEN_S))


# -- the actions ----------------------------------------------------------------------------

def wait(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Wait at the start until it is time to reach (a reaction time, plus hesitation)."""
    return _begin_reach(s, seen) if seen.t >= s.go_at else s


def wait_for_object(s: ParticipantState, seen: Seen) -> ParticipantState:
    """The object is out of reach: wait until it comes back (a task puts a lost object back)."""
    if _distance(seen.position, s.player.home) <= REACH_RADIUS:
        return _enter(s, WAIT, seen.t, go_at=seen.t + pause(s.player))
    return s


def reach(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Move to the pre-grasp pose, following the object if it drifts."""
    t = seen.t
    movement = s.movement.toward(_grasp_pose(s.grasp, s.closure, seen, approach=True))
    pose = movement.at(t)
    if movement.progress(t) < 1.0:
        return s.changed(pose=pose, movement=movement)
    duration = _movement_time(s.player, _length(s.grasp.template.approach), s.player.skill.preshape_margin)
    descent = Movement(pose, _grasp_pose(s.grasp, s.closure, seen, approach=False), t, duration)
    return _enter(s, DESCEND, t, pose=pose, movement=descent)


def descend(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Move the pre-shaped hand around the object until the descent ends or a phalanx touches it."""
    movement = s.movement.toward(_grasp_pose(s.grasp, s.closure, seen, approach=False))
    pose = movement.at(seen.t)
    if movement.progress(seen.t) >= 1.0 or np.count_nonzero(seen.touching):
        return _enter(s, CLOSE, seen.t, pose=pose, movement=movement, close_origin=seen.position)
    return s.changed(pose=pose, movement=movement)


def close(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Close until the hand holds the object; a grip closed fully, or an object pushed away, is a
    failed grasp."""
    s = _closing(s, seen)
    if seen.grasped:
        return _enter(s, SQUEEZE, seen.t, grip=s.closure + _squeeze_depth(s, seen))
    if s.closure >= CLOSURES[-1] or _distance(seen.position, s.close_origin) > LOST_DISTANCE:
        return _begin_retry(s, seen.t)
    return s


def squeeze(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Squeeze to the planned grip, settle, then lift; losing the grasp now is a drop."""
    limit = min(s.grip, CLOSURES[-1])
    s, dropped = _check_drop(_closing(s, seen, limit), seen, displaced=True)
    if dropped or s.closure < limit or seen.t - s.since < SETTLE_S:
        return s
    start = s.pose
    lifted = Pose(start.position + LIFT_OFFSET, start.orientation, start.posture)
    lifting = Movement(start, lifted, seen.t, _carry_time(s.player, _length(LIFT_OFFSET)))
    return _enter(s, LIFT, seen.t, in_hand=_object_in_hand(s.pose, seen), movement=lifting)


def lift(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Lift the object straight up, then (after a pause) carry it."""
    s, arrived = _move_holding(s, seen)
    return _begin_carry(s, seen, pause(s.player)) if arrived else s


def carry(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Carry to the destination; there, hold if the object is close enough to the place, else
    correct; after the last place let go (with a display: once it shows the release stage)."""
    s, arrived = _move_holding(s, seen)
    if not arrived:
        return s
    player = s.player
    if s.place == len(player.plan.rules.places):
        if seen.display is None or seen.display.stage == RELEASE:
            return _begin_open(s, seen.t)
        return _begin_carry(s.changed(place=seen.display.place), seen, player.skill.reaction_s)
    if _distance(seen.position, _destination(s)) <= player.skill.place_accept * player.plan.rules.place_radius:
        rate = 1.0 + player.streams.decisions.normal(0.0, player.skill.clock_cv)
        return _enter(s, HOLD, seen.t, hold_clock=0.0, clock_rate=rate, dark_since=None)
    return _begin_carry(s, seen, player.skill.reaction_s)


def hold(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Hold at the place until done (own clock, or the display moved on); carry back into a place
    it left, or whose mark stayed dark; then on to the next place, the release position or letting go."""
    player, t = s.player, seen.t
    s, dropped = _keep_grip(_closing(s, seen, s.grip), seen)
    if dropped:
        return s
    if _distance(seen.position, _destination(s)) > player.plan.rules.place_radius:
        return _begin_carry(s, seen, player.skill.reaction_s)
    dark = seen.display is not None and not seen.display.lit
    if dark != (s.dark_since is not None):
        s = s.changed(dark_since=t if dark else None)
    if dark and t - s.dark_since > player.skill.reaction_s:
        return _begin_carry(s, seen, player.skill.reaction_s)
    if seen.display is None:
        s = s.changed(hold_clock=s.hold_clock + seen.dt * s.clock_rate)
        done = s.hold_clock >= player.plan.rules.hold_s + player.skill.hold_margin_s
    else:
        done = seen.display.place > s.place or seen.display.stage == RELEASE
    if not done:
        return s
    s = s.changed(place=s.place + 1)
    if s.place < len(player.plan.rules.places) or player.plan.release_position is not None:
        return _begin_carry(s, seen, pause(player))
    return _begin_open(s, t)


def retry(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Open and back off, then reach again for the object where it is now."""
    pose = s.movement.at(seen.t)
    s = s.changed(pose=pose)
    return _begin_reach(s, seen) if s.movement.progress(seen.t) >= 1.0 else s


def open_hand(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Open the grip, then withdraw quickly, out of the back of the hand."""
    pose = s.movement.at(seen.t)
    if s.movement.progress(seen.t) < 1.0:
        return s.changed(pose=pose)
    away = Pose(pose.position + quat_to_matrix(pose.orientation) @ RETREAT_OFFSET, pose.orientation, REST)
    return _enter(s, RETREAT, seen.t, pose=pose, movement=Movement(pose, away, seen.t, RETREAT_S))


def retreat(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Withdraw the open hand, then watch the object."""
    pose = s.movement.at(seen.t)
    if s.movement.progress(seen.t) < 1.0:
        return s.changed(pose=pose)
    return _enter(s, WATCH, seen.t, pose=pose)


def watch(s: ParticipantState, seen: Seen) -> ParticipantState:
    """Stay until the object is seen away from the hand (with a display: until the task shows it
    is over); if it still clings after ``WATCH_S``, open and back off again."""
    away = _distance(seen.position, s.pose.position) > RELEASED_DISTANCE and not seen.grasped
    if away and seen.display is None:
        return _enter(s, DONE, seen.t)
    if not away and seen.t - s.since > WATCH_S:
        return _begin_open(s, seen.t)
    return s


ACTIONS: dict[str, Callable[[ParticipantState, Seen], ParticipantState]] = {
    WAIT: wait,
    WAIT_FOR_OBJECT: wait_for_object,
    REACH: reach,
    DESCEND: descend,
    CLOSE: close,
    SQUEEZE: squeeze,
    LIFT: lift,
    CARRY: carry,
    HOLD: hold,
    RETRY: retry,
    OPEN: open_hand,
    RETREAT: retreat,
    WATCH: watch,
}
"""Which function plays each action (``done`` has none: the participant gives no more frames)."""


def follow_display(s: ParticipantState, seen: Seen) -> ParticipantState | None:
    """React to what the task display shows, before the action does; None if it changes nothing.
    The task is over: done. The task counts a drop while the hand thinks it holds the object: go
    back for it (after a reaction time in the action)."""
    display = seen.display
    if display.stage in FINAL:
        return _enter(s, DONE, seen.t)
    if display.stage == MANIPULATION and s.action in HOLDING and seen.t - s.since > s.player.skill.reaction_s:
        return _begin_retry(s.changed(attempts=s.attempts + 1), seen.t, dropped=True)
    return None


def decide(s: ParticipantState, seen: Seen) -> ParticipantState:
    """The state after this frame's decision: the display's, if it has one, else the action's."""
    if seen.display is not None:
        followed = follow_display(s, seen)
        if followed is not None:
            return followed
    return ACTIONS[s.action](s, seen)
