"""Unit quaternions (w, x, y, z) and the small rotation helpers the physics needs."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def quat_multiply(a, b):
    """Hamilton product a * b: rotate by b, then by a."""
    w1, x1, y1, z1 = a[0], a[1], a[2], a[3]
    w2, x2, y2, z2 = b[0], b[1], b[2], b[3]
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


@njit(cache=True)
def quat_normalize(q):
    return q / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])


@njit(cache=True)
def quat_to_matrix(q):
    """Rotation matrix R with columns the body axes in world coordinates (paper, Eq. 3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


@njit(cache=True)
def quat_from_rotation_vector(v):
    """The rotation by angle |v| about v / |v|."""
    angle = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if angle < 1e-12:
        return quat_normalize(np.array([1.0, 0.5 * v[0], 0.5 * v[1], 0.5 * v[2]]))
    s = np.sin(0.5 * angle) / angle
    return np.array([np.cos(0.5 * angle), s * v[0], s * v[1], s * v[2]])


@njit(cache=True)
def quat_from_matrix(m):
    """The unit quaternion (w > 0) of a rotation matrix (Shepperd's method: from the largest of the
    four squared components, so no division by a small number)."""
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    q = np.empty(4)
    if trace > m[0, 0] and trace > m[1, 1] and trace > m[2, 2]:
        r = np.sqrt(1.0 + trace)
        q[0], q[1], q[2], q[3] = 0.5 * r, (m[2, 1] - m[1, 2]) / (2 * r), (m[0, 2] - m[2, 0]) / (2 * r), \
            (m[1, 0] - m[0, 1]) / (2 * r)
    elif m[0, 0] >= m[1, 1] and m[0, 0] >= m[2, 2]:
        r = np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q[0], q[1], q[2], q[3] = (m[2, 1] - m[1, 2]) / (2 * r), 0.5 * r, (m[0, 1] + m[1, 0]) / (2 * r), \
            (m[0, 2] + m[2, 0]) / (2 * r)
    elif m[1, 1] >= m[2, 2]:
        r = np.sqrt(1.0 - m[0, 0] + m[1, 1] - m[2, 2])
        q[0], q[1], q[2], q[3] = (m[0, 2] - m[2, 0]) / (2 * r), (m[0, 1] + m[1, 0]) / (2 * r), 0.5 * r, \
            (m[1, 2] + m[2, 1]) / (2 * r)
    else:
        r = np.sqrt(1.0 - m[0, 0] - m[1, 1] + m[2, 2])
        q[0], q[1], q[2], q[3] = (m[1, 0] - m[0, 1]) / (2 * r), (m[0, 2] + m[2, 0]) / (2 * r), \
            (m[1, 2] + m[2, 1]) / (2 * r), 0.5 * r
    if q[0] < 0:
        for i in range(4):
            q[i] = -q[i]
    return q


def quat_from_euler_deg(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Quaternion from intrinsic x-y-z angles in degrees (object placement in scene files)."""
    qx = quat_from_rotation_vector(np.array([np.radians(roll), 0.0, 0.0]))
    qy = quat_from_rotation_vector(np.array([0.0, np.radians(pitch), 0.0]))
    qz = quat_from_rotation_vector(np.array([0.0, 0.0, np.radians(yaw)]))
    return quat_multiply(quat_multiply(qx, qy), qz)
