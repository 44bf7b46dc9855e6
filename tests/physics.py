"""Small drivers shared by the physics tests: run a world along a scripted hand path."""

from __future__ import annotations

import numpy as np

from microg.skeleton import HandFrame
from microg.sim import PlacedObject, compose_scene, load_object, make_world, step
from microg.participant.scripted import probe_hand
from microg.paths import object_file

RATE = 110.0


def placed(name: str, position=(0.0, 0.2, 0.0), **state) -> PlacedObject:
    return PlacedObject(load_object(object_file(name)), tuple(position), **state)


def world_of(objects, effects=None, interaction="impulse_penetration", gravity=(0.0, 0.0, 0.0), **options):
    """A world with exactly ``effects`` when given, else ``interaction`` plus the usual effects."""
    if effects is not None:
        from microg.sim import Scene
        return make_world(Scene(objects=tuple(objects), effects=frozenset(effects), gravity=gravity, **options))
    return make_world(compose_scene(objects, interaction, gravity=gravity, **options))


def probe_frames(path, t_end, t_start=0.0, rate=RATE, width=0.016, side="right", track_id=0) -> list[HandFrame]:
    """Frames of a probe hand following ``path(t) -> {phalanx: position}`` (None: no hand)."""
    frames = []
    for t in np.arange(t_start, t_end + 1e-12, 1.0 / rate):
        phalanges = path(t)
        hands = () if phalanges is None else (probe_hand(phalanges, side, width, track_id),)
        frames.append(HandFrame(float(t), hands))
    return frames


def drive(world, path, t_end, t_start=0.0, rate=RATE, width=0.016, side="right"):
    """Step ``world`` with a probe hand following ``path(t) -> {phalanx: position}`` (None: no hand)."""
    for frame in probe_frames(path, t_end, t_start, rate, width, side):
        world = step(world, frame)
    return world


def through_guard(frames: list[HandFrame]) -> list[HandFrame]:
    """The frames as hand tracking's guard passes them on (``microg.hands.guard``, the jump rule's
    one place): a hand that jumped and stayed comes with a new track id."""
    from microg.hands import Guard

    guard = Guard()
    return [out for frame in frames for out in guard.admit(frame)] + list(guard.finish())


def coast(world, duration, rate=10.0):
    """Advance without a hand for ``duration`` seconds."""
    if not world.data.frames:
        world = step(world, HandFrame(world.time))
    t0 = world.time
    for t in np.arange(t0 + 1.0 / rate, t0 + duration + 1e-12, 1.0 / rate):
        world = step(world, HandFrame(float(t)))
    return world
