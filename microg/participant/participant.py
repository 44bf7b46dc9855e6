"""The simulated participant: a closed-loop motor model that plays a task (a pick-and-place, a
catch, a stop of a spin, a send; a handover with both hands: ``HandingParticipant``).

    participant = SimulatedParticipant(plan, "veteran", seed=7)
    for moments in play(lanes, participant):       # microg.task.play: one lane, a Python source
        ...

or, by hand, ``frame = participant.next_frame(observe(world))`` then ``world = step(world, frame)``.

Each frame the participant advances its own clock by one frame interval (``noise.frame_interval``),
looks at what the last frame showed of the task (``microg.task.Observation``: the object's pose,
which phalanges touch it, whether it is grasped, what the task displays), decides what the hand
does (``actions``) and returns a Leap-shaped frame: the intended pose plus physiological tremor
plus tracking noise. The frame is one compiled call (``step_participant``) on plain records (the
``actions.PLAYER`` constants and the ``actions.STATE`` that changes); ``SimulatedParticipant``
holds them for the ``HandSource`` interface, and ``runner`` plays many participants with the same
call from compiled code (a session's simulated participant, an in-silico study's).

Reaches, lifts and carries are minimum-jerk movements sized by Fitts' law; the reach follows the
object if it drifts. Closing stops when the hand grasps the object, then the grip squeezes deeper
by an amount sized for the expected load (the object's mass and friction and the gravity come from
the plan, as a trained participant knows the objects); a visible slip of the object in the hand
squeezes more. A grasp that closes fully without holding, or an object that leaves the hand (a
drop), sends the participant back to reach for the object where it now is. After letting go it
watches until the object is away from its hand. Every random draw comes from the seed, in
separate streams for frame timing, decisions, tremor and tracking noise.

With a display in the observation (``TaskDisplay``, what the task shows), the participant follows
the place marks, as a person does: it holds at a place until the task moves on to the next one
(rather than timing the hold itself), carries back into a place that went dark, goes back for the
object when the task counts a drop, lets go only in the release stage, and stops when the task is
over. Without one it judges everything from the scene and its own clock.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numba import njit
from numba.typed import List

from microg.sim.rotation import quat_from_rotation_vector, quat_multiply
from microg.skeleton import BONES_PER_HAND, SIDES, HandFrame, side_slots
from microg.task import KINDS, Observation
from microg.task.kind import APPROACHES, COMPLETED, TAKES, THENS, TIMEOUT, Kind
from .actions import (ACTIONS, ALONE, DONE, GIVING, HANDOVER_SIDE, LIFT_OFFSET, MAX_PLACES, PLAYER, SEEN, SKILL, STATE,
                      TAKING_OVER, WAIT_FOR_HAND, decide, pause)
from .anatomy import CARPALS, KNUCKLES, PHALANGES, REST, pose_joints, posed_hand
from .grasp import TOWARD_USER, UP, grasps
from .noise import (NOISE_SIZE, FrameTiming, TrackingNoiseLevels, advance_noise, advance_tremor, frame_interval,
                    noise_start, tremor_start, tremor_value)
from .plan import TaskPlan
from .skill import SkillProfile, skill_profile

MEASURED_TIMING = FrameTiming()
MEASURED_NOISE = TrackingNoiseLevels()
ABOVE_THE_OBJECT = np.array([0.0, 0.10, 0.12])
"""Where the hand waits when the plan does not say: this far (m) from the object's start, above it
and nearer the user."""
STREAMS = ("timing", "decisions", "tremor", "noise")
"""The seed's random streams, one per kind of draw, so that one kind does not shift another."""


