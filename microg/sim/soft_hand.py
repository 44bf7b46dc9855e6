"""The compliant soft-hand coupling: the comparison baseline, not part of the paper's model.

A soft hand presses on objects through a compliant skin: at every step each overlapping phalanx
pushes with a normal spring and damper, and drags the surface with regularised Coulomb friction
(viscous below ``slip_velocity``, mu times the normal force above it). There are no god-object
anchors and no impulses, so grasps hold through damping rather than static friction and a fast
touch is absorbed rather than bounced.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .rotation import cross, quat_to_matrix
from .wrench import add_point_force, add_point_matrix


@njit(cache=True)
def _soft_hand(stiffness_n, damping_n, slip_velocity, friction, static_friction, position, orientation,
               velocity, angular_velocity, hand_velocity, active, anchor, normal, depth, sliding,
               wrench, stiffness, damping):
    n_slots, n_objects = active.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        for k in range(n_slots):
            sliding[k, o] = False
            if not active[k, o]:
                continue
            r = rot @ anchor[k, o]
            n = rot @ normal[k, o]
            relative = hand_velocity[k] - (cross(angular_velocity[o], r) + velocity[o])
            v_n = relative @ n
            press = stiffness_n * depth[k, o] - damping_n * v_n
            if press <= 0.0:
                continue
            normal_part = np.outer(n, n)
            on_object = -stiffness_n * depth[k, o] * n
            local_damping = damping_n * normal_part
            if friction:
                v_t = relative - v_n * n
                speed = np.sqrt(v_t @ v_t)
                limit = static_friction[o] * press
                if speed <= slip_velocity:
                    local_damping += limit / slip_velocity * (np.eye(3) - normal_part)
                else:
                    on_object += limit / speed * v_t
                    sliding[k, o] = True
            add_point_force(wrench[o], r, on_object + local_damping @ hand_velocity[k])
            add_point_matrix(stiffness[o], r, stiffness_n * normal_part)
            add_point_matrix(damping[o], r, local_damping)


def soft_hand_forces(model, data, h: float) -> None:
    """Spring, damper and regularised friction of the soft hand at every overlapping phalanx."""
    p = model.scene.soft_hand
    _soft_hand(p.stiffness, p.damping, p.slip_velocity, "friction" in model.effects, model.static_friction,
               data.position, data.orientation, data.velocity, data.angular_velocity, data.hand_velocity,
               data.active, data.anchor, data.normal, data.depth, data.sliding, data.wrench,
               data.stiffness, data.damping)
