"""What a study reads off the world after each step: contacts, grasps, highlights, poses.

``snapshot`` reads all a study needs of one object after a step (its pose and velocities, the
phalanges touching it, the grasp, the rendered phalanges) in one compiled call: the study asks it
of every frame, and reading each field from Python costs more than computing them.

Grasp rule: an object is grasped when, on one hand, a thumb phalanx and a phalanx of another
digit are both in contact with it and their contact normals oppose (their dot product is below
``OPPOSITION``, i.e. they press from directions more than 120 degrees apart), so the two squeeze
the object between them. A palm push or two fingers on the same face is not a grasp.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from microg.skeleton import BONES_PER_HAND, N_BONES, SLOTS
from .rotation import quat_to_matrix
from .state import CLOCK_FRAME, CLOCK_TIME, COUNT_FRAMES, unpack
from .vec import add, cell, dot, entry, kernel, mat_vec, rotation, row, scale, set_row
from .world import World

OPPOSITION = -0.5
SNAPSHOT = np.dtype([("t", "f8"), ("time", "f8"), ("position", "f8", (3,)), ("orientation", "f8", (4,)), ("velocity", "f8", (3,)),
                     ("angular_velocity", "f8", (3,)), ("touching", "u1", (SLOTS,)), ("grasped_by", "u1", (2,)),
                     ("rendered", "f8", (SLOTS, 3))], align=True)
"""One object of a world after a step as a record (``Snapshot``'s fields, and the world's simulated
``time``), what compiled code reads: the task's rules, the simulated participant, the frame log."""


class Snapshot(NamedTuple):
    """One object of a world after a step, and the hands' rendered phalanges (copies)."""

    t: float
    """The last frame's time (the world's time before any frame)."""
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    touching: np.ndarray
    """(40,) True where a phalanx slot touches the object (``touching``)."""
    grasped_by: np.ndarray
    """(2,) The grasp rule per hand (left, right): which hands hold the object."""
    rendered: np.ndarray
    """(40, 3) ``rendered_phalanges``."""

    @property
    def grasped(self) -> bool:
        """The module's grasp rule, for this object: either hand holds it."""
        return bool(self.grasped_by.any())


def snapshot(world: World, index: int = 0) -> Snapshot:
    """What a study reads of object ``index`` after a step, in one compiled call (module docstring)."""
    data = world.data
    t, values, touching, by_side = _snapshot(data.reals, data.flags, data.counts, data.n_objects, index)
    return Snapshot(t, values[0:3], values[3:7], values[7:10], values[10:13], touching, by_side,
                    values[13:].reshape(-1, 3))


@entry
def _snapshot(reals, flags, counts, n, index):
    """(t, [position, orientation, velocity, angular velocity, rendered phalanges], touching, which
    hands grasp it): the numbers in one new array, as each array handed back to Python costs a
    microsecond."""
    s = unpack(reals, flags, counts, n)
    t = s.clock[CLOCK_FRAME] if s.counter[COUNT_FRAMES] else s.clock[CLOCK_TIME]
    rendered = _rendered(s.valid, s.hand_position, s.active, s.depth, s.anchor, s.radius, s.normal, s.position,
                         s.orientation)
    values = np.empty(13 + rendered.size)
    values[0:3], values[3:7] = s.position[index], s.orientation[index]
    values[7:10], values[10:13] = s.velocity[index], s.angular_velocity[index]
    values[13:] = rendered.ravel()
    return t, values, s.active[:, index].copy(), _grasped_by(s.active, s.normal)[:, index].copy()


@kernel
def observe(reals, flags, counts, n, index, out, render):
    """What the world shows of object ``index`` into ``out`` (a ``SNAPSHOT`` record): the last
    frame's time, its pose and motion, the phalanges touching it, which hands grasp it and, when
    ``render``, the rendered phalanges (else left as they were)."""
    s = unpack(reals, flags, counts, n)
    out.t = s.clock[CLOCK_FRAME] if s.counter[COUNT_FRAMES] else s.clock[CLOCK_TIME]
    out.time = s.clock[CLOCK_TIME]
    for i in range(3):
        out.position[i], out.velocity[i], out.angular_velocity[i] = s.position[index, i], s.velocity[index, i], \
            s.angular_velocity[index, i]
    for i in range(4):
        out.orientation[i] = s.orientation[index, i]
    for k in range(out.touching.shape[0]):
        out.touching[k] = s.active[k, index]
    for side in range(2):
        out.grasped_by[side] = _hand_grasps(s.active, s.normal, side, index)
    if render:
        _render(s.valid, s.hand_position, s.active, s.depth, s.anchor, s.radius, s.normal, s.position, s.orientation,
                out.rendered)


def touching(world: World) -> np.ndarray:
    """(40, N) True where a phalanx slot is in contact with an object (ghosts excluded)."""
    return world.data.active.copy()