def start(plan: TaskPlan, skill: SkillProfile, seed: int, timing: FrameTiming = MEASURED_TIMING,
          noise: TrackingNoiseLevels = MEASURED_NOISE, time_limit_s: float = 300.0, *, player=None, state=None,
          role: int = ALONE):
    """The participant before its first frame, into ``player`` and ``state`` (a ``PLAYER`` and a
    ``STATE`` record; new ones when None): the hand waiting at its start, open and relaxed. Returns
    the records, the random streams (``STREAMS``, a typed list of generators) and the grasps it can
    take of the object (``grasp.grasps``). A handover's two hands each start with their ``role``
    (``handover_hand``)."""
    if len(plan.rules.places) > MAX_PLACES:
        raise ValueError(f"TaskPlan.rules.places has {len(plan.rules.places)} places: a simulated participant "
                         f"plays at most {MAX_PLACES}")
    entropy = seed if role == ALONE else (seed, role)  # each hand of a handover draws on its own
    streams = List([np.random.default_rng(s) for s in np.random.SeedSequence(entropy).spawn(len(STREAMS))])
    player = np.zeros(1, PLAYER)[0] if player is None else player
    state = np.zeros(1, STATE)[0] if state is None else state
    for name in SKILL:
        player[name] = getattr(skill, name)
    spec = plan.object
    half = np.asarray(spec.half_extents, dtype=np.float64)
    player["time_limit"] = float(time_limit_s)
    player["home"] = (np.asarray(plan.hand_start, dtype=np.float64) if plan.hand_start is not None
                      else np.asarray(plan.start, dtype=np.float64) + ABOVE_THE_OBJECT)
    player["first_slot"] = side_slots(SIDES.index(plan.hand)).start
    player["mirror"] = -1.0 if plan.hand == "left" else 1.0
    player["caution"] = 1.0 + skill.shape_caution * math.log(float(half.max() / half.min()))
    player["round_object"] = spec.shape == "sphere"
    player["half"] = half
    player["mass"], player["static_friction"] = float(spec.mass), float(spec.material.static_friction)
    player["gravity"] = plan.gravity
    kind = KINDS[plan.rules.kind]
    aims, play = kind.aims(plan.rules), kind.play
    player["approach"], player["take"] = APPROACHES.index(play.approach), TAKES.index(play.take)
    player["then"], player["toward"] = THENS.index(play.then), squeezed_toward(aims.path if play.squeeze == "path" else None)
    places = np.asarray(aims.places, dtype=np.float64)
    player["places"][:len(places)] = places
    player["n_places"], player["place_radius"], player["hold_s"] = len(places), aims.place_radius, aims.hold_s
    if aims.target is not None:
        player["target"], player["arrival_s"] = aims.target, aims.arrival_s
    player["has_release"] = plan.release_position is not None
    if plan.release_position is not None:
        player["release"] = plan.release_position
    for name in ("period", "jitter_sd", "p_one_missing", "p_two_missing"):
        player[name] = getattr(timing, name)
    player["tremor_centre"], player["tremor_base"], state["tremor"] = tremor_start(skill.tremor_rms, streams[2])
    player["noise_tau"], player["noise_sd"], state["noise"] = noise_start(noise, streams[3])
    state["time"], state["action"], state["since"], state["grasp"] = math.nan, 0, 0.0, -1
    state["pose"]["position"], state["pose"]["orientation"], state["pose"]["posture"] = player["home"], \
        (1.0, 0.0, 0.0, 0.0), REST
    state["released_since"], state["dark_since"], state["clock_rate"] = math.nan, math.nan, 1.0
    state["go_at"] = pause(player, streams[1], skill.new_object_pause_s if plan.first_with_object else 0.0)
    state["other_held_since"], state["lapse_at"] = math.nan, math.nan
    if role != ALONE:
        handover_hand(plan, role, player, state)
    return player, state, streams, grasps(spec.shape, tuple(float(v) for v in half), plan.hand)


def meeting_point(plan: TaskPlan) -> np.ndarray:
    """Where a handover's giving hand offers the object: halfway from its start to the place zone,
    raised by the lift (``actions.LIFT_OFFSET``)."""
    zone = KINDS[plan.rules.kind].aims(plan.rules).places[0]
    return (np.asarray(plan.start, dtype=np.float64) + np.asarray(zone)) / 2.0 + LIFT_OFFSET


def handover_hand(plan: TaskPlan, role: int, player, state) -> None:
    """One hand of a handover (``plan.hand`` is that hand): the giving hand carries to the meeting
    point (its one place); the hand it passes the object to waits beside it, below and out to its
    own side (``actions.HANDOVER_SIDE``), takes the object from below, palm up, squeezing across the
    giving grip, carries it into the place zone and holds it there for the handover's ``hold_s``."""
    meeting = meeting_point(plan)
    player["role"], player["n_places"] = role, 1
    if role == GIVING:  # it aims at the meeting point as at a place of the task table
        player["places"][0], player["place_radius"], player["hold_s"] = meeting, plan.rules.place_radius, \
            plan.rules.hold_s
        return
    side = -1.0 if plan.hand == "left" else 1.0
    player["home"] = meeting + HANDOVER_SIDE * np.array([side, 1.0, 1.0])
    player["toward"], player["palm_up"] = (side, 0.0, 0.3), True
    state["action"] = WAIT_FOR_HAND
    state["pose"]["position"] = player["home"]


