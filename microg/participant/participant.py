"""The simulated participant: a closed-loop motor model that plays the pick-and-place task.

    participant = SimulatedParticipant(plan, "veteran", seed=7)
    for moment in play(world, participant, plan.rules, smooth):   # microg.task.play
        ...

or, by hand, ``frame = participant.next_frame(observe(world))`` then ``world = step(world, frame)``.

Each frame the participant advances its own clock by one frame interval (``noise.FrameTiming``),
looks at what the last frame showed of the task (``microg.task.Observation``: the object's pose,
which phalanges touch it, whether it is grasped, what the task displays), decides what the hand
does (``actions``) and returns a Leap-shaped frame: the intended pose plus physiological tremor
plus tracking noise. ``advance(state, observation) -> (state, frame)`` is that frame as a pure
function of the participant's state; ``SimulatedParticipant`` holds the state for the
``HandSource`` interface.

Reaches, lifts and carries are minimum-jerk movements sized by Fitts' law; the reach follows the
object if it drifts. Closing stops when the hand grasps the object, then the grip squeezes deeper
by an amount sized for the expected load (the object's mass and friction and the gravity come from
the plan, as a trained participant knows the objects); a visible slip of the object in the hand
squeezes more. A grasp that closes fully without holding, or an object that leaves the hand (a
drop), sends the participant back to reach for the object where it now is. After letting go it
watches until the object is away from its hand. Every random draw comes from the seed, in
separate streams for timing, decisions, tremor and tracking noise.

With a display in the observation (``TaskDisplay``, what the task shows), the participant follows
the place marks, as a person does: it holds at a place until the task moves on to the next one
(rather than timing the hold itself), carries back into a place that went dark, goes back for the
object when the task counts a drop, lets go only in the release stage, and stops when the task is
over. Without one it judges everything from the scene and its own clock.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from microg.skeleton import BONES_PER_HAND, N_BONES, SIDES, SLOT_DIGIT, HandFrame, side_slots
from microg.sim.rotation import quat_from_rotation_vector, quat_multiply
from microg.task import Observation
from .actions import DONE, ParticipantState, Player, Seen, Streams, decide, pause
from .motion import Pose
from .noise import (FrameTiming, NormalStream, TrackingNoise, TrackingNoiseLevels, Tremor, advance_noise,
                    advance_tremor, tremor_value)
from .plan import TaskPlan
from .anatomy import CARPALS, KNUCKLES, PHALANGES, REST, pose_joints, posed_hand
from .skill import SkillProfile, skill_profile

MEASURED_TIMING = FrameTiming()
MEASURED_NOISE = TrackingNoiseLevels()
ABOVE_THE_OBJECT = np.array([0.0, 0.10, 0.12])
"""Where the hand waits when the plan does not say: this far (m) from the object's start, above it
and nearer the user."""


def start(plan: TaskPlan, skill: SkillProfile, seed: int, timing: FrameTiming = MEASURED_TIMING,
          noise: TrackingNoiseLevels = MEASURED_NOISE, time_limit_s: float = 300.0) -> ParticipantState:
    """The participant before its first frame: the hand waiting at its start, open and relaxed."""
    generators = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4)]
    streams = Streams(generators[0], generators[1], NormalStream(generators[2]), NormalStream(generators[3]))
    tremor = Tremor.start(skill.tremor_rms, streams.tremor)
    jitter = TrackingNoise.start(noise, streams.noise)
    home = (np.asarray(plan.hand_start, dtype=np.float64) if plan.hand_start is not None
            else np.asarray(plan.start, dtype=np.float64) + ABOVE_THE_OBJECT)
    side = SIDES.index(plan.hand)
    slots = side_slots(side)
    thumb = SLOT_DIGIT[slots] == 0
    extents = np.asarray(plan.object.half_extents, dtype=np.float64)
    caution = 1.0 + skill.shape_caution * math.log(float(extents.max() / extents.min()))
    player = Player(plan, skill, timing, float(time_limit_s), home, slots, thumb, ~thumb, streams,
                    -1.0 if plan.hand == "left" else 1.0, caution)
    pose = Pose(home, np.array([1.0, 0.0, 0.0, 0.0]), REST.copy())
    first_reach = pause(player, skill.new_object_pause_s if plan.first_with_object else 0.0)
    return ParticipantState(player, pose, tremor, jitter, go_at=first_reach)


def perceive(player: Player, observation: Observation, t: float, dt: float) -> Seen:
    """What the participant takes in of ``observation`` at its time ``t``."""
    touching = (np.zeros(BONES_PER_HAND, dtype=bool) if observation.touching is None
                else np.asarray(observation.touching, dtype=bool)[player.slots])
    in_my_hand = (bool(observation.grasped) and np.count_nonzero(touching & player.thumb) > 0
                  and np.count_nonzero(touching & player.fingers) > 0)
    return Seen(t, dt, np.asarray(observation.position, dtype=np.float64),
                np.asarray(observation.orientation, dtype=np.float64), touching, in_my_hand, observation.display)


def advance(state: ParticipantState, observation: Observation) -> tuple[ParticipantState, HandFrame | None]:
    """One frame: the clock moves on by a frame interval, the participant looks at ``observation``
    and decides, and its hand is tracked. The frame is None once it is done or out of time."""
    player = state.player
    if state.action == DONE:
        return state, None
    if state.time is None:  # the first frame shows the hand where it waits
        return _tracked(state, 0.0, 0.0)
    dt = player.timing.interval(player.streams.timing)
    t = state.time + dt
    if t > player.time_limit_s:
        return state.changed(time=t, action=DONE), None
    return _tracked(decide(state, perceive(player, observation, t, dt)), t, dt)


def _tracked(state: ParticipantState, t: float, dt: float) -> tuple[ParticipantState, HandFrame]:
    """The intended pose plus tremor and tracking noise, as a Leap-shaped hand at ``t``, ``dt``
    after the last frame."""
    player, tremor, noise, pose = state.player, state.tremor, state.noise, state.pose
    streams = player.streams
    # The kernel fills arrays made here: a compiled function's new arrays cost more to hand back.
    oscillators, stages = np.empty(7), np.empty((2, TrackingNoise.SIZE))
    palm, orientation, joints = np.empty(3), np.empty(4), np.empty((5, N_BONES + 1, 3))
    _jitter(dt, tremor.state, tremor.centre, tremor.base, noise.stages, noise.tau, noise.sd,
            streams.tremor.take(4), streams.noise.take(TrackingNoise.SIZE), pose.position, pose.orientation,
            pose.posture, player.mirror, oscillators, stages, palm, orientation, joints)
    hand = posed_hand(joints, palm, orientation, player.plan.hand)
    return (state.changed(time=t, tremor=Tremor(tremor.centre, tremor.base, oscillators),
                          noise=TrackingNoise(noise.tau, noise.sd, stages)),
            HandFrame.made(t, (hand,)))


@njit(cache=True)
def _jitter(dt, oscillators, centre, base, stages, tau, sd, tremor_draws, noise_draws, position, orientation,
            posture, mirror, next_oscillators, next_stages, palm, palm_orientation, joints):
    """One compiled call a frame: the tremor's and the tracking noise's states ``dt`` later
    (into ``next_oscillators``, ``next_stages``) and the hand they jitter, the intended pose plus
    the tremor and the noise's offsets (into ``palm``, ``palm_orientation`` and ``joints``)."""
    advance_tremor(oscillators, centre, dt, tremor_draws, next_oscillators)
    advance_noise(stages, tau, sd, dt, noise_draws, next_stages)
    shake, offset = np.empty(3), next_stages[1]
    tremor_value(next_oscillators, base, shake)
    for i in range(3):
        palm[i] = position[i] + shake[i] + offset[i]
    palm_orientation[:] = quat_multiply(quat_from_rotation_vector(offset[3:6]), orientation)
    angles = posture.copy()
    for d in range(5):
        for k in range(2):
            angles[d, k] += offset[6 + 2 * d + k]
    pose_joints(angles, KNUCKLES, CARPALS, PHALANGES, palm, palm_orientation, mirror, joints)


