"""A compliant contact: spring and damper along the normal, regularised Coulomb friction.

Used where a surface is soft rather than a god-object proxy: the soft-hand baseline's skin and
the table objects rest on. With n the object's outward normal at the contact, delta the depth
and w the relative velocity of the other body's surface with respect to the object's,

    f_n = k delta - c (w . n)                   (pressing force, never pulling)
    f_t = mu f_n w_t / max(|w_t|, v_slip)       (viscous below v_slip, Coulomb above)

and the object receives -f_n n + f_t at the contact point. The friction acts as a damper whose
coefficient gives the Coulomb force at the current sliding speed, and the velocity update treats
it implicitly: friction can stop a sliding object but never reverse it, at any step size. A
contact predicted to release within the step (depth < h times the separating speed) acts with its
mean spring force until then and nothing else, so it never pulls.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .contact import point_velocity
from .wrench import add_point_force, add_point_matrix


@njit(cache=True)
def add_compliant_contact(wrench, stiffness, damping, r, n, depth, other_velocity, velocity, angular_velocity,
                          spring, damper, friction, slip_velocity, h):
    """Accumulate one compliant contact at offset r; returns True when it slides."""
    relative = other_velocity - point_velocity(velocity, angular_velocity, r)
    w_n = relative @ n
    press = spring * depth - damper * w_n
    if press <= 0.0:
        return False
    on_object = -spring * depth * n
    if depth <= h * w_n:
        add_point_force(wrench, r, depth / (2.0 * h * w_n) * on_object)
        return False
    normal_part = np.outer(n, n)
    local_damping = damper * normal_part
    w_t = relative - w_n * n
    speed = np.sqrt(w_t @ w_t)
    if friction > 0.0:
        local_damping += friction * press / max(speed, slip_velocity) * (np.eye(3) - normal_part)
    add_point_force(wrench, r, on_object + (local_damping + h * spring * normal_part) @ other_velocity)
    add_point_matrix(stiffness, r, spring * normal_part)
    add_point_matrix(damping, r, local_damping)
    return speed > slip_velocity
