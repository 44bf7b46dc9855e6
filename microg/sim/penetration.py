"""The penetration phase (paper, Eqs. 16-20): a spring from each god-object proxy to its phalanx.

For a phalanx in contact, with c its anchor on the surface and s its innermost point (the
centroid p moved by the radius against the normal, so a sphere that only touches feels nothing):

    f = gamma (c - s)                                  (Eq. 16, gamma = 100 N/m)
    f_n = (f . n) n,  f_t = f - f_n                    (Eqs. 17-18)

f pulls the rendered hand out of the object; the object receives -f, as force and torque. Since
c - s = (c + rho n) - p, f is a spring between the tracked phalanx centre and the god-object
phalanx centre c + rho n, a point fixed in the object: the torque is taken there. For a point
phalanx (the paper's, rho = 0) that is c itself; for a sphere the normal part has the same torque
at either point, and only there does the spring's energy add up (applied at c, the friction part
would turn with a torque off by rho n x f_t and a still hand could spin an object up).
The velocity update treats the spring implicitly on the *relative* motion of hand and object over
the step (both move; see ``wrench``), and a spring only pushes: a contact predicted to release
within the step (depth < h times its separating speed, Eq. 8) acts with its mean force until the
release and adds no stiffness, so an object leaving a finger is never pulled back.

Two stages. ``friction_cone`` (Eqs. 19-20) runs first: inside the cone, f . n > 0 and
|f_t| <= mu (f . n), the contact sticks and the anchor stays; outside it the anchor slides along
the surface until the tangential pull is the dynamic friction, |f_t| = phi (f . n) (Eq. 20 read
as Coulomb's law: kinetic friction is phi times the normal force, so a fast tangential jerk cannot
pull harder than friction allows). ``penetration_forces`` then applies f. In a scene
without friction the surface is frictionless: the anchor follows the phalanx's projection on the
face and only f_n acts.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .contact import point_velocity, project_to_surface
from .rotation import quat_to_matrix
from .wrench import add_point_force, add_point_matrix


@njit(cache=True)
def _spring_offset(rot, position, hand_position, radius, anchor, normal):
    """c - s in the body frame, its normal length delta and its tangential part."""
    p = rot.T @ (hand_position - position)
    offset = anchor - (p - radius * normal)
    delta = offset @ normal
    return offset, delta, offset - delta * normal


@njit(cache=True)
def _friction_cone(static_friction, dynamic_friction, shape, half_size, position, orientation,
                   hand_position, radius, active, anchor, normal, sliding):
    n_slots, n_objects = active.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        for k in range(n_slots):
            sliding[k, o] = False
            if not active[k, o]:
                continue
            _, delta, tangential = _spring_offset(rot, position[o], hand_position[k], radius[k],
                                                  anchor[k, o], normal[k, o])
            length = np.sqrt(tangential @ tangential)
            if length > static_friction[o] * delta:
                moved = anchor[k, o] - (length - dynamic_friction[o] * delta) / length * tangential
                anchor[k, o], normal[k, o] = project_to_surface(shape[o], half_size[o], moved, normal[k, o])
                sliding[k, o] = True


def friction_cone(model, data, h: float) -> None:
    """Eqs. 19-20: each contact sticks inside the cone, or its anchor slides to dynamic friction."""
    _friction_cone(model.static_friction, model.dynamic_friction, model.shape, model.half_size,
                   data.position, data.orientation, data.hand_position, data.radius, data.active,
                   data.anchor, data.normal, data.sliding)


@njit(cache=True)
def _penetration(gamma, friction, dynamic_friction, shape, half_size, position, orientation, velocity,
                 angular_velocity, hand_position, hand_velocity, radius, active, anchor, normal, depth, sliding,
                 wrench, stiffness, h):
    n_slots, n_objects = active.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        for k in range(n_slots):
            if not active[k, o]:
                continue
            offset, delta, tangential = _spring_offset(rot, position[o], hand_position[k], radius[k],
                                                       anchor[k, o], normal[k, o])
            if not friction:
                anchor[k, o], normal[k, o] = project_to_surface(shape[o], half_size[o],
                                                                anchor[k, o] - tangential, normal[k, o])
                offset, delta, tangential = _spring_offset(rot, position[o], hand_position[k], radius[k],
                                                           anchor[k, o], normal[k, o])
            depth[k, o] = delta
            if delta <= 0.0:  # off the face it pressed on: nothing presses, nothing pulls
                continue
            if not friction or sliding[k, o]:  # an anchor held at a face's edge cannot pull past the cone
                limit = dynamic_friction[o] * delta if friction else 0.0
                length = np.sqrt(tangential @ tangential)
                if length > limit:
                    offset = delta * normal[k, o] + limit / length * tangential
            n_world = rot @ normal[k, o]
            r = rot @ anchor[k, o] + radius[k] * n_world
            on_object = -gamma * (rot @ offset)
            separating = n_world @ (hand_velocity[k] - point_velocity(velocity[o], angular_velocity[o], r))
            if delta <= h * separating:
                add_point_force(wrench[o], r, delta / (2.0 * h * separating) * on_object)
                continue
            local = gamma * np.eye(3) if friction and not sliding[k, o] else gamma * np.outer(n_world, n_world)
            add_point_force(wrench[o], r, on_object + h * (local @ hand_velocity[k]))
            add_point_matrix(stiffness[o], r, local)


def penetration_forces(model, data, h: float) -> None:
    """Eqs. 16-18: the spring force of every contact, applied to the object at its god-object phalanx."""
    _penetration(model.penetration_stiffness, "friction" in model.effects, model.dynamic_friction, model.shape,
                 model.half_size, data.position, data.orientation, data.velocity, data.angular_velocity,
                 data.hand_position, data.hand_velocity, data.radius, data.active, data.anchor, data.normal,
                 data.depth, data.sliding, data.wrench, data.stiffness, h)
