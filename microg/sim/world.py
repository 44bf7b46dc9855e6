"""The world: static model, dynamic data, and the step that advances them frame by frame.

    world = make_world(scene)
    world = step(world, hand_frame)

    batch = make_batch(scene, 256)                 # 256 independent worlds of one scene
    batch = step_batch(batch, frames)              # frames: 256 HandFrames, or stack_frames(...)

``make_world`` validates the scene once and compiles (or loads from the cache) the step for exactly
the effects the scene names (``pipeline.specialise``). ``step`` takes one hand frame (already
filtered: ``microg.hands.filter``; a ``HandFrame`` or its ``HANDS`` record) and advances the world
to the frame's timestamp in one compiled call: the frame intake (a new track where a hand
appears, its track id changes or it jumped: the jump rule, ``skeleton.is_jump``; the phalanx
slots) and every physics step of ``scene.dt`` that fits, with the hand moving linearly from the
previous frame to this one.

Copy on step: the world's state is three flat buffers (``state``); ``step`` copies them (three
``memcpy``s, a few kilobytes), advances the copy and returns it in a new World, so its argument is
left untouched and a World once returned never changes unless its owner writes to it. The named
fields (``world.data.position`` ...) are views into the buffers, made on first access.

``step_batch`` does the same for a batch of worlds of one model, their buffers stacked on a
leading world axis, in one compiled call: world i of the batch follows exactly the trajectory
``step`` gives it alone (tested).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .bodies import SceneError
from .compiled import attach
from microg.skeleton import HANDS, HandFrame, hands_record
from .mesh import pack_meshes
from .pipeline import specialise, step_worlds
from .scene import Scene
from .state import (CLOCK_FRAME, CLOCK_PREVIOUS_FRAME, CLOCK_START, CLOCK_TIME, COUNT_FRAMES, COUNT_STEPS, FIELDS,
                    PARAMETERS, empty_buffers, pack_params, parameter, view)


@dataclass(frozen=True, eq=False)
class Model:
    """What does not change while the world runs: the scene, its numbers packed for the compiled
    step, and the step. Every parameter of ``state.PARAMETERS`` is an attribute (``model.mass``,
    ``model.dt``, ...): a view into ``params`` or ``ints`` for an array, the number otherwise."""

    scene: Scene
    names: tuple[str, ...]
    effects: frozenset[str]
    params: np.ndarray
    """The model's reals (``state.pack_params``)."""
    ints: np.ndarray
    step: Callable
    """The compiled step of one world for this scene's effects (``pipeline.specialise``)."""
    step_worlds: Callable
    """The same for a batch of worlds (``pipeline.step_worlds``)."""

    @property
    def n_objects(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Position of the named object in the state arrays."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no object named {name!r} in this world (objects: {list(self.names)})") from None


attach(Model, [name for name, *_ in PARAMETERS], lambda model, name: parameter(model.params, model.ints, name))


class Data:
    """Everything that changes: object states, the tracked hand, contacts and god-object anchors.

    Three buffers (``reals``, ``flags``, ``counts``); every field of ``state.FIELDS`` is an
    attribute, a view into them (writing to it writes the state): object poses and velocities (N, ...),
    the phalanx slots (K, ...), contacts (K, N, ...) with anchors and normals in the body frame.
    """

    def __init__(self, n_objects: int, reals: np.ndarray, flags: np.ndarray, counts: np.ndarray):
        self.n_objects, self.reals, self.flags, self.counts = n_objects, reals, flags, counts

    def __getattr__(self, name: str) -> np.ndarray:
        raise AttributeError(f"Data has no field {name!r}")

    time = property(lambda self: float(self.reals[CLOCK_TIME]), doc="Simulated time (s).")
    start_time = property(lambda self: float(self.reals[CLOCK_START]), doc="Time of the first frame (s).")
    frame_time = property(lambda self: float(self.reals[CLOCK_FRAME]), doc="Time of the last frame (s).")
    previous_frame_time = property(lambda self: float(self.reals[CLOCK_PREVIOUS_FRAME]))
    steps = property(lambda self: int(self.counts[COUNT_STEPS]), doc="Physics steps taken.")
    frames = property(lambda self: int(self.counts[COUNT_FRAMES]), doc="Hand frames taken.")

    def copy(self) -> Data:
        return Data(self.n_objects, self.reals.copy(), self.flags.copy(), self.counts.copy())


attach(Data, [name for name, *_ in FIELDS],
       lambda data, name: view((data.reals, data.flags, data.counts), data.n_objects, name))


@dataclass(frozen=True, eq=False)
class World:
    model: Model
    data: Data

    @property
    def time(self) -> float:
        return self.data.time


def make_model(scene: Scene) -> Model:
    """Validate the scene and compile (or load) its step."""
    scene.validate()
    meshes = pack_meshes([placed.spec.mesh for placed in scene.objects]) if scene.has_meshes else None
    params, ints = pack_params(scene, meshes)
    return Model(scene=scene, names=tuple(placed.spec.name for placed in scene.objects), effects=scene.effects,
                 params=params, ints=ints, step=specialise(scene.effects, scene.has_meshes),
                 step_worlds=step_worlds(scene.effects, scene.has_meshes))


def initial_data(model: Model) -> Data:
    """The scene's initial state, no hand seen yet."""
    n = model.n_objects
    data = Data(n, *empty_buffers(n))
    objects = model.scene.objects
    data.position[:] = [p.position for p in objects]
    data.orientation[:] = [p.orientation for p in objects]
    data.velocity[:] = [p.velocity for p in objects]
    data.angular_velocity[:] = [p.angular_velocity for p in objects]
    for name in ("hand_position", "hand_previous", "hand_from", "hand_to"):
        getattr(data, name)[:] = np.nan
    return data


