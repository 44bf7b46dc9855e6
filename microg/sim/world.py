"""The world: static model, dynamic data, and the step that advances them frame by frame.

    world = make_world(scene)
    world = step(world, hand_frame)

``make_world`` validates the scene once and assembles the step from exactly the stages the scene's
effects call for. ``step`` takes one hand frame (already filtered: ``microg.hands.filter``), notes
which hands start a new track, then runs as many fixed physics steps of ``scene.dt`` as fit up to
the frame's timestamp, moving the hand linearly from the previous frame to this one. It returns a new World
and leaves its argument untouched; inside, the stages update one private copy in place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Callable

import numpy as np

from .bodies import SHAPES, SceneError
from .contact import detect_contacts, sweep_contacts
from .hand import BONES_PER_HAND, N_BONES, N_DIGITS, SIDES, SLOTS, Hand, HandFrame, bone_centres, is_jump, phalanx_mask
from .impulse import apply_impulses
from .integrate import (EXPLICIT_EULER, MIDPOINT, SEMI_IMPLICIT_EULER, apply_gravity, integrate_position,
                        integrate_velocity, rotate_free, rotate_without_gyroscopic)
from .penetration import friction_cone, penetration_forces
from .scene import Scene
from .soft_hand import soft_hand_forces
from .table import table_contacts

CONTACT_EFFECTS = frozenset({"impulse", "penetration", "soft_hand"})
MAX_TURN = 0.1
"""rad: the most an object may turn in one physics step; faster spins cut the step into parts."""
MAX_PARTS = 64
_METHODS = {"midpoint": MIDPOINT, "semi_implicit_euler": SEMI_IMPLICIT_EULER, "explicit_euler": EXPLICIT_EULER}


@dataclass(frozen=True, eq=False)
class Model:
    """What does not change while the world runs: the scene as arrays, and the assembled step."""

    scene: Scene
    names: tuple[str, ...]
    effects: frozenset[str]
    shape: np.ndarray
    half_size: np.ndarray
    """(N, 3) box half extents; a sphere's radius in every column."""
    mass: np.ndarray
    inertia: np.ndarray
    """(N, 3) principal moments in the body frame."""
    restitution: np.ndarray
    static_friction: np.ndarray
    dynamic_friction: np.ndarray
    gravity: np.ndarray
    penetration_stiffness: float
    resting_tolerance: float
    angular_method: int
    dt: float
    stage_names: tuple[str, ...]
    stages: tuple[Callable, ...]

    @property
    def n_objects(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Position of the named object in the state arrays."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no object named {name!r} in this world (objects: {list(self.names)})") from None


@dataclass(eq=False)
class Data:
    """Everything that changes: object states, the tracked hand, contacts and god-object anchors."""

    time: float
    steps: int
    start_time: float
    frame_time: float
    previous_frame_time: float
    frames: int
    # objects (N, ...)
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    wrench: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    # tracked hand, per phalanx slot (K, ...)
    hand_position: np.ndarray
    hand_previous: np.ndarray
    hand_from: np.ndarray
    hand_to: np.ndarray
    hand_velocity: np.ndarray
    radius: np.ndarray
    valid: np.ndarray
    fresh: np.ndarray
    # per hand side
    joints: np.ndarray
    """(2, 5, 5, 3) the tracked skeleton of each side; NaN when absent."""
    present: np.ndarray
    track_id: np.ndarray
    reference: np.ndarray
    """(2, 26, 3) palm and joints of each side's last hand, for the jump rule."""
    # contacts (K, N, ...); anchors and normals in the object's body frame
    active: np.ndarray
    ghost: np.ndarray
    onset: np.ndarray
    sliding: np.ndarray
    anchor: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    normal_velocity: np.ndarray
    impulse: np.ndarray

    def copy(self) -> Data:
        return Data(**{f.name: (v.copy() if isinstance(v := getattr(self, f.name), np.ndarray) else v)
                       for f in fields(self)})


@dataclass(frozen=True, eq=False)
class World:
    model: Model
    data: Data

    @property
    def time(self) -> float:
        return self.data.time


def move_hand(model: Model, data: Data, h: float) -> None:
    """Place the phalanges for the end of this step, on the line from the last frame to this one;
    a new step starts with no contact onsets."""
    data.onset[:] = False
    data.hand_previous[:] = data.hand_position
    interval = data.frame_time - data.previous_frame_time
    alpha = 1.0 if interval <= 0 else min(1.0, (data.time + h - data.previous_frame_time) / interval)
    data.hand_position[:] = data.hand_from + alpha * (data.hand_to - data.hand_from)


