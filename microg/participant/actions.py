"""What the simulated participant does each frame: one compiled function per action, on plain records.

The participant at one frame is a ``STATE`` record (its clock, its action and since when, the
intended hand, the current movement and grasp, the closure and grip, the place, its own count of
attempts, its hold clock, the tremor and tracking-noise states); what stays the same through a task
is a ``PLAYER`` record (the skill, the task as the participant knows it: the object, the places, the
gravity; the frame timing); what it perceives of a frame is a ``SEEN`` record (its own clock, the
object's pose, which of its phalanges touch it, whether its hand holds it, the task's display).
Each frame ``decide`` lets the display preempt the action where it must (the task is over; the task
counted a drop) and calls the action's function, which updates the state. The actions, in the order
a clean run goes through them:

    wait -> reach -> descend -> close -> squeeze -> lift -> carry -> hold (once per place, with
    corrective carries) -> open -> retreat -> watch -> done

plus ``wait_for_object`` (the object is out of reach) and ``retry`` (a failed grasp or a drop:
open, back off, reach again). That is the play of a task kind that carries its object to places
(``microg.task.kind.Play``: ``PLAYER.approach``, ``take``, ``then``). A kind whose play keeps the
object takes it and keeps it; one that pushes it takes it and pushes it off toward the target; one
that touches it closes only until the index fingertip touches and keeps it there; one that hands it
over is played by two hands (``PLAYER.role``), each a participant of its own that sees what the
other does (``SEEN.other_action``, ``SEEN.other_grasped``):

    intercept, keep: wait -> intercept -> descend -> close -> squeeze -> keep -> done
    keep:            wait -> reach -> descend -> close -> squeeze -> keep -> done
    push:            wait -> reach -> descend -> close -> squeeze -> push -> open -> retreat (braking)
                     -> watch -> done (the task shows the object loose again: wait -> reach ... again)
    touch:           wait -> reach -> descend -> close (until the index fingertip touches) -> touch -> done
    hand_over, the hand that takes the object (role ``GIVING``):
                     wait -> reach -> descend -> close -> squeeze -> lift -> carry (to the meeting point)
                     -> offer -> open -> retreat -> watch -> done (a drop: wait -> reach ... again)
    hand_over, the hand it is passed to (role ``TAKING_OVER``):
                     wait_for_hand -> wait -> reach (from below, palm up) -> descend -> close -> squeeze
                     -> take_over -> carry (to the place zone) -> hold -> open -> retreat -> watch -> done
                     (a drop: back to wait_for_hand)

An ``intercept`` moves the pre-shaped hand into the launched object's path, above the point
where it will be once the hand is there (zero gravity: x + v t, from the velocity it is seen moving
at), and waits; as the object arrives it descends onto it, following it (so that it ends moving
with it), closes and squeezes moving with it, and brakes to a stop in ``BRAKE_S`` (a soft catch).
An object to intercept that moves slower than ``MOVING_SPEED`` is reached for as it lies. A
``push`` aims the held object at the target (with the aim error) and brings it up to the speed that
drifts there in ``arrival_s`` as the participant's own clock runs (``clock_cv``), its speed rising
smoothly over ``PUSH_S``; the hand opens coasting on at that speed, then brakes as it withdraws
(in ``BRAKE_S``). A send that the task shows missed (its object loose again) is fetched and sent
again. A handover's giving hand carries the object to the meeting point and offers it there,
keeping its grip, until it sees the other hand hold it, then lets go; the other hand waits until the
object is offered, takes it from below, palm up, squeezing across the giving grip (so that the
digits of the two hands press different faces), keeps it until the giving hand has let go, and
carries it into the place zone. Random draws
come from the participant's ``decisions`` generator. Everything is compiled (numba): a session
calls ``participant.next_frame`` once a frame, and an in-silico study steps many participants and
their worlds in one compiled loop, with the same code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from microg.sim.rotation import quat_from_matrix, quat_multiply, quat_to_matrix
from .anatomy import REST
from .grasp import CLOSURES, ROUND_LATITUDE, choose_grasp
from .motion import minimum_jerk_at, movement_time

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
REPLAN_DISTANCE = 0.02
"""A reach's target that moves this far (m) from one frame to the next was not followed but
replaced (the object was put back): the hand starts a new movement toward it."""
PEAK_ACCELERATION = 5.77
"""Peak acceleration of a minimum-jerk movement over D / T^2."""
PEAK_SPEED = 1.875
"""Peak speed of a minimum-jerk movement over D / T."""
MAX_POINT_SPEED = 3.0
"""m/s: the fastest any point of the hand moves at a movement's peak, about a fast reach's: a
movement takes at least as long as that allows (a much practised participant's Fitts time can be
shorter; the hand would then jump further between two frames than a hand can)."""
HAND_LENGTH = 0.2
"""m: how far a fingertip may be from the hand's position, the lever arm of the hand's turn."""
MAX_PLACES = 8
"""The most places a task may have (the paper's has three)."""
MOVING_SPEED = 0.02
"""m/s: a catch's object moving at least this fast is intercepted in its path, a slower one reached for."""
BRAKE_S = 0.3
"""s: a catching hand, moving with the object it took, slows to a stop in this time (evenly); so does
a sending hand as it withdraws from the object it let go."""
HANDOVER_SIDE = np.array([0.15, -0.08, 0.06])
"""Where the hand a handover passes the object to waits (m), from the meeting point: out to its own
side (x, mirrored for a left hand), below and nearer the user."""
PUSH_S = 0.4
"""s: a send brings the held object up to its release speed in this time (the speed rising as a
minimum-jerk movement's position does, so that the push starts and ends without a jolt)."""

ACTIONS = ("wait", "wait_for_object", "reach", "descend", "close", "squeeze", "lift", "carry", "hold", "retry",
           "open", "retreat", "watch", "done", "intercept", "keep", "push", "offer", "wait_for_hand", "take_over",
           "touch")
"""The participant's actions ("phase" is the study's timeline, "stage" the task's): ``STATE.action``
is an index into this tuple."""
(WAIT, WAIT_FOR_OBJECT, REACH, DESCEND, CLOSE, SQUEEZE, LIFT, CARRY, HOLD, RETRY, OPEN, RETREAT, WATCH,
 DONE, INTERCEPT, KEEP, PUSH, OFFER, WAIT_FOR_HAND, TAKE_OVER, TOUCH) = range(len(ACTIONS))
INDEX_TIP = 1 * 4 + 3
"""The index finger's distal phalanx among a hand's 20 phalanges (digit-major): what a touch touches with."""
REACH_FOR, INTERCEPT_IT = range(2)
"""``PLAYER.approach`` codes: how the participant goes for the object (``microg.task.kind.Play``:
``reach``, ``intercept``)."""
GRASP_IT, TOUCH_IT = range(2)
"""``PLAYER.take`` codes: it grasps the object, or touches it with the index fingertip (``grasp``, ``touch``)."""
CARRY_IT, KEEP_IT, PUSH_IT, HAND_IT_OVER = range(4)
"""``PLAYER.then`` codes: what it does with the object once taken (``carry``, ``keep``, ``push``,
``hand_over``)."""
ALONE, GIVING, TAKING_OVER = 0, 1, 2
"""``PLAYER.role`` codes: the one hand of every kind but the handover; a handover's hand that takes the
object first and gives it, and the hand it is passed to."""
SKILL = ("movement_intercept", "movement_slope", "carry_slowdown", "aim_sd", "reaction_s", "hesitation_s",
         "tremor_rms", "preshape_margin", "closing_speed", "grip_safety", "stiffness_belief_sd", "hold_margin_s",
         "clock_cv", "place_accept", "shape_caution", "new_object_pause_s", "drop_pause_s", "grip_lapse",
         "drop_grip_gain")
"""The skill's numbers in a ``PLAYER`` record (``skill.SkillProfile``'s fields)."""

_POSE = [("position", "f8", (3,)), ("orientation", "f8", (4,)), ("posture", "f8", (5, 4))]
POSE = np.dtype(_POSE, align=True)
"""A hand's intended pose: its palm's position and orientation and its joint angles."""
PLAYER = np.dtype([(name, "f8") for name in SKILL] + [
    ("time_limit", "f8"), ("approach", "i8"), ("take", "i8"), ("then", "i8"), ("toward", "f8", (3,)), ("home", "f8", (3,)), ("first_slot", "i8"),
    ("mirror", "f8"), ("role", "i8"), ("palm_up", "?"), ("caution", "f8"),
    ("round_object", "?"), ("half", "f8", (3,)), ("mass", "f8"), ("static_friction", "f8"), ("gravity", "f8", (3,)),
    ("places", "f8", (MAX_PLACES, 3)), ("n_places", "i8"), ("place_radius", "f8"), ("hold_s", "f8"),
    ("release", "f8", (3,)), ("has_release", "?"), ("target", "f8", (3,)), ("arrival_s", "f8"),
    ("period", "f8"), ("jitter_sd", "f8"), ("p_one_missing", "f8"), ("p_two_missing", "f8"),
    ("noise_tau", "f8"), ("noise_sd", "f8", (16,)), ("tremor_centre", "f8"), ("tremor_base", "f8"),
], align=True)
"""What stays the same through a task: the skill (``SKILL``), the participant's clock limit, the
task's kind's play (``approach``, ``take``, ``then``: ``REACH_FOR`` ...), the direction its grip squeezes most along (``grasp.choose_grasp``),
where the hand waits, its phalanx slots (the first of its 20), the mirror (-1 for a left hand), its
role in the task (``ALONE``, ``GIVING``, ``TAKING_OVER``), whether it grasps palm up, its caution
with this object, the object (ball or box, half extents, mass, friction), the gravity, the
places and the hold (a place's, a catch's or a rest's), where to let go, a send's target and drift
time, the frame timing and the tremor and noise constants."""
STATE = np.dtype([
    ("time", "f8"), ("action", "i8"), ("since", "f8"), ("go_at", "f8"),
    ("pose", _POSE), ("start", _POSE), ("end", _POSE), ("begin", "f8"), ("duration", "f8"),
    ("grasp", "i8"), ("hand_in_object", "f8", (3, 3)), ("grasp_orientation", "f8", (4,)), ("aim", "f8", (3,)),
    ("closure", "f8"), ("grip", "f8"), ("place", "i8"), ("attempts", "i8"),
    ("in_hand", "f8", (3,)), ("close_origin", "f8", (3,)), ("released_since", "f8"),
    ("hold_clock", "f8"), ("clock_rate", "f8"), ("dark_since", "f8"), ("catch_at", "f8", (3,)), ("drift", "f8", (3,)),
    ("other_held_since", "f8"), ("lapse_at", "f8"),
    ("tremor", "f8", (7,)), ("noise", "f8", (2, 16)),
], align=True)
"""The participant at one frame. ``time`` is its own clock (NaN before the first frame); the
intended hand is ``pose``; the current movement runs from ``start`` to ``end`` from ``begin`` for
``duration``; ``grasp`` is the key of this attempt's grasp (``grasp.GRASP``), ``aim`` its aim error;
``closure`` how far (m) the pressing phalanges are closed past the faces they touch, ``grip`` the
closure the squeeze aims for; ``place`` the place it carries to or holds at; ``attempts`` the drops
it saw (its own count; the task keeps the official one); ``in_hand`` where the object sat in the
hand when the grip settled (hand frame), ``close_origin`` where it was when closing began (a
catching hand's: where it should be, moving on at ``drift``); ``released_since``, ``dark_since``:
NaN for none; ``catch_at``: where the intercepting hand waits for the object's centre; ``drift``:
the velocity a catching hand moves on at with the object, and brakes from, or a send's release
velocity, which the sending hand coasts on at and brakes from (zero otherwise);
``other_held_since``: since when a handover's offering hand has seen the other hand hold the
object (NaN for not); ``lapse_at``: when the grip lapses open during this carry (NaN for never)."""
SEEN = np.dtype([
    ("t", "f8"), ("dt", "f8"), ("position", "f8", (3,)), ("orientation", "f8", (4,)), ("touching", "u1", (20,)),
    ("grasped", "?"), ("has_display", "?"), ("over", "?"), ("loose", "?"), ("release", "?"), ("place", "i8"),
    ("lit", "?"), ("velocity", "f8", (3,)),
    ("other_action", "i8"), ("other_grasped", "?"),
], align=True)
"""One frame as the participant perceives it: its own clock and the time since the last frame,
the object's pose, its own phalanges touching the object (1: touching), whether the physics reports the object
grasped with its own thumb and another digit on it, what the task displays, if anything, and the
object's velocity (zero in silico, which plays only the pick-and-place and never reads it); in a
handover, what the participant's other hand is doing (``ACTIONS``) and whether it holds the object."""


# -- helpers every action shares ------------------------------------------------------------

@njit(cache=True)
def pause(p, draws, extra_s):
    """Reaction time plus hesitation before a new movement (s), plus an exponential pause of mean
    ``extra_s`` (a new object, a drop)."""
    extra = draws.exponential(extra_s) if extra_s > 0 else 0.0
    if p.hesitation_s == 0:
        return p.reaction_s + extra
    return p.reaction_s + draws.exponential(p.hesitation_s) + extra


@njit(cache=True)
def _fitts(p, distance, tolerance):
    """Fitts' law with the participant's constants, slowed by its caution with this object (s)."""
    return p.caution * movement_time(distance, tolerance, p.movement_intercept, p.movement_slope)


@njit(cache=True)
def _carry_time(p, distance):
    return p.carry_slowdown * _fitts(p, distance, p.place_accept * p.place_radius)


@njit(cache=True)
def _distance(a, b):
    x, y, z = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return math.sqrt(x * x + y * y + z * z)


@njit(cache=True)
def _enter(s, action, t):
    s.action, s.since = action, t


@njit(cache=True)
def _copy_pose(source, target):
    target.position[:] = source.position
    target.orientation[:] = source.orientation
    target.posture[:] = source.posture


@njit(cache=True)
def posture_at(grasp, closure, out):
    """Joint angles at ``closure`` (m) of a grasp, interpolated on its ladder (``grasp.CLOSURES``)."""
    q = min(max(closure, CLOSURES[0]), CLOSURES[-1])
    i = 0
    while i < len(CLOSURES) - 2 and CLOSURES[i + 1] <= q:
        i += 1
    w = (q - CLOSURES[i]) / (CLOSURES[i + 1] - CLOSURES[i])
    for d in range(5):
        for j in range(4):
            out[d, j] = (1.0 - w) * grasp.postures[i, d, j] + w * grasp.postures[i + 1, d, j]


@njit(cache=True)
def _grasp_pose(p, s, grasps, closure, position, orientation, approach, out):
    """Where the hand grasps the object at ``position`` and ``orientation`` (with this attempt's aim
    error), into ``out``; ``approach``: the pre-grasp pose, backed off along the grasp's approach. A
    ball has no faces: the hand keeps the world's axes however it has rolled (``choose_grasp``)."""
    grasp = grasps[s.grasp]
    if p.round_object:
        choose_grasp(True, p.half, orientation, s.hand_in_object, p.toward, p.palm_up)
        s.grasp_orientation[:] = quat_from_matrix(s.hand_in_object)
    rotation = quat_to_matrix(orientation) @ s.hand_in_object
    for i in range(3):
        out.position[i] = position[i] + s.aim[i]
        for k in range(3):
            out.position[i] -= rotation[i, k] * grasp.object_in_hand[k]
            if approach:
                out.position[i] += rotation[i, k] * grasp.approach[k]
    out.orientation[:] = quat_multiply(orientation, s.grasp_orientation)
    posture_at(grasp, closure, out.posture)


@njit(cache=True)
def _move(s, t):
    """The intended hand where the current movement has it at ``t`` (minimum jerk); its progress."""
    progress = min(max((t - s.begin) / s.duration, 0.0), 1.0)
    minimum_jerk_at(s.start.position, s.end.position, s.start.orientation, s.end.orientation, s.start.posture,
                    s.end.posture, progress, s.pose.position, s.pose.orientation, s.pose.posture)
    return progress


@njit(cache=True)
def _begin_movement(s, t, duration):
    """A new movement from the intended hand to ``s.end`` (already set), from ``t``, lasting
    ``duration`` or as long as ``MAX_POINT_SPEED`` needs for its farthest point's path (the
    translation and the turn at ``HAND_LENGTH``); the end's quaternion on the start's side, so the
    hand turns the short way."""
    _copy_pose(s.pose, s.start)
    if _dot4(s.start.orientation, s.end.orientation) < 0.0:
        for i in range(4):
            s.end.orientation[i] = -s.end.orientation[i]
    turn = 2.0 * math.acos(min(1.0, _dot4(s.start.orientation, s.end.orientation)))
    path = _distance(s.start.position, s.end.position) + turn * HAND_LENGTH
    s.begin, s.duration = t, max(duration, PEAK_SPEED * path / MAX_POINT_SPEED)


@njit(cache=True)
def _dot4(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


@njit(cache=True)
def _follow(p, s, grasps, seen, approach):
    """Re-aim the current movement's end at the grasp pose of the object as seen now (a drifting,
    turning object): the end's quaternion kept on the side of the last one, so the hand turns on
    continuously. A target that moved by ``REPLAN_DISTANCE`` or more since the last frame (an
    object put back at its start), or that turned more than half a turn from where the movement
    began (a tumbling object: the arc to its quaternion would be ill-defined and swing the hand
    round in one frame), is reached by a new movement from where the hand is."""
    aimed = np.empty(1, POSE)  # indexed at each use: a record taken out of it once would outlive the array
    _grasp_pose(p, s, grasps, s.closure, seen.position, seen.orientation, approach, aimed[0])
    if _dot4(aimed[0].orientation, s.end.orientation) < 0.0:
        for i in range(4):
            aimed[0].orientation[i] = -aimed[0].orientation[i]
    replan = _distance(aimed[0].position, s.end.position) >= REPLAN_DISTANCE \
        or _dot4(aimed[0].orientation, s.start.orientation) < 0.0
    _copy_pose(aimed[0], s.end)
    if replan:
        _begin_movement(s, seen.t, _fitts(p, _distance(s.end.position, s.pose.position), p.preshape_margin))


@njit(cache=True)
def _closing(s, grasps, seen, p, limit):
    """The grip closed one frame further at the profile's speed, up to ``limit`` (m)."""
    s.closure = min(s.closure + p.closing_speed * seen.dt, limit)
    posture_at(grasps[s.grasp], s.closure, s.pose.posture)


@njit(cache=True)
def _object_in_hand(s, seen, out):
    """The seen object's centre in the intended hand frame."""
    rotation = quat_to_matrix(s.pose.orientation)
    x, y, z = seen.position[0] - s.pose.position[0], seen.position[1] - s.pose.position[1], \
        seen.position[2] - s.pose.position[2]
    for i in range(3):
        out[i] = rotation[0, i] * x + rotation[1, i] * y + rotation[2, i] * z


@njit(cache=True)
def _destination(p, s):
    """The current place, or after the last one the release position (a new array)."""
    goal = np.empty(3)
    for i in range(3):
        goal[i] = p.places[s.place, i] if s.place < p.n_places else p.release[i]
    return goal


@njit(cache=True)
def _squeeze_depth(p, s, seen, draws):
    """Extra closure (m) that holds the expected load: the grip force safety x m (g + a) / (2 mu)
    per side, through the believed stiffness of the phalanges pressing on each side; raised by
    ``drop_grip_gain`` of itself for each drop in the task. A ball is pressed above its equator
    (``grasp.ROUND_LATITUDE``, theta), so each press also pushes it out of the grip and only
    mu cos(theta) - sin(theta) of it holds: people grip harder where the surface slopes away from
    the grip (Jenmalm and Johansson 1997)."""
    thumb, others = 0, 0
    for k in range(20):
        if seen.touching[k]:
            if k < 4:
                thumb += 1
            else:
                others += 1
    thumb, others = max(thumb, 1), max(others, 1)
    gravity = math.sqrt(p.gravity[0] ** 2 + p.gravity[1] ** 2 + p.gravity[2] ** 2)
    if p.then == CARRY_IT or p.then == HAND_IT_OVER:  # carried to a place (a handover's: the meeting point, the zone)
        distance = _distance(p.places[min(s.place, p.n_places - 1)], seen.position)
        load = p.mass * (gravity + PEAK_ACCELERATION * distance / _carry_time(p, distance) ** 2)
    else:  # kept where it was taken: a catch's brakes it to a stop
        load = p.mass * (gravity + _length(seen.velocity) / BRAKE_S)
    holding = p.static_friction * math.cos(ROUND_LATITUDE) - math.sin(ROUND_LATITUDE) if p.round_object \
        else p.static_friction
    force = p.grip_safety * (1.0 + p.drop_grip_gain * s.attempts) * load / (2.0 * max(holding, 0.1))
    stiffness = BELIEVED_STIFFNESS * math.exp(draws.normal(0.0, p.stiffness_belief_sd))
    return max(force * (thumb + others) / (2.0 * stiffness * thumb * others), MIN_SQUEEZE)


@njit(cache=True)
def _check_drop(p, s, seen, grasps, draws, displaced):
    """Whether the object has been out of the grasp for ``DROP_CONFIRM_S``, ``displaced`` from its
    place in the hand all along; a drop starts a retry."""
    if not displaced or seen.grasped:
        s.released_since = math.nan
        return False
    if math.isnan(s.released_since):
        s.released_since = seen.t
    if seen.t - s.released_since >= DROP_CONFIRM_S:
        s.attempts += 1
        s.released_since = math.nan
        _begin_retry(p, s, grasps, draws, seen.t, True)
        return True
    return False


@njit(cache=True)
def _keep_grip(p, s, seen, grasps, draws):
    """Keep the grip: squeeze more after a visible slip; True with a drop (the object out of the
    grasp and ``DROP_DISTANCE`` from its place in the hand)."""
    in_hand = np.empty(3)
    _object_in_hand(s, seen, in_hand)
    moved = _distance(in_hand, s.in_hand)
    if _check_drop(p, s, seen, grasps, draws, moved > DROP_DISTANCE):
        return True
    if moved > SLIP_DISTANCE and seen.grasped:
        s.grip = min(s.grip + SLIP_SQUEEZE, CLOSURES[-1])
        s.in_hand[:] = in_hand
    return False


@njit(cache=True)
def _move_holding(p, s, seen, grasps, draws):
    """Carry the hand along its movement with the object in it (its grip opening at a lapse);
    True when the movement ended with the object held."""
    progress = _move(s, seen.t)
    if seen.t >= s.lapse_at:
        s.grip, s.lapse_at = -p.preshape_margin, math.nan
    _closing(s, grasps, seen, p, s.grip)
    return not _keep_grip(p, s, seen, grasps, draws) and progress >= 1.0


# -- starting a movement --------------------------------------------------------------------

@njit(cache=True)
def _take_grasp(p, s, grasps, key, draws):
    """Take grasp ``key``: its orientation (a ball's in the world's axes, as the hand holds it), this
    movement's aim error, and the grip opened to its pre-shape."""
    s.grasp = key
    if p.round_object:
        s.grasp_orientation[:] = quat_from_matrix(s.hand_in_object)
    else:
        s.grasp_orientation[:] = grasps[key].orientation
    for i in range(3):
        s.aim[i] = draws.normal(0.0, p.aim_sd)
    s.closure = -p.preshape_margin


@njit(cache=True)
def _begin_reach(p, s, seen, grasps, draws):
    """Plan a grasp of the object as it lies now and reach for its pre-grasp pose (the object out
    of reach, or lying so that the hand cannot grip it: wait for it)."""
    t = seen.t
    key = choose_grasp(p.round_object, p.half, seen.orientation, s.hand_in_object, p.toward, p.palm_up)
    if _distance(seen.position, p.home) > REACH_RADIUS or not grasps[key].valid:
        _enter(s, WAIT_FOR_OBJECT, t)
        return
    _take_grasp(p, s, grasps, key, draws)
    _grasp_pose(p, s, grasps, s.closure, seen.position, seen.orientation, True, s.end)
    _begin_movement(s, t, _fitts(p, _distance(s.end.position, s.pose.position), p.preshape_margin))
    _enter(s, REACH, t)


@njit(cache=True)
def _begin_take(p, s, seen, grasps, draws):
    """Go for the object: a catch's moving object intercepted in its path, any other reached for."""
    if p.approach == INTERCEPT_IT and _length(seen.velocity) >= MOVING_SPEED:
        _begin_intercept(p, s, seen, grasps, draws)
    else:
        s.drift[:] = 0.0
        _begin_reach(p, s, seen, grasps, draws)


@njit(cache=True)
def _ahead(p, s, seen, grasps, key):
    """How far ahead (s) the hand intercepts the moving object: where its path (x + v t) passes
    nearest the hand's start, or later if the hand could not be above it half a descent before it
    (a few rounds of Fitts' law to the pre-grasp pose there); -1 when that point is out of reach."""
    v, x = seen.velocity, seen.position
    speed2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    nearest = max(((p.home[0] - x[0]) * v[0] + (p.home[1] - x[1]) * v[1] + (p.home[2] - x[2]) * v[2]) / speed2, 0.0)
    grasp = grasps[key]
    rotation = quat_to_matrix(seen.orientation) @ s.hand_in_object
    offset = rotation @ (grasp.object_in_hand - grasp.approach)
    half_descent = _fitts(p, _length(grasp.approach), p.preshape_margin) / 2.0
    ahead, point = nearest, np.empty(3)
    for _ in range(3):
        for i in range(3):
            point[i] = x[i] + v[i] * ahead - offset[i]
        ahead = max(nearest, _fitts(p, _distance(point, s.pose.position), p.preshape_margin) + half_descent)
    for i in range(3):
        point[i] = x[i] + v[i] * ahead
    return ahead if _distance(point, p.home) <= REACH_RADIUS else -1.0


@njit(cache=True)
def _begin_intercept(p, s, seen, grasps, draws):
    """Plan a grasp across the moving object's path and move the pre-shaped hand to its pre-grasp
    pose where the object will be (``_ahead``; none within reach: wait for it)."""
    t = seen.t
    key = choose_grasp(p.round_object, p.half, seen.orientation, s.hand_in_object, p.toward, p.palm_up)
    ahead = _ahead(p, s, seen, grasps, key) if grasps[key].valid else -1.0
    if ahead < 0.0:
        _enter(s, WAIT_FOR_OBJECT, t)
        return
    _take_grasp(p, s, grasps, key, draws)
    for i in range(3):
        s.catch_at[i] = seen.position[i] + seen.velocity[i] * ahead
    s.close_origin[:] = seen.position
    _grasp_pose(p, s, grasps, s.closure, s.catch_at, seen.orientation, True, s.end)
    _begin_movement(s, t, _fitts(p, _distance(s.end.position, s.pose.position), p.preshape_margin))
    _enter(s, INTERCEPT, t)


@njit(cache=True)
def _begin_keep(p, s, seen, draws):
    """Keep the object where it was taken, the grip settled (its own hold clock started); a catching
    hand brakes from its ``drift``."""
    _object_in_hand(s, seen, s.in_hand)
    s.hold_clock, s.clock_rate = 0.0, 1.0 + draws.normal(0.0, p.clock_cv)
    _enter(s, KEEP, seen.t)


@njit(cache=True)
def _begin_push(p, s, seen, draws):
    """Plan the send from where the object is held, after a pause: toward the target (with an aim
    error), at the speed v that drifts there in ``arrival_s`` on the participant's own clock; the
    push covers v ``PUSH_S`` / 2 of the way, so v = distance / (arrival + ``PUSH_S`` / 2)."""
    arrival = p.arrival_s * (1.0 + draws.normal(0.0, p.clock_cv))
    for i in range(3):
        s.drift[i] = (p.target[i] + draws.normal(0.0, p.aim_sd) - seen.position[i]) / (arrival + PUSH_S / 2.0)
    _object_in_hand(s, seen, s.in_hand)
    _copy_pose(s.pose, s.end)
    _begin_movement(s, seen.t + pause(p, draws, 0.0), PUSH_S)
    _enter(s, PUSH, seen.t)


@njit(cache=True)
def _begin_carry(p, s, seen, draws, delay):
    """Carry the object to the current destination (with an aim error), after ``delay`` (s)."""
    goal = _destination(p, s)
    for i in range(3):
        goal[i] += draws.normal(0.0, p.aim_sd)
    duration = _carry_time(p, _distance(goal, seen.position))
    _copy_pose(s.pose, s.end)
    for i in range(3):
        s.end.position[i] = goal[i] - (seen.position[i] - s.pose.position[i])
    _begin_movement(s, seen.t + delay, duration)
    s.lapse_at = math.nan
    if p.grip_lapse > 0 and s.attempts == 0 and draws.random() < p.grip_lapse:
        s.lapse_at = seen.t + delay + draws.random() * s.duration
    _enter(s, CARRY, seen.t)


@njit(cache=True)
def _begin_retry(p, s, grasps, draws, t, dropped):
    """Open the hand and back off, then reach for the object again where it is; after a drop the
    hand first stays where it is for a pause (``drop_pause_s``)."""
    grasp = grasps[s.grasp]
    rotation = quat_to_matrix(s.pose.orientation)
    _copy_pose(s.pose, s.end)
    for i in range(3):
        for k in range(3):
            s.end.position[i] += rotation[i, k] * grasp.approach[k]
    posture_at(grasp, -p.preshape_margin, s.end.posture)
    s.closure, s.lapse_at = -p.preshape_margin, math.nan
    wait = pause(p, draws, p.drop_pause_s) - p.reaction_s if dropped else 0.0
    _begin_movement(s, t + wait, OPEN_S + p.reaction_s)
    _enter(s, RETRY, t)


@njit(cache=True)
def _begin_open(p, s, grasps, t):
    """Let go: open the grip where the hand is."""
    _copy_pose(s.pose, s.end)
    posture_at(grasps[s.grasp], -p.preshape_margin, s.end.posture)
    _begin_movement(s, t, OPEN_S)
    _enter(s, OPEN, t)


@njit(cache=True)
def _begin_hold(p, s, seen, draws):
    s.hold_clock, s.clock_rate, s.dark_since = 0.0, 1.0 + draws.normal(0.0, p.clock_cv), math.nan
    _enter(s, HOLD, seen.t)


# -- the actions ----------------------------------------------------------------------------

@njit(cache=True)
def wait(p, s, seen, grasps, draws):
    """Wait at the start until it is time to reach (a reaction time, plus hesitation)."""
    if seen.t >= s.go_at:
        _begin_take(p, s, seen, grasps, draws)


@njit(cache=True)
def wait_for_object(p, s, seen, grasps, draws):
    """The object is out of reach (or lies so the hand cannot grip it): wait until that changes (a
    task puts a lost object back)."""
    frame = np.empty((3, 3))
    key = choose_grasp(p.round_object, p.half, seen.orientation, frame, p.toward, p.palm_up)
    if p.approach == INTERCEPT_IT and _length(seen.velocity) >= MOVING_SPEED:
        s.hand_in_object[:] = frame
        reachable = grasps[key].valid and _ahead(p, s, seen, grasps, key) >= 0.0
    else:
        reachable = _distance(seen.position, p.home) <= REACH_RADIUS and grasps[key].valid
    if reachable:
        s.go_at = seen.t + pause(p, draws, 0.0)
        _enter(s, WAIT, seen.t)


@njit(cache=True)
def reach(p, s, seen, grasps, draws):
    """Move to the pre-grasp pose, following the object if it drifts."""
    _follow(p, s, grasps, seen, True)
    if _move(s, seen.t) < 1.0:
        return
    _grasp_pose(p, s, grasps, s.closure, seen.position, seen.orientation, False, s.end)
    _begin_movement(s, seen.t, _fitts(p, _length(grasps[s.grasp].approach), p.preshape_margin))
    _enter(s, DESCEND, seen.t)


@njit(cache=True)
def _length(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@njit(cache=True)
def descend(p, s, seen, grasps, draws):
    """Move the pre-shaped hand around the object until the descent ends or a phalanx touches it."""
    _follow(p, s, grasps, seen, False)
    if _move(s, seen.t) >= 1.0 or seen.touching.any():
        s.close_origin[:] = seen.position
        _enter(s, CLOSE, seen.t)


@njit(cache=True)
def close(p, s, seen, grasps, draws):
    """Close until the hand holds the object (or, to touch it, until the index fingertip does); a
    grip closed fully, or an object pushed away, is a failed grasp."""
    _closing(s, grasps, seen, p, math.inf)
    if p.take == TOUCH_IT:
        if seen.touching[INDEX_TIP]:
            s.hold_clock, s.clock_rate = 0.0, 1.0 + draws.normal(0.0, p.clock_cv)
            _enter(s, TOUCH, seen.t)
        elif s.closure >= CLOSURES[-1] or _distance(seen.position, s.close_origin) > LOST_DISTANCE:
            _begin_retry(p, s, grasps, draws, seen.t, False)
    elif seen.grasped:
        s.grip = s.closure + _squeeze_depth(p, s, seen, draws)
        _enter(s, SQUEEZE, seen.t)
    elif s.closure >= CLOSURES[-1] or _distance(seen.position, s.close_origin) > LOST_DISTANCE:
        _begin_retry(p, s, grasps, draws, seen.t, False)


@njit(cache=True)
def squeeze(p, s, seen, grasps, draws):
    """Squeeze to the planned grip, settle, then lift; losing the grasp now is a drop."""
    limit = min(s.grip, CLOSURES[-1])
    _closing(s, grasps, seen, p, limit)
    if _check_drop(p, s, seen, grasps, draws, True) or s.closure < limit or seen.t - s.since < SETTLE_S:
        return
    if p.then == PUSH_IT:
        _begin_push(p, s, seen, draws)
        return
    if p.role == TAKING_OVER:
        _object_in_hand(s, seen, s.in_hand)
        _enter(s, TAKE_OVER, seen.t)
        return
    if p.then == KEEP_IT:
        _begin_keep(p, s, seen, draws)
        return
    _copy_pose(s.pose, s.end)
    for i in range(3):
        s.end.position[i] += LIFT_OFFSET[i]
    _object_in_hand(s, seen, s.in_hand)
    _begin_movement(s, seen.t, _carry_time(p, _length(LIFT_OFFSET)))
    _enter(s, LIFT, seen.t)


@njit(cache=True)
def lift(p, s, seen, grasps, draws):
    """Lift the object straight up, then (after a pause) carry it."""
    if _move_holding(p, s, seen, grasps, draws):
        _begin_carry(p, s, seen, draws, pause(p, draws, 0.0))


@njit(cache=True)
def carry(p, s, seen, grasps, draws):
    """Carry to the destination; there, hold if the object is close enough to the place, else
    correct; after the last place let go (with a display: once it shows the release stage)."""
    if not _move_holding(p, s, seen, grasps, draws):
        return
    if p.role == GIVING:
        s.other_held_since = math.nan  # (an offer again after a drop starts its own reaction time)
        _enter(s, OFFER, seen.t)
    elif s.place == p.n_places:
        if not seen.has_display or seen.release:
            _begin_open(p, s, grasps, seen.t)
        else:
            s.place = seen.place
            _begin_carry(p, s, seen, draws, p.reaction_s)
    elif _distance(seen.position, _destination(p, s)) <= p.place_accept * p.place_radius:
        _begin_hold(p, s, seen, draws)
    else:
        _begin_carry(p, s, seen, draws, p.reaction_s)


@njit(cache=True)
def hold(p, s, seen, grasps, draws):
    """Hold at the place until done (own clock, or the display moved on); carry back into a place
    it left, or whose mark stayed dark; then on to the next place, the release position or letting go."""
    t = seen.t
    _closing(s, grasps, seen, p, s.grip)
    if _keep_grip(p, s, seen, grasps, draws):
        return
    if _distance(seen.position, _destination(p, s)) > p.place_radius:
        _begin_carry(p, s, seen, draws, p.reaction_s)
        return
    dark = seen.has_display and not seen.lit and p.then != HAND_IT_OVER  # (a handover's zone has no mark to light)
    if dark != (not math.isnan(s.dark_since)):
        s.dark_since = t if dark else math.nan
    if dark and t - s.dark_since > p.reaction_s:
        _begin_carry(p, s, seen, draws, p.reaction_s)
        return
    if not seen.has_display:
        s.hold_clock += seen.dt * s.clock_rate
        done = s.hold_clock >= p.hold_s + p.hold_margin_s
    else:
        done = seen.place > s.place or seen.release
    if not done:
        return
    s.place += 1
    if s.place < p.n_places or p.has_release:
        _begin_carry(p, s, seen, draws, pause(p, draws, 0.0))
    else:
        _begin_open(p, s, grasps, t)


@njit(cache=True)
def retry(p, s, seen, grasps, draws):
    """Open and back off, then go for the object again where it is now (a handover's hand that takes
    it over: wait for it to be offered again)."""
    if _move(s, seen.t) < 1.0:
        return
    if p.role == TAKING_OVER:
        _enter(s, WAIT_FOR_HAND, seen.t)
    else:
        _begin_take(p, s, seen, grasps, draws)


@njit(cache=True)
def intercept(p, s, seen, grasps, draws):
    """Move above the object's path and wait there, pre-shaped; descend onto it once it is due
    under the hand within half the descent's time (or on a touch), to move on with it at the
    velocity it then has. An object that slowed down is reached for; one that went by, or was put
    back, is intercepted afresh (or, out of reach, waited for)."""
    progress = _move(s, seen.t)
    v = seen.velocity
    speed = _length(v)
    if speed < MOVING_SPEED:
        _begin_take(p, s, seen, grasps, draws)
        return
    along = 0.0
    for i in range(3):
        along += (s.catch_at[i] - seen.position[i]) * v[i] / speed
    descent = _fitts(p, _length(grasps[s.grasp].approach), p.preshape_margin)
    if seen.touching.any() or (progress >= 1.0 and along <= speed * descent / 2.0):
        _grasp_pose(p, s, grasps, s.closure, seen.position, seen.orientation, False, s.end)
        _begin_movement(s, seen.t, descent)
        s.drift[:] = v
        s.close_origin[:] = seen.position
        _enter(s, DESCEND, seen.t)
    elif along < -LOST_DISTANCE or _distance(seen.position, s.close_origin) >= REPLAN_DISTANCE:
        _begin_take(p, s, seen, grasps, draws)
    else:
        s.close_origin[:] = seen.position


@njit(cache=True)
def push(p, s, seen, grasps, draws):
    """Push the held object off toward the target: the hand's speed rises from rest to the release
    speed (``drift``) over ``PUSH_S`` as minimum jerk, so it has gone drift x ``PUSH_S`` x (2.5 tau^4 -
    3 tau^5 + tau^6) at tau of the push (the speed's integral); then let go, coasting on."""
    tau = min(max((seen.t - s.begin) / s.duration, 0.0), 1.0)
    gone = s.duration * tau ** 4 * (2.5 - 3.0 * tau + tau * tau)
    for i in range(3):
        s.pose.position[i] = s.start.position[i] + s.drift[i] * gone
    _closing(s, grasps, seen, p, s.grip)
    if not _keep_grip(p, s, seen, grasps, draws) and tau >= 1.0:
        _begin_open(p, s, grasps, seen.t)


@njit(cache=True)
def _coast(s, seen):
    """A sending hand coasts on at the release velocity (``drift``) while it opens, then brakes to a
    stop in ``BRAKE_S`` as it withdraws: its movement is carried along."""
    factor = 1.0 if s.action == OPEN else max(1.0 - (seen.t - s.since) / BRAKE_S, 0.0)
    for i in range(3):
        step = s.drift[i] * factor * seen.dt
        s.start.position[i] += step
        s.end.position[i] += step


@njit(cache=True)
def _ride(p, s, seen, grasps, draws):
    """A catching hand moves on at the object's velocity (``drift``) while it closes on it (its pose,
    and where the object should be: ``close_origin``); an object that is not where it should be
    (knocked away, put back) is gone for afresh. True when it was."""
    for i in range(3):
        s.close_origin[i] += s.drift[i] * seen.dt
        if s.action != DESCEND:
            s.pose.position[i] += s.drift[i] * seen.dt
    if _distance(seen.position, s.close_origin) <= LOST_DISTANCE:
        return False
    _begin_retry(p, s, grasps, draws, seen.t, False)
    return True


@njit(cache=True)
def keep(p, s, seen, grasps, draws):
    """Keep the object where it was taken, gripped, until the task is over (the display says so,
    ``follow_display``) or, without a display, for ``hold_s`` plus a margin on its own clock."""
    brake = max(1.0 - (seen.t - s.since) / BRAKE_S, 0.0)
    for i in range(3):
        s.pose.position[i] += s.drift[i] * brake * seen.dt
    _closing(s, grasps, seen, p, s.grip)
    if _keep_grip(p, s, seen, grasps, draws) or seen.has_display:
        return
    s.hold_clock += seen.dt * s.clock_rate
    if s.hold_clock >= p.hold_s + p.hold_margin_s:
        _enter(s, DONE, seen.t)


@njit(cache=True)
def touch(p, s, seen, grasps, draws):
    """Keep the index fingertip on the object, the hand still, until the task is over (the display
    says so, ``follow_display``) or, without a display, for ``hold_s`` plus a margin on its own
    clock; a fingertip that lost the object closes on toward it again."""
    if not seen.touching[INDEX_TIP]:
        _enter(s, CLOSE, seen.t)
        return
    if seen.has_display:
        return
    s.hold_clock += seen.dt * s.clock_rate
    if s.hold_clock >= p.hold_s + p.hold_margin_s:
        _enter(s, DONE, seen.t)


@njit(cache=True)
def open_hand(p, s, seen, grasps, draws):
    """Open the grip, then withdraw quickly, out of the back of the hand; a sending hand stays open
    and brakes (``_coast``), and the object drifts on out of it."""
    if _move(s, seen.t) < 1.0:
        return
    _copy_pose(s.pose, s.end)
    if p.then == PUSH_IT:
        _begin_movement(s, seen.t, BRAKE_S)
        _enter(s, RETREAT, seen.t)
        return
    rotation = quat_to_matrix(s.pose.orientation)
    for i in range(3):
        for k in range(3):
            s.end.position[i] += rotation[i, k] * RETREAT_OFFSET[k]
    s.end.posture[:] = REST
    _begin_movement(s, seen.t, RETREAT_S)
    _enter(s, RETREAT, seen.t)


@njit(cache=True)
def retreat(p, s, seen, grasps, draws):
    """Withdraw the open hand, then watch the object."""
    if _move(s, seen.t) >= 1.0:
        s.drift[:] = 0.0
        _enter(s, WATCH, seen.t)


@njit(cache=True)
def watch(p, s, seen, grasps, draws):
    """Stay until the object is seen away from the hand (with a display: until the task shows it
    is over, or that a send missed or a handed-over object was dropped: fetch it again); if it
    still clings after ``WATCH_S``, open and back off again."""
    again = (p.then == PUSH_IT or p.role == GIVING) and seen.loose
    if seen.has_display and again:
        s.attempts += 1
        s.go_at = seen.t + pause(p, draws, p.drop_pause_s)
        _enter(s, WAIT, seen.t)
        return
    away = _distance(seen.position, s.pose.position) > RELEASED_DISTANCE and not seen.grasped
    if away and not seen.has_display:
        _enter(s, DONE, seen.t)
    elif not away and seen.t - s.since > WATCH_S:
        _begin_open(p, s, grasps, seen.t)


@njit(cache=True)
def offer(p, s, seen, grasps, draws):
    """A handover's giving hand keeps the object still at the meeting point, gripped, until it sees
    the other hand hold it for a reaction time; then lets go."""
    _closing(s, grasps, seen, p, s.grip)
    if _keep_grip(p, s, seen, grasps, draws):
        return
    if not seen.other_grasped:
        s.other_held_since = math.nan
    elif math.isnan(s.other_held_since):
        s.other_held_since = seen.t
    elif seen.t - s.other_held_since >= p.reaction_s:
        _begin_open(p, s, grasps, seen.t)


@njit(cache=True)
def wait_for_hand(p, s, seen, grasps, draws):
    """A handover's hand that takes the object over waits until the other hand offers it."""
    if seen.other_action == OFFER:
        s.go_at = seen.t + pause(p, draws, 0.0)
        _enter(s, WAIT, seen.t)


@njit(cache=True)
def take_over(p, s, seen, grasps, draws):
    """A handover's hand that took the object over keeps it, gripped, until the giving hand has let
    go of it; then carries it into the place zone."""
    _closing(s, grasps, seen, p, s.grip)
    if not _keep_grip(p, s, seen, grasps, draws) and not seen.other_grasped:
        _begin_carry(p, s, seen, draws, p.reaction_s)


@njit(cache=True)
def follow_display(p, s, seen, grasps, draws):
    """React to what the task display shows, before the action does; False if it changes nothing.
    The task is over: done. The task shows the object not held (a pick-and-place's manipulation, a
    catch's approach, a send's pick-up, a handover's take) while the hand thinks it holds it: go
    back for it (after a reaction time in the action)."""
    if seen.over:
        _enter(s, DONE, seen.t)
        return True
    holding = s.action == LIFT or s.action == CARRY or s.action == HOLD or s.action == KEEP or s.action == PUSH \
        or s.action == OFFER or s.action == TAKE_OVER
    if seen.loose and holding and seen.t - s.since > p.reaction_s:
        s.attempts += 1
        _begin_retry(p, s, grasps, draws, seen.t, True)
        return True
    return False


@njit(cache=True)
def decide(p, s, seen, grasps, draws):
    """This frame's decision: the display's, if it has one, else the current action's."""
    if seen.has_display and follow_display(p, s, seen, grasps, draws):
        return
    action = s.action
    if p.approach == INTERCEPT_IT and (action == DESCEND or action == CLOSE or action == SQUEEZE) \
            and _ride(p, s, seen, grasps, draws):
        return
    if p.then == PUSH_IT and (action == OPEN or action == RETREAT):
        _coast(s, seen)
    if action == WAIT:
        wait(p, s, seen, grasps, draws)
    elif action == WAIT_FOR_OBJECT:
        wait_for_object(p, s, seen, grasps, draws)
    elif action == REACH:
        reach(p, s, seen, grasps, draws)
    elif action == DESCEND:
        descend(p, s, seen, grasps, draws)
    elif action == CLOSE:
        close(p, s, seen, grasps, draws)
    elif action == SQUEEZE:
        squeeze(p, s, seen, grasps, draws)
    elif action == LIFT:
        lift(p, s, seen, grasps, draws)
    elif action == CARRY:
        carry(p, s, seen, grasps, draws)
    elif action == HOLD:
        hold(p, s, seen, grasps, draws)
    elif action == RETRY:
        retry(p, s, seen, grasps, draws)
    elif action == OPEN:
        open_hand(p, s, seen, grasps, draws)
    elif action == RETREAT:
        retreat(p, s, seen, grasps, draws)
    elif action == WATCH:
        watch(p, s, seen, grasps, draws)
    elif action == INTERCEPT:
        intercept(p, s, seen, grasps, draws)
    elif action == KEEP:
        keep(p, s, seen, grasps, draws)
    elif action == PUSH:
        push(p, s, seen, grasps, draws)
    elif action == OFFER:
        offer(p, s, seen, grasps, draws)
    elif action == WAIT_FOR_HAND:
        wait_for_hand(p, s, seen, grasps, draws)
    elif action == TAKE_OVER:
        take_over(p, s, seen, grasps, draws)
    elif action == TOUCH:
        touch(p, s, seen, grasps, draws)