def make_world(scene: Scene) -> World:
    """Validate the scene and build the world at rest at its initial state."""
    model = make_model(scene)
    return World(model, initial_data(model))


def stack_frames(frames: Sequence[HandFrame]) -> np.ndarray:
    """Hand frames as an array of ``microg.skeleton.HANDS`` records, one per world: what the compiled
    step reads."""
    stacked = np.zeros(len(frames), HANDS)
    for i, frame in enumerate(frames):
        hands_record(frame, stacked[i])
    return stacked


MAX_INTERVAL = 60.0
"""s: the longest a world integrates between two hand frames in one call (26 400 steps at the
default dt); a frame further ahead is a clock that jumped, not a pause (the tracking guard
re-anchors such jumps before the physics sees them)."""


def _late(timestamp: float, frame_time: float, frames_seen: int) -> None:
    """Refuse a frame that is not after the last one, or that is more than ``MAX_INTERVAL`` after it."""
    if frames_seen and timestamp <= frame_time:
        raise SceneError(f"hand frame timestamp {timestamp!r} is not after the previous frame's {frame_time!r}; "
                         "order frames (the tracking guard does) before the physics")
    if frames_seen and timestamp - frame_time > MAX_INTERVAL:
        raise SceneError(f"hand frame timestamp {timestamp!r} is {timestamp - frame_time:g} s after the previous "
                         f"frame's {frame_time!r}, more than MAX_INTERVAL = {MAX_INTERVAL:g} s: the clock jumped; "
                         "pass frames through the tracking guard (it re-anchors the clock) or start a new world")


def _step_worlds(model: Model, buffers, frames: np.ndarray) -> None:
    model.step_worlds(model.params, model.ints, *buffers, frames)


def step(world: World, frame: HandFrame | np.void) -> World:
    """Advance the world to the frame's timestamp with the hand as the frame shows it: a
    ``HandFrame``, or the same as a ``HANDS`` record (``stack_frames(frames)[i]``: frames
    converted once, before a loop steps through them; a conversion takes longer than the step)."""
    if isinstance(frame, HandFrame):
        timestamp, frames = frame.timestamp, stack_frames((frame,))
    elif isinstance(frame, np.void) and frame.dtype == HANDS:
        timestamp, frames = float(frame["t"]), np.asarray(frame)[None]
    else:
        raise SceneError(f"step: frame is a {type(frame).__name__} ({getattr(frame, 'dtype', '')}); "
                         "expected a HandFrame or a microg.skeleton.HANDS record (stack_frames(frames)[i])")
    data = world.data
    _late(timestamp, float(data.reals[CLOCK_FRAME]), int(data.counts[COUNT_FRAMES]))
    reals, flags, counts = data.reals.copy(), data.flags.copy(), data.counts.copy()
    _step_worlds(world.model, (reals[None], flags[None], counts[None]), frames)
    return World(world.model, Data(data.n_objects, reals, flags, counts))


@dataclass(frozen=True, eq=False)
class Batch:
    """Independent worlds of one model, their state buffers stacked on a leading world axis."""

    model: Model
    reals: np.ndarray
    flags: np.ndarray
    counts: np.ndarray

    def __len__(self) -> int:
        return self.reals.shape[0]

    def world(self, i: int) -> World:
        """World i, as a view into the batch's buffers (the batch's step copies, so it stays as it is)."""
        return World(self.model, Data(self.model.n_objects, self.reals[i], self.flags[i], self.counts[i]))

    def field(self, name: str) -> np.ndarray:
        """A state field of every world, stacked: e.g. ``batch.field("position")`` is (B, N, 3)."""
        return np.stack([getattr(self.world(i).data, name) for i in range(len(self))])


def make_batch(scene_or_worlds: Scene | Sequence[World], size: int | None = None) -> Batch:
    """A batch of ``size`` copies of the scene's initial world, or of the given worlds (one model)."""
    if isinstance(scene_or_worlds, Scene):
        world = make_world(scene_or_worlds)
        worlds = [world] * int(size)
    else:
        worlds = list(scene_or_worlds)
    model = worlds[0].model
    if any(w.model is not model for w in worlds):
        raise SceneError("a batch's worlds must share one model (make them from one make_world or make_batch)")
    return Batch(model, np.stack([w.data.reals for w in worlds]), np.stack([w.data.flags for w in worlds]),
                 np.stack([w.data.counts for w in worlds]))


def step_batch(batch: Batch, frames: np.ndarray | Sequence[HandFrame]) -> Batch:
    """Advance every world of the batch to its own frame's timestamp (one frame per world, in
    order); returns a new Batch and leaves its argument untouched."""
    if not isinstance(frames, np.ndarray):
        frames = stack_frames(frames)
    if frames.shape != (len(batch),):
        raise SceneError(f"step_batch: {len(frames)} frames for a batch of {len(batch)} worlds")
    interval = frames["t"] - batch.reals[:, CLOCK_FRAME]
    wrong = (batch.counts[:, COUNT_FRAMES] > 0) & ((interval <= 0) | (interval > MAX_INTERVAL))
    if wrong.any():
        i = int(np.argmax(wrong))
        _late(float(frames["t"][i]), float(batch.reals[i, CLOCK_FRAME]), 1)
    buffers = (batch.reals.copy(), batch.flags.copy(), batch.counts.copy())
    _step_worlds(batch.model, buffers, frames)
    return Batch(batch.model, *buffers)
