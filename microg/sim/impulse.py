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

Several colliding contacts that start on one object in the same step (a face landing on four
fingertips) are solved together: the impulses j_k make every contact obey Newton's law with the
others' impulses counted, sum_l n_k^T K_kl n_l j_l = -(1 + e) u_k, with
K_kl = (1/m) I - [r_k]x I_w^-1 [r_l]x, and each j_k lies between 0 (a contact never pulls) and the
impulse Eq. 14 gives that contact alone (the paper computes each contact independently; no
contact hits harder than it would alone). Where the contacts do not determine the impulses (four
points on one face) the smallest are taken, which shares them evenly; where they cannot all be
met (two fingers closing on an object from both sides) the bounded contacts leave the rest to the
penetration phase. For one contact this is Eq. 14. Applied together, independent impulses on a
flat landing would add up to four times the bounce; applied one after another, the first contact
would take it all and set the object spinning.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .contact import COLLIDING, classify, point_velocity
from .rotation import cross, quat_to_matrix, skew


@njit(cache=True)
def collision_matrix(mass, inverse_world_inertia, r_a, r_b):
    """K_ab: the change of the object's velocity at offset r_a per unit impulse at offset r_b
    from a kinematic body. K_aa is Eq. 12."""
    return np.eye(3) / mass - skew(r_a) @ inverse_world_inertia @ skew(r_b)


@njit(cache=True)
def _simultaneous_impulses(mass, inverse_inertia, arms, normals, u_init, restitution):
    """Impulse magnitudes for contacts that collide together (see module docstring)."""
    count = arms.shape[0]
    matrix = np.empty((count, count))
    for a in range(count):
        for b in range(count):
            matrix[a, b] = normals[a] @ collision_matrix(mass, inverse_inertia, arms[a], arms[b]) @ normals[b]
    target = -(1.0 + restitution) * u_init
    alone = target / np.diag(matrix)
    j = np.zeros(count)
    free = np.ones(count, dtype=np.bool_)
    for _ in range(count):
        index, fixed = np.flatnonzero(free), np.flatnonzero(~free)
        rhs = target[index] - matrix[index][:, fixed] @ j[fixed]
        j[index] = np.linalg.lstsq(matrix[index][:, index], rhs, rcond=1e-12)[0]
        excess = np.maximum(-j[index], j[index] - alone[index]) / alone[index]
        worst = np.argmax(excess)
        if excess[worst] <= 1e-12:
            break
        k = index[worst]
        j[k] = 0.0 if j[k] < 0.0 else alone[k]
        free[k] = False
    return np.minimum(np.maximum(j, 0.0), alone)


@njit(cache=True)
def _apply_impulses(mass, inertia, restitution, position, orientation, velocity, angular_velocity,
                    hand_velocity, onset, anchor, normal, tolerance, impulse):
    n_slots, n_objects = onset.shape
    impulse[:] = 0.0
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        inverse_inertia = rot @ np.diag(1.0 / inertia[o]) @ rot.T
        slots = np.empty(n_slots, dtype=np.int64)
        arms, normals, u_init = np.empty((n_slots, 3)), np.empty((n_slots, 3)), np.empty(n_slots)
        count = 0
        for k in range(n_slots):
            if not onset[k, o]:
                continue
            r = rot @ anchor[k, o]
            n = rot @ normal[k, o]
            u = n @ (hand_velocity[k] - point_velocity(velocity[o], angular_velocity[o], r))
            if classify(u, tolerance) == COLLIDING:
                slots[count], arms[count], normals[count], u_init[count] = k, r, n, u
                count += 1
        if count == 0:
            continue
        j = _simultaneous_impulses(mass[o], inverse_inertia, arms[:count], normals[:count], u_init[:count],
                                   restitution[o])
        for i in range(count):
            on_object = -j[i] * normals[i]
            velocity[o] += on_object / mass[o]
            angular_velocity[o] += inverse_inertia @ cross(arms[i], on_object)
            impulse[slots[i], o] = j[i]


def apply_impulses(model, data, h: float) -> None:
    """Eqs. 9-15 for the contacts that began colliding this step, solved together per object."""
    _apply_impulses(model.mass, model.inertia, model.restitution, data.position, data.orientation,
                    data.velocity, data.angular_velocity, data.hand_velocity, data.onset, data.anchor,
                    data.normal, model.resting_tolerance, data.impulse)
