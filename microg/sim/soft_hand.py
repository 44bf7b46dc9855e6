"""The compliant soft-hand coupling: the comparison baseline, not part of the paper's model.

A soft hand presses on objects through a compliant skin: at every step each overlapping phalanx
pushes with a normal spring and damper and drags the surface with regularised Coulomb friction
(see ``compliant``). There are no god-object anchors and no impulses, so grasps hold through
damping rather than static friction and a fast touch is absorbed rather than bounced.
"""

from __future__ import annotations

from numba import njit

from .compliant import add_compliant_contact
from .rotation import quat_to_matrix


@njit(cache=True)
def _soft_hand(spring, damper, slip_velocity, friction, static_friction, position, orientation, velocity,
               angular_velocity, hand_velocity, active, anchor, normal, depth, sliding, wrench, stiffness, damping, h):
    n_slots, n_objects = active.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        for k in range(n_slots):
            sliding[k, o] = False
            if active[k, o]:
                sliding[k, o] = add_compliant_contact(
                    wrench[o], stiffness[o], damping[o], rot @ anchor[k, o], rot @ normal[k, o], depth[k, o],
                    hand_velocity[k], velocity[o], angular_velocity[o], spring, damper,
                    static_friction[o] if friction else 0.0, slip_velocity, h)


def soft_hand_forces(model, data, h: float) -> None:
    """Spring, damper and regularised friction of the soft hand at every overlapping phalanx."""
    p = model.scene.soft_hand
    _soft_hand(p.stiffness, p.damping, p.slip_velocity, "friction" in model.effects, model.static_friction,
               data.position, data.orientation, data.velocity, data.angular_velocity, data.hand_velocity,
               data.active, data.anchor, data.normal, data.depth, data.sliding, data.wrench,
               data.stiffness, data.damping, h)
