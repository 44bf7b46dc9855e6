"""The impulse phase (paper, Eqs. 9-15): one impulse at the onset of a colliding contact.

The hand is kinematic (infinite mass), so only the object's velocities change. With r the contact
point relative to the object's centre of mass and I_w its world inertia, the collision matrix is

    K = (1/m) I - [r]x I_w^-1 [r]x                                  (Eq. 12)

Newton's impact law (Eq. 10) asks the relative normal velocity to go from u_init to -e u_init,
which takes the impulse magnitude

    j = -(1 + e) u_init / (n^T K n)                                 (Eq. 14)

J = j n acts on the hand; the object receives -J at the contact point, changing its linear
velocity by -J/m (Eq. 15) and its angular velocity by I_w^-1 (r x -J).
Contacts that start separating or resting (Eq. 8) get no impulse.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .rotation import cross, quat_to_matrix, skew


@njit(cache=True)
def collision_matrix(mass, inverse_world_inertia, r):
    """K of Eq. 12 for an object hit by a kinematic body at offset r."""
    s = skew(r)
    return np.eye(3) / mass - s @ inverse_world_inertia @ s


@njit(cache=True)
def _apply_impulses(mass, inertia, restitution, position, orientation, velocity, angular_velocity,
                    hand_velocity, onset, anchor, normal, tolerance, impulse):
    n_slots, n_objects = onset.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        inverse_inertia = rot @ np.diag(1.0 / inertia[o]) @ rot.T
        for k in range(n_slots):
            impulse[k, o] = 0.0
            if not onset[k, o]:
                continue
            r = rot @ anchor[k, o]
            n = rot @ normal[k, o]
            relative = hand_velocity[k] - (cross(angular_velocity[o], r) + velocity[o])
            u_init = n @ relative
            if u_init >= -tolerance:
                continue
            j = -(1.0 + restitution[o]) * u_init / (n @ collision_matrix(mass[o], inverse_inertia, r) @ n)
            on_object = -j * n
            velocity[o] += on_object / mass[o]
            angular_velocity[o] += inverse_inertia @ cross(r, on_object)
            impulse[k, o] = j


def apply_impulses(model, data, h: float) -> None:
    """Eqs. 9-15 for every contact that began this step, one after another."""
    _apply_impulses(model.mass, model.inertia, model.restitution, data.position, data.orientation,
                    data.velocity, data.angular_velocity, data.hand_velocity, data.onset, data.anchor,
                    data.normal, model.resting_tolerance, data.impulse)