STAGES: dict[str, Callable] = {
    "move_hand": move_hand,
    "detect_contacts": detect_contacts,
    "continuous_collision": sweep_contacts,
    "impulse": apply_impulses,
    "friction": friction_cone,
    "penetration": penetration_forces,
    "soft_hand": soft_hand_forces,
    "gravity": apply_gravity,
    "table": table_contacts,
    "integrate_velocity": integrate_velocity,
    "integrate_position": integrate_position,
    "gyroscopic": rotate_free,
    "rotate_without_gyroscopic": rotate_without_gyroscopic,
}
"""Every stage by name. ``make_world`` looks stages up here, so a test can count their calls."""


def substep_stages(effects: frozenset[str]) -> tuple[str, ...]:
    """The physics step's stages, in order, for a set of effects: nothing unnamed runs."""
    names = ["move_hand"]
    if effects & CONTACT_EFFECTS:
        if "continuous_collision" in effects:
            names.append("continuous_collision")
        names.append("detect_contacts")
    if "impulse" in effects:
        names.append("impulse")
    if {"penetration", "friction"} <= effects:
        names.append("friction")
    names += [e for e in ("penetration", "soft_hand", "gravity", "table") if e in effects]
    names += ["integrate_velocity", "integrate_position"]
    names.append("gyroscopic" if "gyroscopic" in effects else "rotate_without_gyroscopic")
    return tuple(names)


def make_world(scene: Scene) -> World:
    """Validate the scene and build the world at rest at its initial state."""
    scene.validate()
    specs = [p.spec for p in scene.objects]
    names = tuple(s.name for s in specs)
    stage_names = substep_stages(scene.effects)
    model = Model(
        scene=scene, names=names, effects=scene.effects,
        shape=np.array([SHAPES.index(s.shape) for s in specs], dtype=np.int64),
        half_size=np.array([s.half_extents for s in specs]),
        mass=np.array([s.mass for s in specs], dtype=np.float64),
        inertia=np.array([s.principal_inertia for s in specs]),
        restitution=np.array([s.material.restitution for s in specs], dtype=np.float64),
        static_friction=np.array([s.material.static_friction for s in specs], dtype=np.float64),
        dynamic_friction=np.array([s.material.dynamic_friction for s in specs], dtype=np.float64),
        gravity=np.asarray(scene.gravity, dtype=np.float64),
        penetration_stiffness=float(scene.penetration_stiffness),
        resting_tolerance=float(scene.resting_tolerance),
        angular_method=_METHODS[scene.angular_integrator],
        dt=scene.dt, stage_names=stage_names, stages=tuple(STAGES[n] for n in stage_names),
    )
    n = len(specs)
    nan_slots = np.full((SLOTS, 3), np.nan)
    data = Data(
        time=0.0, steps=0, start_time=0.0, frame_time=0.0, previous_frame_time=0.0, frames=0,
        position=np.array([p.position for p in scene.objects], dtype=np.float64),
        orientation=np.array([p.orientation for p in scene.objects], dtype=np.float64),
        velocity=np.array([p.velocity for p in scene.objects], dtype=np.float64),
        angular_velocity=np.array([p.angular_velocity for p in scene.objects], dtype=np.float64),
        wrench=np.zeros((n, 6)), stiffness=np.zeros((n, 6, 6)), damping=np.zeros((n, 6, 6)),
        hand_position=nan_slots.copy(), hand_previous=nan_slots.copy(), hand_from=nan_slots.copy(),
        hand_to=nan_slots.copy(), hand_velocity=np.zeros((SLOTS, 3)), radius=np.zeros(SLOTS),
        valid=np.zeros(SLOTS, dtype=bool), fresh=np.zeros(SLOTS, dtype=bool),
        joints=np.full((2, N_DIGITS, N_BONES + 1, 3), np.nan), present=np.zeros(2, dtype=bool),
        track_id=np.zeros(2, dtype=np.int64), reference=np.full((2, 1 + N_DIGITS * (N_BONES + 1), 3), np.nan),
        active=np.zeros((SLOTS, n), dtype=bool), ghost=np.zeros((SLOTS, n), dtype=bool),
        onset=np.zeros((SLOTS, n), dtype=bool), sliding=np.zeros((SLOTS, n), dtype=bool),
        anchor=np.zeros((SLOTS, n, 3)), normal=np.zeros((SLOTS, n, 3)), depth=np.zeros((SLOTS, n)),
        normal_velocity=np.zeros((SLOTS, n)), impulse=np.zeros((SLOTS, n)),
    )
    return World(model, data)


