"""Minimum-jerk movements (Flash and Hogan, 1985) and the movement-time law that sizes them.

A point-to-point movement of duration T that minimises the integrated squared jerk follows

    x(t) = x0 + (x1 - x0) s(t / T),   s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5,

with zero velocity and acceleration at both ends and a bell-shaped speed whose peak, at mid-time,
is 1.875 times the mean speed. The participant moves every degree of freedom (palm position,
palm orientation by slerp, joint angles) along ``s``; a target that moves while the hand travels
(a drifting object) is followed by re-aiming x1 at each frame (``Movement.toward``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def minimum_jerk(tau: float | np.ndarray) -> float | np.ndarray:
    """The normalised minimum-jerk position s(tau), tau clipped to [0, 1] (a float without numpy:
    a movement takes one every frame)."""
    tau = min(max(tau, 0.0), 1.0) if isinstance(tau, float) else np.clip(tau, 0.0, 1.0)
    return tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)


def movement_time(distance: float, tolerance: float, intercept: float, slope: float) -> float:
    """Fitts' law, Shannon form: T = a + b log2(D / W + 1), with W the target's full width (2 x tolerance)."""
    return intercept + slope * math.log2(distance / (2.0 * tolerance) + 1.0)


def slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """Spherical interpolation between unit quaternions (shortest arc), s in [0, 1]."""
    dot = float(np.dot(q0, q1))
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:
        q = q0 + s * (q1 - q0)
        return q / math.sqrt(q.dot(q))  # np.linalg.norm's arithmetic, without its checks
    theta = math.acos(dot)
    return (math.sin((1.0 - s) * theta) * q0 + math.sin(s * theta) * q1) / math.sin(theta)


@dataclass(frozen=True, eq=False)
class Pose:
    """An intended hand: palm position (m), palm orientation (w, x, y, z), joint angles (5, 4)."""

    position: np.ndarray
    orientation: np.ndarray
    posture: np.ndarray


@dataclass(frozen=True, eq=False)
class Movement:
    """A minimum-jerk movement of every degree of freedom from ``start`` to ``end``, beginning at
    ``begin`` (s) and lasting ``duration`` (s)."""

    start: Pose
    end: Pose
    begin: float
    duration: float

    def progress(self, t: float) -> float:
        """The fraction of the movement's time elapsed at ``t``, in [0, 1]."""
        return min(max((t - self.begin) / self.duration, 0.0), 1.0)

    def at(self, t: float) -> Pose:
        s = minimum_jerk(self.progress(t))
        start, end = self.start, self.end
        return Pose(start.position + s * (end.position - start.position), slerp(start.orientation, end.orientation, s),
                    start.posture + s * (end.posture - start.posture))

    def toward(self, end: Pose) -> Movement:
        """The same movement re-aimed at ``end`` (a target that moved while the hand travels)."""
        return Movement(self.start, end, self.begin, self.duration)
