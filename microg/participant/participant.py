"""The simulated participant: a closed-loop motor model that plays the pick-and-place task.

    participant = SimulatedParticipant(plan, "veteran", seed=7)
    while (frame := participant.next_frame(world)) is not None:
        world = step(world, frame)

Each call advances the participant's own clock by one frame interval (``noise.FrameTiming``),
looks at the world (the object's pose, which phalanges touch it, whether it is grasped), decides
what the hand does and returns a Leap-shaped frame: the intended pose plus physiological tremor
plus tracking noise. The task runs as a sequence of phases:

    wait -> reach -> descend -> close -> squeeze -> lift -> carry -> hold (x3, with corrective
    carries) -> open -> retreat -> watch -> done

Reaches, lifts and carries are minimum-jerk movements sized by Fitts' law; the reach follows the
object if it drifts. Closing stops when the world reports a grasp (``observe.grasped``), then the
grip squeezes deeper by an amount sized for the expected load; a visible slip of the object in
the hand squeezes more. A grasp that closes fully without holding, or an object that leaves the
hand (a drop), sends the participant back to reach for the object where it now is (``retry``).
After letting go the participant watches until the object is away from its hand. Every random
draw comes from the seed, in separate streams for timing, decisions, tremor and tracking noise.

Given a ``display`` (a function returning the ``TaskDisplay`` the study shows), the participant
also follows the place marks, as a person does: it holds at a place until the study moves on to
the next one (rather than timing the hold itself), carries back into a place that went dark, goes
back for the object when the study counts a drop, lets go only in the release stage, and stops
when the task is over. Without one it judges everything from the scene and its own clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from microg.sim.bodies import SHAPES
from microg.sim.hand import BONES_PER_HAND, SIDES, SLOT_DIGIT, HandFrame
from microg.sim.observe import grasped
from microg.sim.rotation import quat_from_rotation_vector, quat_multiply, quat_to_matrix
from microg.sim.world import World
from .grasp import CLOSURES, GraspTemplate, plan_grasp
from .motion import minimum_jerk, movement_time, slerp
from .noise import FrameTiming, TrackingNoise, TrackingNoiseLevels, Tremor
from .plan import PickPlacePlan, TaskDisplay
from .skeleton import REST, make_hand
from .skill import SkillProfile, skill_profile

MEASURED_TIMING = FrameTiming()
MEASURED_NOISE = TrackingNoiseLevels()
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
LIFT = np.array([0.0, 0.04, 0.0])
"""The participant first lifts a grasped object straight up this far (m), then carries it."""
RETREAT = np.array([0.0, 0.08, 0.06])
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


def _length(v: np.ndarray) -> float:
    return math.sqrt(float(v @ v))


@dataclass(frozen=True, eq=False)
class Pose:
    """The intended hand: palm position (m), palm orientation (w, x, y, z), joint angles (5, 4)."""

    position: np.ndarray
    orientation: np.ndarray
    posture: np.ndarray


@dataclass(frozen=True, eq=False)
class Movement:
    """A minimum-jerk movement from ``start`` toward ``target()``, re-aimed every frame."""

    start: Pose
    target: Callable[[], Pose]
    begin: float
    duration: float

    def progress(self, t: float) -> float:
        return min(max((t - self.begin) / self.duration, 0.0), 1.0)

    def at(self, t: float) -> Pose:
        target = self.target()
        s = float(minimum_jerk(self.progress(t)))
        return Pose(self.start.position + s * (target.position - self.start.position),
                    slerp(self.start.orientation, target.orientation, s),
                    self.start.posture + s * (target.posture - self.start.posture))


@dataclass(frozen=True, eq=False)
class View:
    """What the participant sees of its object this frame."""

    position: np.ndarray
    orientation: np.ndarray
    rotation: np.ndarray


class SimulatedParticipant:
    """A ``HandSource`` that plays a ``PickPlacePlan`` in closed loop with the world."""

    def __init__(self, plan: PickPlacePlan, skill: str | SkillProfile = "veteran", seed: int = 0, *,
                 timing: FrameTiming = MEASURED_TIMING, noise: TrackingNoiseLevels = MEASURED_NOISE,
                 time_limit_s: float = 300.0, display: Callable[[], TaskDisplay] | None = None):
        if not isinstance(plan, PickPlacePlan):
            raise TypeError(f"plan = {plan!r}: must be a PickPlacePlan")
        self.plan = plan
        self.skill = skill_profile(skill) if isinstance(skill, str) else skill
        self.seed = int(seed)
        self.description = f"simulated:{self.skill.name}:seed={self.seed}"
        self.timing = timing
        self.time_limit_s = float(time_limit_s)
        self.display = display
        self._dark_since: float | None = None
        streams = [np.random.default_rng(s) for s in np.random.SeedSequence(self.seed).spawn(4)]
        self._timing_rng, self._rng, tremor_rng, noise_rng = streams
        self._tremor = Tremor(self.skill.tremor_rms, tremor_rng)
        self._noise = TrackingNoise(noise, noise_rng)
        self._slots = slice(SIDES.index(plan.side) * BONES_PER_HAND, (SIDES.index(plan.side) + 1) * BONES_PER_HAND)
        self._thumb_slots = SLOT_DIGIT[self._slots] == 0
        self.time: float | None = None
        self.phase = "wait"
        self.place_index = 0
        self.drops = 0
        """Objects the participant saw leave its grasp (its own count; the study engine keeps the official one)."""
        self.closed = False
        self._object = -1
        self._pose: Pose | None = None
        self._movement: Movement | None = None
        self._template: GraspTemplate | None = None
        self._template_quat = np.array([1.0, 0.0, 0.0, 0.0])
        self._aim = np.zeros(3)
        self._closure = 0.0
        self._grip = 0.0
        self._phase_start = 0.0
        self._in_hand = np.zeros(3)
        self._close_origin = np.zeros(3)
        self._released_since: float | None = None
        self._hold_clock = 0.0
        self._clock_rate = 1.0
        self._home = np.zeros(3)
        self._go_at = 0.0
        self._seen: View | None = None

    # -- the HandSource interface -------------------------------------------------------------

    def next_frame(self, world: World | None = None) -> HandFrame | None:
        """The next frame, or None once the participant has finished (or run out of time)."""
        if self.closed or self.phase == "done":
            return None
        if world is None:
            raise ValueError(f"{self.description}: a simulated participant is closed-loop; next_frame needs the world")
        if self.time is None:
            self._start(world)
            dt = 0.0
        else:
            dt = self.timing.interval(self._timing_rng)
            self.time += dt
            if self.time > self.time_limit_s:
                self.phase = "done"
                return None
            self._decide(self.time, dt, world)
        return HandFrame(self.time, (self._render(dt),))

    def close(self) -> None:
        self.closed = True

    # -- perception ----------------------------------------------------------------------------

    def _view(self, world: World) -> View:
        q = world.data.orientation[self._object].copy()
        return View(world.data.position[self._object].copy(), q, quat_to_matrix(q))

    def _grasped(self, world: World) -> bool:
        touching = self._touching(world)
        if not (touching[self._thumb_slots].any() and touching[~self._thumb_slots].any()):
            return False
        return bool(grasped(world)[self._object])

    def _touching(self, world: World) -> np.ndarray:
        return world.data.active[self._slots, self._object]

    # -- phases --------------------------------------------------------------------------------

    def _start(self, world: World) -> None:
        try:
            self._object = world.model.index(self.plan.object_name)
        except KeyError as error:
            raise ValueError(f"{self.description}: plan.object_name: {error.args[0]}") from None
        view = self._view(world)
        start = (np.asarray(self.plan.hand_start) if self.plan.hand_start is not None
                 else view.position + np.array([0.0, 0.10, 0.12]))
        self._home = start
        self._pose = Pose(start, np.array([1.0, 0.0, 0.0, 0.0]), REST.copy())
        self.time = 0.0
        self._go_at = self._pause()
        self.phase = "wait"

    def _pause(self) -> float:
        """Reaction time plus hesitation before a new movement (s)."""
        if self.skill.hesitation_s == 0:
            return self.skill.reaction_s
        return self.skill.reaction_s + self._rng.exponential(self.skill.hesitation_s)

    def _enter(self, phase: str, t: float) -> None:
        self.phase = phase
        self._phase_start = t

    def _decide(self, t: float, dt: float, world: World) -> None:
        self._seen = self._view(world)
        if self.display is not None and self._follow_display(t, world):
            return
        getattr(self, f"_on_{self.phase}")(t, dt, world)

    def _follow_display(self, t: float, world: World) -> bool:
        """React to what the task display shows; True when that decided this frame."""
        shown = self.display()
        if shown.stage in ("completed", "timeout"):
            self._enter("done", t)
            return True
        holding = self.phase in ("lift", "carry", "hold")
        if shown.stage == "manipulation" and holding and t - self._phase_start > self.skill.reaction_s:
            self.drops += 1
            self._begin_retry(t, world)
            return True
        return False

    def _on_wait(self, t, dt, world):
        if t >= self._go_at:
            self._begin_reach(t, world)

    def _on_wait_for_object(self, t, dt, world):
        if _length(self._seen.position - self._home) <= REACH_RADIUS:
            self._go_at = t + self._pause()
            self._enter("wait", t)

    def _begin_reach(self, t: float, world: World) -> None:
        view = self._seen
        if _length(view.position - self._home) > REACH_RADIUS:
            self._enter("wait_for_object", t)
            return
        model = world.model
        self._template = plan_grasp(SHAPES[int(model.shape[self._object])], model.half_size[self._object],
                                    view.orientation, self.plan.side)
        self._template_quat = Rotation.from_matrix(self._template.hand_in_object).as_quat(scalar_first=True)
        self._aim = self._rng.normal(0.0, self.skill.aim_sd, 3)
        self._closure = -self.skill.preshape_margin
        start = self._pose
        distance = float(_length(self._grasp_pose(approach=True).position - start.position))
        duration = movement_time(distance, self.skill.preshape_margin, self.skill.movement_intercept,
                                 self.skill.movement_slope)
        self._movement = Movement(start, lambda: self._grasp_pose(approach=True), t, duration)
        self._enter("reach", t)

    def _grasp_pose(self, approach: bool) -> Pose:
        """Where the hand grasps the object as seen now (with this attempt's aim error)."""
        view = self._seen
        palm, rotation = self._template.hand_pose(view.position, view.rotation)
        palm = palm + self._aim
        if approach:
            palm = palm + rotation @ self._template.approach
        return Pose(palm, quat_multiply(view.orientation, self._template_quat), self._template.posture(self._closure))

    def _on_reach(self, t, dt, world):
        self._pose = self._movement.at(t)
        if self._movement.progress(t) >= 1.0:
            duration = movement_time(float(_length(self._template.approach)), self.skill.preshape_margin,
                                     self.skill.movement_intercept, self.skill.movement_slope)
            self._movement = Movement(self._pose, lambda: self._grasp_pose(approach=False), t, duration)
            self._enter("descend", t)

    def _on_descend(self, t, dt, world):
        self._pose = self._movement.at(t)
        if self._movement.progress(t) >= 1.0 or self._touching(world).any():
            self._close_origin = self._seen.position
            self._enter("close", t)

    def _set_closure(self, closure: float) -> None:
        self._closure = closure
        self._pose = Pose(self._pose.position, self._pose.orientation, self._template.posture(closure))

    def _on_close(self, t, dt, world):
        self._set_closure(self._closure + self.skill.closing_speed * dt)
        if self._grasped(world):
            self._grip = self._closure + self._squeeze(world)
            self._enter("squeeze", t)
        elif self._closure >= CLOSURES[-1] or _length(self._seen.position - self._close_origin) > LOST_DISTANCE:
            self._begin_retry(t, world)

    def _squeeze(self, world: World) -> float:
        """Extra closure (m) that holds the expected load: the grip force safety x m (g + a) / (2 mu)
        per side, through the believed stiffness of the phalanges pressing on each side."""
        model = world.model
        touching = self._touching(world)
        thumb = max(int((touching & self._thumb_slots).sum()), 1)
        others = max(int((touching & ~self._thumb_slots).sum()), 1)
        target = np.asarray(self.plan.places[min(self.place_index, 2)])
        distance = float(_length(target - self._seen.position))
        duration = self._carry_time(distance)
        load = float(model.mass[self._object]) * (float(_length(model.gravity)) + PEAK_ACCELERATION * distance / duration ** 2)
        force = self.skill.grip_safety * load / (2.0 * max(float(model.static_friction[self._object]), 0.1))
        stiffness = BELIEVED_STIFFNESS * math.exp(self._rng.normal(0.0, self.skill.stiffness_belief_sd))
        return max(force * (thumb + others) / (2.0 * stiffness * thumb * others), MIN_SQUEEZE)

    def _carry_time(self, distance: float) -> float:
        tolerance = self.skill.place_accept * self.plan.place_radius
        return self.skill.carry_slowdown * movement_time(distance, tolerance, self.skill.movement_intercept,
                                                         self.skill.movement_slope)

    def _on_squeeze(self, t, dt, world):
        self._set_closure(min(self._closure + self.skill.closing_speed * dt, min(self._grip, CLOSURES[-1])))
        if self._check_drop(t, world):
            return
        if self._closure >= min(self._grip, CLOSURES[-1]) and t - self._phase_start >= SETTLE_S:
            self._in_hand = self._object_in_hand()
            start = self._pose
            lifted = start.position + LIFT
            duration = self._carry_time(_length(LIFT))
            self._movement = Movement(start, lambda: Pose(lifted, start.orientation, self._pose.posture), t, duration)
            self._enter("lift", t)

    def _move_holding(self, t: float, dt: float, world: World) -> bool:
        """Advance a movement with the object in the hand; True when it ended with the object held."""
        moving = self._movement.at(t)
        self._pose = Pose(moving.position, moving.orientation, self._pose.posture)
        self._set_closure(min(self._closure + self.skill.closing_speed * dt, self._grip))
        return not self._hold_grip(t, world) and self._movement.progress(t) >= 1.0

    def _on_lift(self, t, dt, world):
        if self._move_holding(t, dt, world):
            self._begin_carry(t, world, self._pause())

    def _object_in_hand(self) -> np.ndarray:
        """The seen object's centre in the intended hand frame."""
        rotation = quat_to_matrix(self._pose.orientation)
        return rotation.T @ (self._seen.position - self._pose.position)

    def _destination(self) -> np.ndarray:
        if self.place_index < 3:
            return np.asarray(self.plan.places[self.place_index])
        return np.asarray(self.plan.release_position)

    def _begin_carry(self, t: float, world: World, pause: float) -> None:
        view = self._seen
        offset = view.position - self._pose.position
        goal = self._destination() + self._rng.normal(0.0, self.skill.aim_sd, 3)
        palm = goal - offset
        start = self._pose
        duration = self._carry_time(float(_length(goal - view.position)))
        self._movement = Movement(start, lambda: Pose(palm, start.orientation, self._pose.posture), t + pause, duration)
        self._enter("carry", t)

    def _hold_grip(self, t: float, world: World) -> bool:
        """Keep the grip: squeeze more after a visible slip; True if the object was dropped."""
        if self._check_drop(t, world):
            return True
        in_hand = self._object_in_hand()
        if _length(in_hand - self._in_hand) > SLIP_DISTANCE and self._grasped(world):
            self._grip = min(self._grip + SLIP_SQUEEZE, CLOSURES[-1])
            self._in_hand = in_hand
        return False

    def _on_carry(self, t, dt, world):
        if self._move_holding(t, dt, world):
            distance = _length(self._seen.position - self._destination())
            if self.place_index == 3 and self._may_let_go():
                self._begin_open(t)
            elif self.place_index == 3:  # the display still shows a place to do
                self.place_index = self.display().place
                self._begin_carry(t, world, self.skill.reaction_s)
            elif distance <= self.skill.place_accept * self.plan.place_radius:
                self._hold_clock = 0.0
                self._clock_rate = 1.0 + self._rng.normal(0.0, self.skill.clock_cv)
                self._dark_since = None
                self._enter("hold", t)
            else:
                self._begin_carry(t, world, self.skill.reaction_s)

    def _on_hold(self, t, dt, world):
        self._set_closure(min(self._closure + self.skill.closing_speed * dt, self._grip))
        if self._hold_grip(t, world):
            return
        distance = _length(self._seen.position - self._destination())
        if distance > self.plan.place_radius or self._dark_too_long(t):
            self._begin_carry(t, world, self.skill.reaction_s)
            return
        if self._hold_done(t, dt):
            self.place_index += 1
            if self.place_index < 3 or self.plan.release_position is not None:
                self._begin_carry(t, world, self._pause())
            else:
                self._begin_open(t)

    def _may_let_go(self) -> bool:
        return self.display is None or self.display().stage == "release"

    def _hold_done(self, t: float, dt: float) -> bool:
        """Own clock: held long enough by its reckoning. Display: the study moved on to the next place."""
        if self.display is None:
            self._hold_clock += dt * self._clock_rate
            return self._hold_clock >= self.plan.hold_s + self.skill.hold_margin_s
        shown = self.display()
        return shown.place > self.place_index or shown.stage == "release"

    def _dark_too_long(self, t: float) -> bool:
        """The place the participant holds at stays dark for longer than a reaction time: it moves
        the object back to the mark's centre."""
        if self.display is None or self.display().lit:
            self._dark_since = None
            return False
        self._dark_since = t if self._dark_since is None else self._dark_since
        return t - self._dark_since > self.skill.reaction_s

    def _check_drop(self, t: float, world: World) -> bool:
        """True once the object has been out of the grasp for ``DROP_CONFIRM_S`` and has left its
        place in the hand (while squeezing, losing the grasp is enough)."""
        displaced = self.phase == "squeeze" or _length(self._object_in_hand() - self._in_hand) > DROP_DISTANCE
        if not displaced or self._grasped(world):
            self._released_since = None
            return False
        if self._released_since is None:
            self._released_since = t
        if t - self._released_since >= DROP_CONFIRM_S:
            self.drops += 1
            self._released_since = None
            self._begin_retry(t, world)
            return True
        return False

    def _begin_retry(self, t: float, world: World) -> None:
        """Open the hand and back off, then reach for the object again where it is."""
        start = self._pose
        rotation = quat_to_matrix(start.orientation)
        back = start.position + rotation @ self._template.approach
        opened = self._template.posture(-self.skill.preshape_margin)
        self._movement = Movement(start, lambda: Pose(back, start.orientation, opened), t, OPEN_S + self.skill.reaction_s)
        self._closure = -self.skill.preshape_margin
        self._enter("retry", t)

    def _on_retry(self, t, dt, world):
        self._pose = self._movement.at(t)
        if self._movement.progress(t) >= 1.0:
            self._begin_reach(t, world)

    def _begin_open(self, t: float) -> None:
        start = self._pose
        opened = self._template.posture(-self.skill.preshape_margin)
        self._movement = Movement(start, lambda: Pose(start.position, start.orientation, opened), t, OPEN_S)
        self._enter("open", t)

    def _on_open(self, t, dt, world):
        self._pose = self._movement.at(t)
        if self._movement.progress(t) >= 1.0:
            start = self._pose
            away = start.position + quat_to_matrix(start.orientation) @ RETREAT
            self._movement = Movement(start, lambda: Pose(away, start.orientation, REST), t, RETREAT_S)
            self._enter("retreat", t)

    def _on_retreat(self, t, dt, world):
        self._pose = self._movement.at(t)
        if self._movement.progress(t) >= 1.0:
            self._enter("watch", t)

    def _on_watch(self, t, dt, world):
        """Stay until the object is seen away from the hand (with a display: until the task shows it
        is over); if it still clings, back off again."""
        away = _length(self._seen.position - self._pose.position) > RELEASED_DISTANCE and not self._grasped(world)
        if away and self.display is None:
            self._enter("done", t)
        elif not away and t - self._phase_start > WATCH_S:
            self._begin_open(t)

    # -- the tracked hand ----------------------------------------------------------------------

    def _render(self, dt: float):
        """The intended pose plus tremor and tracking noise, as a Leap-shaped hand."""
        tremor = self._tremor.advance(dt)
        noise = self._noise.advance(dt)
        pose = self._pose
        palm = pose.position + tremor + noise[:3]
        orientation = quat_multiply(quat_from_rotation_vector(noise[3:6]), pose.orientation)
        angles = pose.posture.copy()
        angles[:, :2] += noise[6:].reshape(5, 2)
        return make_hand(angles, palm, orientation, self.plan.side)