def squeezed_toward(path) -> np.ndarray:
    """The direction the grip squeezes most along (``grasp.choose_grasp``): toward the user, or across
    the object's ``path`` (its horizontal normal, on the user's side: a catch's launch, a send's way
    from the start to the target), so that the object flies in between the thumb and the fingers, or
    out from between them, and no digit stands in its way."""
    if path is None:
        return TOWARD_USER
    path = np.asarray(path, dtype=np.float64)
    across = np.cross(path, UP)
    if np.linalg.norm(across) < 1e-6 * np.linalg.norm(path):  # straight up or down: any side will do
        return TOWARD_USER
    across /= np.linalg.norm(across)
    return across if across @ TOWARD_USER >= 0 else -across


@njit(cache=True)
def perceive(p, seen, t, dt, position, orientation, touching, grasped, has_display, over, loose, release, place, lit):
    """What the participant takes in of an observation at its time ``t``, into ``seen``: its own
    phalanges among the 40 slots ``touching``, and the object as its hand holds it (grasped, with
    its own thumb and another of its digits on it)."""
    seen.t, seen.dt = t, dt
    seen.position[:] = position
    seen.orientation[:] = orientation
    thumb = fingers = False
    for k in range(BONES_PER_HAND):
        on = touching[p.first_slot + k]
        seen.touching[k] = on
        thumb = thumb or (on and k < 4)
        fingers = fingers or (on and k >= 4)
    seen.grasped = grasped and thumb and fingers
    seen.has_display, seen.over, seen.loose, seen.release = has_display, over, loose, release
    seen.place, seen.lit = place, lit


@njit(cache=True)
def step_participant(p, s, seen, streams, grasps, joints, palm, palm_orientation):
    """One frame: the clock moves on by a frame interval, the participant looks at ``seen`` (filled
    by ``perceive`` at the new time, which this returns first) and decides, and its hand is tracked
    into ``joints``, ``palm`` and ``palm_orientation``. Returns the frame's time, or NaN once the
    participant is done or out of time (no frame)."""
    if s.action == DONE:
        return math.nan
    if math.isnan(s.time):  # the first frame shows the hand where it waits
        _track(p, s, streams, 0.0, joints, palm, palm_orientation)
        s.time = 0.0
        return 0.0
    if math.isnan(_next_time(p, s, seen, streams)):
        s.action = DONE
        return math.nan
    _act(p, s, seen, streams, grasps, joints, palm, palm_orientation)
    return seen.t


@njit(cache=True)
def step_hands(p, s, seen, streams, grasps, joints, palm, palm_orientation,
               q, r, other_seen, other_streams, other_grasps, other_joints, other_palm, other_orientation):
    """One frame of a handover's two hands, as ``step_participant`` (``p``, ``s``: the giving hand,
    whose frame interval sets the clock; ``q``, ``r``: the hand it passes the object to). A hand that
    is done stays where it is until the other is. Returns the frame's time, or NaN once both are
    done or out of time."""
    if s.action == DONE and r.action == DONE:
        return math.nan
    if math.isnan(s.time):  # the first frame shows the hands where they wait
        _track(p, s, streams, 0.0, joints, palm, palm_orientation)
        _track(q, r, other_streams, 0.0, other_joints, other_palm, other_orientation)
        s.time = r.time = 0.0
        return 0.0
    if math.isnan(_next_time(p, s, seen, streams)):
        s.action = r.action = DONE
        return math.nan
    other_seen.t, other_seen.dt = seen.t, seen.dt
    _act(p, s, seen, streams, grasps, joints, palm, palm_orientation)
    _act(q, r, other_seen, other_streams, other_grasps, other_joints, other_palm, other_orientation)
    return seen.t


@njit(cache=True)
def _next_time(p, s, seen, streams):
    """The next frame's time and interval, into ``seen``: a frame interval after the last frame; NaN
    past the participant's time limit."""
    seen.dt = frame_interval(p.period, p.jitter_sd, p.p_one_missing, p.p_two_missing, streams[0])
    seen.t = s.time + seen.dt
    if seen.t > p.time_limit:
        s.time = seen.t
        return math.nan
    return seen.t