def _track_changes(model: Model, data: Data, hands: tuple[Hand | None, ...]) -> np.ndarray:
    """Which sides start a new track this frame: the hand (re)appeared, changed id, or jumped
    (``hand.is_jump``: a caller that skips the tracking guard is protected too)."""
    new_track = np.zeros(2, dtype=bool)
    for side, hand in enumerate(hands):
        if hand is None:
            data.present[side] = False
            continue
        points = hand.points
        jumped = is_jump(points, data.reference[side], model.scene.jump_distance)
        new_track[side] = not data.present[side] or hand.track_id != data.track_id[side] or jumped
        data.present[side] = True
        data.track_id[side] = hand.track_id
        data.reference[side] = points
    return new_track


def _take_hand(data: Data, hands: tuple[Hand | None, ...], joints: list, new_track: np.ndarray,
               interval: float) -> None:
    """Set each phalanx's path for the coming steps from the (filtered) joints.

    A phalanx whose track starts here (new track, or newly valid) has no velocity yet, and stays
    ``fresh`` until a physics step has looked at it: an overlap found then makes it a ghost.
    """
    data.hand_from[:] = data.hand_to
    restart = np.zeros(SLOTS, dtype=bool)
    for side, hand in enumerate(hands):
        slots = slice(side * BONES_PER_HAND, (side + 1) * BONES_PER_HAND)
        if joints[side] is None:
            data.valid[slots] = False
            data.joints[side] = np.nan
            data.hand_to[slots] = np.nan
            continue
        widths = hand.widths
        valid = phalanx_mask(joints[side], widths).reshape(-1)
        data.joints[side] = joints[side]
        data.hand_to[slots] = bone_centres(joints[side]).reshape(-1, 3)
        data.radius[slots] = np.where(valid, widths.reshape(-1) / 2, 0.0)
        restart[slots] = valid & (new_track[side] | ~data.valid[slots])
        data.valid[slots] = valid
    data.hand_from[restart] = data.hand_to[restart]
    data.hand_position[restart] = data.hand_to[restart]
    data.fresh[:] = data.valid & (restart | data.fresh)
    moving = data.valid & ~restart
    data.hand_velocity[:] = 0.0
    if interval > 0:
        data.hand_velocity[moving] = (data.hand_to[moving] - data.hand_from[moving]) / interval


def step(world: World, frame: HandFrame) -> World:
    """Advance the world to ``frame.timestamp`` with the hand as the frame shows it."""
    model, data = world.model, world.data.copy()
    if data.frames and frame.timestamp <= data.frame_time:
        raise SceneError(f"hand frame timestamp {frame.timestamp!r} is not after the previous frame's "
                         f"{data.frame_time!r}; order frames (the tracking guard does) before the physics")
    if not data.frames:
        data.start_time = data.time = data.previous_frame_time = frame.timestamp
    else:
        data.previous_frame_time = data.frame_time
    data.frame_time = frame.timestamp
    hands = tuple(frame.hand(side) for side in SIDES)
    new_track = _track_changes(model, data, hands)
    joints = [None if hand is None else hand.joints for hand in hands]
    _take_hand(data, hands, joints, new_track, data.frame_time - data.previous_frame_time)
    data.frames += 1
    h = model.dt
    target = math.floor((data.frame_time - data.start_time) / h + 1e-9)
    while data.steps < target:
        parts = _parts(data, h)
        for _ in range(parts):
            for stage in model.stages:
                stage(model, data, h / parts)
            data.fresh[:] = False
            data.time += h / parts
        data.steps += 1
        data.time = data.start_time + data.steps * h
    return World(model, data)


def _parts(data: Data, h: float) -> int:
    """Into how many parts a step must be cut so that no object turns more than ``MAX_TURN`` in
    one: a hard impact can spin a light bar up to hundreds of rad/s, which a contact linearised
    over a whole step would no longer follow (it could even add energy). One part almost always."""
    fastest = float(np.sqrt((data.angular_velocity ** 2).sum(axis=1).max(initial=0.0)))
    return min(MAX_PARTS, max(1, math.ceil(fastest * h / MAX_TURN)))