class SimulatedParticipant:
    """A ``HandSource`` that plays a ``TaskPlan`` in closed loop: it holds the participant's state
    (``state``) and advances it by one frame per ``next_frame``."""

    def __init__(self, plan: TaskPlan, skill: str | SkillProfile = "veteran", seed: int = 0, *,
                 timing: FrameTiming = MEASURED_TIMING, noise: TrackingNoiseLevels = MEASURED_NOISE,
                 time_limit_s: float = 300.0):
        if not isinstance(plan, TaskPlan):
            raise TypeError(f"plan = {plan!r}: must be a TaskPlan")
        self.plan = plan
        self.skill = skill_profile(skill) if isinstance(skill, str) else skill
        self.seed = int(seed)
        self.description = f"simulated:{self.skill.name}:seed={self.seed}"
        self.state = start(plan, self.skill, self.seed, timing, noise, time_limit_s)
        self.closed = False

    def next_frame(self, observation: Observation | None = None) -> HandFrame | None:
        """The next frame, or None once the participant has finished (or run out of time)."""
        if self.closed:
            return None
        if observation is None:
            raise ValueError(f"{self.description}: a simulated participant is closed-loop; "
                             "next_frame needs the observation of the last frame (microg.task.observe)")
        self.state, frame = advance(self.state, observation)
        return frame

    def close(self) -> None:
        self.closed = True