@njit(cache=True)
def _act(p, s, seen, streams, grasps, joints, palm, palm_orientation):
    """The participant decides at ``seen``'s time (unless it is done: its hand stays where it is) and
    its hand is tracked there."""
    if s.action != DONE:
        decide(p, s, seen, grasps, streams[1])
    _track(p, s, streams, seen.dt, joints, palm, palm_orientation)
    s.time = seen.t


@njit(cache=True)
def _track(p, s, streams, dt, joints, palm, palm_orientation):
    """The intended pose plus tremor and tracking noise, as a Leap-shaped hand: the tremor's and the
    noise's states ``dt`` later, and the joints, palm and its orientation they jitter."""
    tremor, noise = s.tremor.copy(), s.noise.copy()
    tremor_draws, noise_draws = np.empty(4), np.empty(NOISE_SIZE)
    tremor_stream, noise_stream = streams[2], streams[3]  # taken out of the list once: each take counts a reference
    for i in range(4):
        tremor_draws[i] = tremor_stream.standard_normal()
    for i in range(NOISE_SIZE):
        noise_draws[i] = noise_stream.standard_normal()
    advance_tremor(tremor, p.tremor_centre, dt, tremor_draws, s.tremor)
    advance_noise(noise, p.noise_tau, p.noise_sd, dt, noise_draws, s.noise)
    shake, offset = np.empty(3), s.noise[1]
    tremor_value(s.tremor, p.tremor_base, shake)
    for i in range(3):
        palm[i] = s.pose.position[i] + shake[i] + offset[i]
    palm_orientation[:] = quat_multiply(quat_from_rotation_vector(offset[3:6]), s.pose.orientation)
    angles = s.pose.posture.copy()
    for d in range(5):
        for k in range(2):
            angles[d, k] += offset[6 + 2 * d + k]
    pose_joints(angles, KNUCKLES, CARPALS, PHALANGES, palm, palm_orientation, p.mirror, joints)


class SimulatedParticipant:
    """A ``HandSource`` that plays a ``TaskPlan`` in closed loop: it holds the participant's records
    and advances them by one frame per ``next_frame``."""

    def __init__(self, plan: TaskPlan, skill: str | SkillProfile = "veteran", seed: int = 0, *,
                 timing: FrameTiming = MEASURED_TIMING, noise: TrackingNoiseLevels = MEASURED_NOISE,
                 time_limit_s: float = 300.0):
        if not isinstance(plan, TaskPlan):
            raise TypeError(f"plan = {plan!r}: must be a TaskPlan")
        self.plan, self.kind = plan, KINDS[plan.rules.kind]
        self.skill = skill_profile(skill) if isinstance(skill, str) else skill
        self.seed = int(seed)
        self.description = f"simulated:{self.skill.name}:seed={self.seed}"
        self.settings = (timing, noise, time_limit_s)
        self.player, self.state, self._streams, self._grasps = start(plan, self.skill, self.seed, timing, noise,
                                                                     time_limit_s)
        self._seen = np.zeros(1, SEEN)[0]
        self.closed = False

    @property
    def action(self) -> str:
        """What the participant is doing (``actions.ACTIONS``)."""
        return ACTIONS[int(self.state["action"])]

    def next_frame(self, observation: Observation | None = None) -> HandFrame | None:
        """The next frame, or None once the participant has finished (or run out of time)."""
        if self.closed:
            return None
        _perceive(self.description, self.kind, self.player, self._seen, observation, self.plan.hand)
        joints, palm, orientation = np.empty((5, 5, 3)), np.empty(3), np.empty(4)
        t = step_participant(self.player, self.state, self._seen, self._streams, self._grasps, joints, palm,
                             orientation)
        if math.isnan(t):
            return None
        return HandFrame.made(t, (posed_hand(joints, palm, orientation, self.plan.hand),))

    def load_into(self, players, b: int) -> None:
        """Play in lane ``b`` of ``players`` (``microg.participant.runner.Players``) from its first
        frame instead: the same participant, in compiled code."""
        players.load(b, self.plan, self.skill, self.seed, *self.settings)

    def close(self) -> None:
        self.closed = True


