"""Minimum-jerk movements (Flash and Hogan, 1985) and the movement-time law that sizes them.

A point-to-point movement of duration T that minimises the integrated squared jerk follows

    x(t) = x0 + (x1 - x0) s(t / T),   s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5,

with zero velocity and acceleration at both ends and a bell-shaped speed whose peak, at mid-time,
is 1.875 times the mean speed. The participant moves every degree of freedom (palm position,
palm orientation by slerp, joint angles) along ``s`` (``minimum_jerk_at``); a target that moves
while the hand travels (a drifting object) is followed by re-aiming x1 at each frame.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize


@vectorize(["float64(float64)"], cache=True)
def minimum_jerk(tau):
    """The normalised minimum-jerk position s(tau), tau clipped to [0, 1] (a numpy ufunc: floats or
    arrays, from Python or compiled code)."""
    tau = min(max(tau, 0.0), 1.0)
    return tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)


@njit(cache=True)
def movement_time(distance: float, tolerance: float, intercept: float, slope: float) -> float:
    """Fitts' law, Shannon form: T = a + b log2(D / W + 1), with W the target's full width (2 x tolerance)."""
    return intercept + slope * math.log2(distance / (2.0 * tolerance) + 1.0)


@njit(cache=True)
def slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """Spherical interpolation between unit quaternions (shortest arc), s in [0, 1]."""
    dot = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    q = np.empty(4)
    _arc(q0, q1 if dot >= 0.0 else -q1, s, q)
    return q


@njit(cache=True)
def _arc(q0, q1, s, out):
    """The rotation ``s`` of the way along the great arc from ``q0`` to ``q1`` as given (the short
    arc when their dot product is positive), into ``out``, with numpy's arithmetic."""
    dot = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    if dot > 0.9995:
        for i in range(4):
            out[i] = q0[i] + s * (q1[i] - q0[i])
        norm = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
        for i in range(4):
            out[i] /= norm
        return
    theta = math.acos(min(max(dot, -1.0), 1.0))
    a, b, c = math.sin((1.0 - s) * theta), math.sin(s * theta), math.sin(theta)
    for i in range(4):
        out[i] = (a * q0[i] + b * q1[i]) / c


@njit(cache=True)
def _interpolate(start_position, end_position, start_orientation, end_orientation, start_posture, end_posture, s,
                 position, orientation, posture):
    """The pose ``s`` of the way from start to end, into the last three arrays: the orientation
    along the arc from the start's quaternion to the end's as given (the movement puts the end on
    the start's side when it begins, and keeps it continuous while it follows a turning object)."""
    for i in range(3):
        position[i] = start_position[i] + s * (end_position[i] - start_position[i])
    _arc(start_orientation, end_orientation, s, orientation)
    for d in range(start_posture.shape[0]):
        for j in range(start_posture.shape[1]):
            posture[d, j] = start_posture[d, j] + s * (end_posture[d, j] - start_posture[d, j])


@njit(cache=True)
def minimum_jerk_at(start_position, end_position, start_orientation, end_orientation, start_posture, end_posture,
                    progress, position, orientation, posture):
    """The pose of a minimum-jerk movement at ``progress`` of its time (every degree of freedom of
    the hand along s: the palm position, its orientation by slerp, the joint angles), into the
    last three arrays."""
    _interpolate(start_position, end_position, start_orientation, end_orientation, start_posture, end_posture,
                 minimum_jerk(progress), position, orientation, posture)
