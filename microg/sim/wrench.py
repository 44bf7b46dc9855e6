"""Point forces on a rigid body as a generalised force (force, torque), with the stiffness and
damping that the linearly implicit velocity update (``integrate.update_velocity``) needs.

A body point at offset r moves with J u, u = (v, omega), J = [I | -[r]x] (Eq. 7). A contact with
another body whose surface point moves at w pushes, at the end of the next step,

    f(u') = f0 + (D + h K) (w - J u')

(spring K and damper D acting on the relative motion of the two surfaces). It contributes
J^T (f0 + (D + h K) w) to the generalised force, J^T D J to the damping and J^T K J to the
stiffness: symmetric and positive semi-definite, so the velocity update stays well posed for any
mass. (The torque's change as r turns with the body, the geometric stiffness [f]x [r]x, is left
out on purpose: it is not symmetric, can be negative, and for a gram-light object it would rule the
update and make it explode.)

The accumulators are one object's: ``wrench`` (6,), ``stiffness`` and ``damping`` (6, 6); 3x3
matrices are tuples of rows (``vec``).
"""

from __future__ import annotations


from .vec import cross, kernel


@kernel
def outer(c, a, b):
    """c a b^T."""
    return ((c * (a[0] * b[0]), c * (a[0] * b[1]), c * (a[0] * b[2])),
            (c * (a[1] * b[0]), c * (a[1] * b[1]), c * (a[1] * b[2])),
            (c * (a[2] * b[0]), c * (a[2] * b[1]), c * (a[2] * b[2])))


@kernel
def add_point_force(wrench, r, force):
    """Accumulate a force applied at offset r: the force and its torque r x f."""
    torque = cross(r, force)
    for i in range(3):
        wrench[i] += force[i]
        wrench[3 + i] += torque[i]


@kernel
def add_point_matrix(matrix, r, local):
    """Accumulate J^T local J for a 3x3 stiffness or damping acting at offset r:
    [[L, -L [r]x], [[r]x L, -[r]x L [r]x]]."""
    skew = ((0.0, -r[2], r[1]), (r[2], 0.0, -r[0]), (-r[1], r[0], 0.0))
    for i in range(3):
        for j in range(3):
            local_skew = local[i][0] * skew[0][j] + local[i][1] * skew[1][j] + local[i][2] * skew[2][j]
            skew_local = skew[i][0] * local[0][j] + skew[i][1] * local[1][j] + skew[i][2] * local[2][j]
            matrix[i, j] += local[i][j]
            matrix[i, 3 + j] -= local_skew
            matrix[3 + i, j] += skew_local
    for i in range(3):
        for j in range(3):
            total = 0.0
            for m in range(3):
                total += (skew[i][0] * local[0][m] + skew[i][1] * local[1][m] + skew[i][2] * local[2][m]) * skew[m][j]
            matrix[3 + i, 3 + j] -= total