class HandingParticipant:
    """A ``HandSource`` that plays a handover with both hands: the ``first_hand`` takes the object
    and gives it (``actions.GIVING``), the other takes it over and puts it in the place zone
    (``actions.TAKING_OVER``). Each hand is a participant of its own (its own ``PLAYER`` and
    ``STATE``, its own random streams, the same skill) that sees what the other is doing; the frame
    times are the giving hand's. The frames end once both hands are done (or out of time)."""

    def __init__(self, plan: TaskPlan, skill: str | SkillProfile = "veteran", seed: int = 0, *,
                 timing: FrameTiming = MEASURED_TIMING, noise: TrackingNoiseLevels = MEASURED_NOISE,
                 time_limit_s: float = 300.0):
        if not isinstance(plan, TaskPlan) or KINDS[plan.rules.kind].play.then != "hand_over":
            raise TypeError(f"plan = {plan!r}: must be a TaskPlan of a kind played with both hands")
        self.kind = KINDS[plan.rules.kind]
        first = self.kind.aims(plan.rules).first_hand
        self.sides = (first, SIDES[1 - SIDES.index(first)])
        self.plans = tuple(replace(plan, hand=side) for side in self.sides)
        self.skill = skill_profile(skill) if isinstance(skill, str) else skill
        self.seed = int(seed)
        self.description = f"simulated:{self.skill.name}:seed={self.seed}"
        self.plan, self.settings = plan, (timing, noise, time_limit_s)
        self.hands = [start(hand_plan, self.skill, self.seed, timing, noise, time_limit_s, role=role)
                      for hand_plan, role in zip(self.plans, (GIVING, TAKING_OVER))]
        self._seen = [np.zeros(1, SEEN)[0] for _ in self.hands]
        self.closed = False

    @property
    def action(self) -> tuple[str, str]:
        """What each hand is doing (``actions.ACTIONS``): the giving hand's, then the other's."""
        return tuple(ACTIONS[int(state["action"])] for _, state, _, _ in self.hands)

    def next_frame(self, observation: Observation | None = None) -> HandFrame | None:
        """The next frame of both hands (left first), or None once both are done (or out of time)."""
        if self.closed:
            return None
        for k, ((player, state, _, _), seen, side) in enumerate(zip(self.hands, self._seen, self.sides)):
            other = self.hands[1 - k][1]
            _perceive(self.description, self.kind, player, seen, observation, side)
            seen["other_action"] = other["action"]
            grasped_by = observation.grasped_by
            seen["other_grasped"] = grasped_by is not None and bool(grasped_by[SIDES.index(self.sides[1 - k])])
        out = [(np.empty((5, 5, 3)), np.empty(3), np.empty(4)) for _ in self.hands]
        (p, s, streams, grasps), (q, r, other_streams, other_grasps) = self.hands
        t = step_hands(p, s, self._seen[0], streams, grasps, *out[0], q, r, self._seen[1], other_streams, other_grasps,
                       *out[1])
        if math.isnan(t):
            return None
        hands = [posed_hand(*pose, side, track_id=k + 1) for k, (pose, side) in enumerate(zip(out, self.sides))]
        return HandFrame.made(t, tuple(sorted(hands, key=lambda hand: SIDES.index(hand.side))))

    load_into = SimulatedParticipant.load_into

    def close(self) -> None:
        self.closed = True


def _perceive(description: str, kind: Kind, player, seen, observation: Observation | None, side: str) -> None:
    """What one hand takes in of the observation of the last frame, into ``seen`` (``perceive``): its
    own grasp of the object (the physics' per hand, when the observation has it), what the task's
    display says of its ``kind``'s stage."""
    if observation is None:
        raise ValueError(f"{description}: a simulated participant is closed-loop; "
                         "next_frame needs the observation of the last frame (microg.task.observe)")
    o, display = observation, observation.display
    touching = np.zeros(2 * BONES_PER_HAND, dtype=np.bool_) if o.touching is None else np.asarray(o.touching)
    grasped = bool(o.grasped) if o.grasped_by is None else bool(o.grasped_by[SIDES.index(side)])
    stage = kind.stages[kind.index(display.stage)] if display is not None else None
    perceive(player, seen, 0.0, 0.0, np.asarray(o.position, dtype=np.float64),
             np.asarray(o.orientation, dtype=np.float64), touching, grasped, display is not None,
             stage is not None and stage.name in (COMPLETED, TIMEOUT), stage is not None and stage.loose,
             stage is not None and stage.release, display.place if display is not None else 0,
             bool(display.lit) if display is not None else False)
    seen["velocity"] = o.velocity

