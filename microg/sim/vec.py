"""3-vectors and 3x3 matrices as tuples, for the compiled kernels.

A vector is ``(x, y, z)``, a matrix the tuple of its rows. Tuples live in registers: a kernel
that works on them allocates nothing, which is most of what makes a substep cheap (a small numpy
array costs a heap allocation each time it is made).
"""

from __future__ import annotations

import math

from .compiled import entry, kernel  # noqa: F401  (the kernels' decorators, used by every physics module)

@kernel
def row(a, i):
    """a[i] of an (n, 3) array as a vector (no view made: a view costs a reference count)."""
    return (a[i, 0], a[i, 1], a[i, 2])


@kernel
def set_row(a, i, v):
    a[i, 0], a[i, 1], a[i, 2] = v[0], v[1], v[2]


@kernel
def cell(a, k, o):
    """a[k, o] of a (K, N, 3) array as a vector."""
    return (a[k, o, 0], a[k, o, 1], a[k, o, 2])


@kernel
def set_cell(a, k, o, v):
    a[k, o, 0], a[k, o, 1], a[k, o, 2] = v[0], v[1], v[2]


@kernel
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@kernel
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@kernel
def scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@kernel
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@kernel
def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@kernel
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@kernel
def mat_vec(m, v):
    """m v."""
    return (dot(m[0], v), dot(m[1], v), dot(m[2], v))


@kernel
def mat_t_vec(m, v):
    """m^T v."""
    return (m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
            m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
            m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2])


@kernel
def rotation(q):
    """Rotation matrix of a unit quaternion (w, x, y, z): its columns are the body axes (Eq. 3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))


@kernel
def conjugated(rot, diagonal):
    """rot diag(diagonal) rot^T: a body-frame principal tensor (inertia) in the world frame."""
    a = (rot[0][0] * diagonal[0], rot[0][1] * diagonal[1], rot[0][2] * diagonal[2])
    b = (rot[1][0] * diagonal[0], rot[1][1] * diagonal[1], rot[1][2] * diagonal[2])
    c = (rot[2][0] * diagonal[0], rot[2][1] * diagonal[1], rot[2][2] * diagonal[2])
    return ((dot(a, rot[0]), dot(a, rot[1]), dot(a, rot[2])),
            (dot(b, rot[0]), dot(b, rot[1]), dot(b, rot[2])),
            (dot(c, rot[0]), dot(c, rot[1]), dot(c, rot[2])))


@kernel
def quat_mul(a, b):
    """Hamilton product a * b: rotate by b, then by a."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


@kernel
def quat_unit(q):
    length = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / length, q[1] / length, q[2] / length, q[3] / length)


@kernel
def quat_turn(v):
    """The rotation by angle |v| about v / |v|."""
    angle = norm(v)
    if angle < 1e-12:
        return quat_unit((1.0, 0.5 * v[0], 0.5 * v[1], 0.5 * v[2]))
    s = math.sin(0.5 * angle) / angle
    return (math.cos(0.5 * angle), s * v[0], s * v[1], s * v[2])
