"""Point forces on a rigid body as a generalised force (force, torque), with the stiffness and
damping that the linearly implicit velocity update (``integrate.integrate_velocity``) needs.

A body point at offset r moves with J u, u = (v, omega), J = [I | -[r]x] (Eq. 7). A contact with
another body whose surface point moves at w pushes, at the end of the next step,

    f(u') = f0 + (D + h K) (w - J u')

(spring K and damper D acting on the relative motion of the two surfaces). It contributes
J^T (f0 + (D + h K) w) to the generalised force, J^T D J to the damping and J^T K J to the
stiffness: symmetric and positive semi-definite, so the velocity update stays well posed for any
mass. (The torque's change as r turns with the body, the geometric stiffness [f]x [r]x, is left
out on purpose: it is not symmetric, can be negative, and for a gram-light object it would rule the
update and make it explode.)
"""

from __future__ import annotations

from numba import njit

from .rotation import cross, skew


@njit(cache=True)
def add_point_force(wrench, r, force):
    """Accumulate a force applied at offset r: the force and its torque r x f."""
    wrench[:3] += force
    wrench[3:] += cross(r, force)


@njit(cache=True)
def add_point_matrix(matrix, r, local):
    """Accumulate J^T local J for a 3x3 stiffness or damping acting at offset r."""
    s = skew(r)
    matrix[:3, :3] += local
    matrix[:3, 3:] -= local @ s
    matrix[3:, :3] += s @ local
    matrix[3:, 3:] -= s @ local @ s
