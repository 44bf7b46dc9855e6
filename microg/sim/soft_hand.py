"""The compliant soft-hand coupling: the comparison baseline, not part of the paper's model.

A soft hand presses on objects through a compliant skin: at every step each overlapping phalanx
pushes with a normal spring and damper and drags the surface with regularised Coulomb friction
(see ``compliant``). There are no god-object anchors and no impulses, so grasps hold through
damping rather than static friction and a fast touch is absorbed rather than bounced.
"""

from __future__ import annotations


from .compliant import add_compliant_contact
from microg.skeleton import SLOTS
from .vec import cell, kernel, mat_vec, row


@kernel
def soft_hand_forces(p, s, o, rot, friction, wrench, stiffness, damping, h):
    """Spring, damper and regularised friction of the soft hand at every phalanx overlapping object o."""
    mu = p.static_friction[o] if friction else 0.0
    velocity, angular_velocity = row(s.velocity, o), row(s.angular_velocity, o)
    for k in range(SLOTS):
        s.sliding[k, o] = False
        if s.active[k, o]:
            s.sliding[k, o] = add_compliant_contact(
                wrench, stiffness, damping, mat_vec(rot, cell(s.anchor, k, o)), mat_vec(rot, cell(s.normal, k, o)),
                s.depth[k, o], row(s.hand_velocity, k), velocity, angular_velocity, p.soft_stiffness,
                p.soft_damping, mu, p.soft_slip_velocity, h)
