"""What a study reads off the world after each step: contacts, grasps, highlights, poses.

Grasp rule: an object is grasped when, on one hand, a thumb phalanx and a phalanx of another
digit are both in contact with it and their contact normals oppose (their dot product is below
``OPPOSITION``, i.e. they press from directions more than 120 degrees apart), so the two squeeze
the object between them. A palm push or two fingers on the same face is not a grasp.
"""

from __future__ import annotations

import numpy as np

from .hand import BONES_PER_HAND, N_BONES, SIDES
from .rotation import quat_to_matrix
from .world import World

OPPOSITION = -0.5


def touching(world: World) -> np.ndarray:
    """(40, N) True where a phalanx slot is in contact with an object (ghosts excluded)."""
    return world.data.active.copy()


def highlighted(world: World) -> np.ndarray:
    """(40,) True for each phalanx the rendered hand shows highlighted: it touches something."""
    return world.data.active.any(axis=1)


def grasped(world: World) -> np.ndarray:
    """(N,) True for each object held between a thumb and an opposing digit (module rule)."""
    data = world.data
    active, normal = data.active, data.normal
    result = np.zeros(world.model.n_objects, dtype=bool)
    for side in range(len(SIDES)):
        thumb = slice(side * BONES_PER_HAND, side * BONES_PER_HAND + N_BONES)
        other = slice(side * BONES_PER_HAND + N_BONES, (side + 1) * BONES_PER_HAND)
        if not (active[thumb].any() and active[other].any()):
            continue
        cosines = np.einsum("kni,lni->kln", normal[thumb], normal[other])  # (thumb, other, object)
        result |= (active[thumb][:, None] & active[other][None] & (cosines < OPPOSITION)).any(axis=(0, 1))
    return result


def rotations(orientation: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of (N, 4) unit quaternions (w, x, y, z)."""
    w, x, y, z = orientation.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)],
                    axis=1)


def rendered_phalanges(world: World) -> np.ndarray:
    """(40, 3) centres of the rendered (god-object) phalanges: on the surface where a phalanx is
    in contact (its deepest contact), at the tracked position elsewhere; NaN where untracked."""
    data = world.data
    rendered = np.where(data.valid[:, None], data.hand_position, np.nan)
    touching = np.flatnonzero(data.active.any(axis=1))
    if touching.size:
        deepest = np.argmax(np.where(data.active[touching], data.depth[touching], -np.inf), axis=1)
        centre = data.anchor[touching, deepest] + data.radius[touching, None] * data.normal[touching, deepest]
        turned = np.einsum("kij,kj->ki", rotations(data.orientation)[deepest], centre)
        rendered[touching] = data.position[deepest] + turned
    return rendered


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

