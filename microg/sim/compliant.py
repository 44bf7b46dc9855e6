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


from .contact import point_velocity
from .vec import add, dot, kernel, mat_vec, norm, scale, sub
from .wrench import add_point_force, add_point_matrix, outer


@kernel
def add_compliant_contact(wrench, stiffness, damping, r, n, depth, other_velocity, velocity, angular_velocity,
                          spring, damper, friction, slip_velocity, h):
    """Accumulate one compliant contact at offset r; returns True when it slides."""
    relative = sub(other_velocity, point_velocity(velocity, angular_velocity, r))
    w_n = dot(relative, n)
    press = spring * depth - damper * w_n
    if press <= 0.0:
        return False
    on_object = scale(-spring * depth, n)
    if depth <= h * w_n:
        add_point_force(wrench, r, scale(depth / (2.0 * h * w_n), on_object))
        return False
    normal_part = outer(1.0, n, n)
    speed = norm(sub(relative, scale(w_n, n)))
    local_damping = outer(damper, n, n)
    if friction > 0.0:
        c = friction * press / max(speed, slip_velocity)
        local_damping = tuple_sum(local_damping, ((c * (1.0 - normal_part[0][0]), c * (0.0 - normal_part[0][1]),
                                                   c * (0.0 - normal_part[0][2])),
                                                  (c * (0.0 - normal_part[1][0]), c * (1.0 - normal_part[1][1]),
                                                   c * (0.0 - normal_part[1][2])),
                                                  (c * (0.0 - normal_part[2][0]), c * (0.0 - normal_part[2][1]),
                                                   c * (1.0 - normal_part[2][2]))))
    spring_part = outer(h * spring, n, n)
    pushing = mat_vec(tuple_sum(local_damping, spring_part), other_velocity)
    add_point_force(wrench, r, add(on_object, pushing))
    add_point_matrix(stiffness, r, outer(spring, n, n))
    add_point_matrix(damping, r, local_damping)
    return speed > slip_velocity


@kernel
def tuple_sum(a, b):
    """a + b for 3x3 tuples."""
    return (add(a[0], b[0]), add(a[1], b[1]), add(a[2], b[2]))
