"""Leap Motion units and conventions, converted once at the input boundary.

The Leap Motion delivers millimetres and microseconds in its own frame (right-handed, y up, origin
at the device, +z toward the user); the hand model holds metres and seconds in that same frame.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from microg.skeleton import at_tracker_precision

MILLIMETRES_PER_METRE = 1000.0
MICROSECONDS_PER_SECOND = 1e6


def metres(millimetres) -> np.ndarray:
    """Leap lengths (mm) in metres at the tracker's precision (``microg.skeleton.TRACKER_FLOAT``);
    anything missing or non-finite becomes NaN (unknown)."""
    values = at_tracker_precision(np.asarray(millimetres, dtype=np.float64) / MILLIMETRES_PER_METRE)
    return np.where(np.isfinite(values), values, np.nan)


def seconds(microseconds: float) -> float:
    """A Leap timestamp (microseconds) in seconds."""
    return microseconds / MICROSECONDS_PER_SECOND


def palm_quaternion(normal, direction) -> np.ndarray:
    """The palm orientation (w, x, y, z) as LeapC defines it: the rotation whose columns are the
    basis {normal x direction, -normal, -direction}; NaN when either vector is unknown.

    The tracker's two vectors are only nearly orthogonal, so the nearest rotation is taken.
    """
    normal = np.asarray(normal, dtype=np.float64)
    direction = np.asarray(direction, dtype=np.float64)
    if not (np.isfinite(normal).all() and np.isfinite(direction).all()):
        return np.full(4, np.nan)
    basis = np.column_stack([np.cross(normal, direction), -normal, -direction])
    if abs(np.linalg.det(basis)) < 1e-6:
        return np.full(4, np.nan)
    x, y, z, w = Rotation.from_matrix(basis).as_quat(canonical=True)
    return np.array([w, x, y, z])