def highlighted(world: World) -> np.ndarray:
    """(40,) True for each phalanx the rendered hand shows highlighted: it touches something."""
    return world.data.active.any(axis=1)


def grasped(world: World) -> np.ndarray:
    """(N,) True for each object held between a thumb and an opposing digit (module rule)."""
    data = world.data
    return _grasped(data.active, data.normal)


@kernel
def _hand_grasps(active, normal, side, o):
    """Whether hand ``side`` holds object ``o``: a thumb phalanx and one of another digit in contact
    with opposing normals (module rule)."""
    first = side * BONES_PER_HAND
    for thumb in range(first, first + N_BONES):
        if not active[thumb, o]:
            continue
        for other in range(first + N_BONES, first + BONES_PER_HAND):
            if active[other, o] and dot(cell(normal, thumb, o), cell(normal, other, o)) < OPPOSITION:
                return True
    return False


@entry
def _grasped_by(active, normal):
    """(hands, N) True where a hand holds an object (module rule)."""
    slots, n = active.shape
    result = np.zeros((slots // BONES_PER_HAND, n), dtype=np.bool_)
    for o in range(n):
        for side in range(slots // BONES_PER_HAND):
            result[side, o] = _hand_grasps(active, normal, side, o)
    return result


@entry
def _grasped(active, normal):
    """(N,) True where either hand holds an object."""
    slots, n = active.shape
    result = np.zeros(n, dtype=np.bool_)
    for o in range(n):
        for side in range(slots // BONES_PER_HAND):
            result[o] = result[o] or _hand_grasps(active, normal, side, o)
    return result


def rendered_phalanges(world: World) -> np.ndarray:
    """(40, 3) centres of the rendered (god-object) phalanges: on the surface where a phalanx is
    in contact (its deepest contact), at the tracked position elsewhere; NaN where untracked."""
    data = world.data
    return _rendered_state(data.reals, data.flags, data.counts, data.n_objects)


@entry
def _rendered_state(reals, flags, counts, n):
    """``_rendered`` on a world's buffers, their views made in the compiled code (the frame log
    asks it of every frame, and Python views cost more than the kernel)."""
    s = unpack(reals, flags, counts, n)
    return _rendered(s.valid, s.hand_position, s.active, s.depth, s.anchor, s.radius, s.normal, s.position,
                     s.orientation)


@entry
def _rendered(valid, hand_position, active, depth, anchor, radius, normal, position, orientation):
    rendered = np.empty((active.shape[0], 3))
    _render(valid, hand_position, active, depth, anchor, radius, normal, position, orientation, rendered)
    return rendered


@kernel
def _render(valid, hand_position, active, depth, anchor, radius, normal, position, orientation, rendered):
    """The rendered phalanges into ``rendered`` (``rendered_phalanges``)."""
    slots, n = active.shape
    for k in range(slots):
        if not valid[k]:
            rendered[k, 0] = rendered[k, 1] = rendered[k, 2] = np.nan
            continue
        deepest = -1
        for o in range(n):
            if active[k, o] and (deepest < 0 or depth[k, o] > depth[k, deepest]):
                deepest = o
        if deepest < 0:
            set_row(rendered, k, row(hand_position, k))
            continue
        centre = add(cell(anchor, k, deepest), scale(radius[k], cell(normal, k, deepest)))
        turned = mat_vec(rotation(orientation[deepest]), centre)
        set_row(rendered, k, add(row(position, deepest), turned))


def object_states(world: World) -> dict[str, dict[str, np.ndarray]]:
    """Pose and velocities of each object by name (copies)."""
    d = world.data
    return {name: {"position": d.position[i].copy(), "orientation": d.orientation[i].copy(),
                   "velocity": d.velocity[i].copy(), "angular_velocity": d.angular_velocity[i].copy()}
            for i, name in enumerate(world.model.names)}


def kinetic_energy(world: World) -> np.ndarray:
    """(N,) translational plus rotational kinetic energy of each object (J)."""
    d, m = world.data, world.model
    energy = 0.5 * m.mass * (d.velocity ** 2).sum(axis=1)
    for o in range(m.n_objects):
        rot = quat_to_matrix(d.orientation[o])
        body = rot.T @ d.angular_velocity[o]
        energy[o] += 0.5 * float(body @ (m.inertia[o] * body))
    return energy


def angular_momentum(world: World) -> np.ndarray:
    """(N, 3) angular momentum of each object about its centre of mass, world frame."""
    d, m = world.data, world.model
    out = np.empty((m.n_objects, 3))
    for o in range(m.n_objects):
        rot = quat_to_matrix(d.orientation[o])
        out[o] = rot @ (m.inertia[o] * (rot.T @ d.angular_velocity[o]))
    return out

