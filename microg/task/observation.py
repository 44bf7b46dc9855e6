"""What one frame of the world shows the task, and the simulated participant who plays it.

The task's rules and a simulated participant look at the same thing: the object's pose and
motion, which phalanges touch it, whether it is grasped (``microg.sim.grasped``'s rule) and, for
the participant, what the task displays. Nobody downstream of the physics reads ``world.data``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from microg.sim import Snapshot, World, snapshot

if TYPE_CHECKING:
    from .kind import TaskDisplay


UPRIGHT = np.array([1.0, 0.0, 0.0, 0.0])
UPRIGHT.setflags(write=False)
STILL = np.zeros(3)
STILL.setflags(write=False)


class Observation(NamedTuple):
    """The task's object at one moment (positions in metres, tracker frame)."""

    t: float
    grasped: bool
    position: tuple[float, float, float] | np.ndarray
    """The object's centre."""
    orientation: np.ndarray = UPRIGHT
    """(w, x, y, z)."""
    touching: np.ndarray | None = None
    """(40,) True for each phalanx slot in contact with the object (``microg.sim.slot``)."""
    display: TaskDisplay | None = None
    """What the task shows (set by whoever runs the task, for a participant to follow)."""
    velocity: np.ndarray = STILL
    """The object's centre's velocity (m/s)."""
    angular_velocity: np.ndarray = STILL
    """(rad/s, tracker frame): what a stop of a spin judges."""
    grasped_by: np.ndarray | None = None
    """(2,) which hands hold it (left, right: ``microg.skeleton.SIDES``), what a handover judges;
    None where the source does not say (only ``grasped``)."""


def observe(world: World, index: int = 0, display: TaskDisplay | None = None) -> Observation:
    """What ``world`` shows of object ``index`` now."""
    return seen_in(snapshot(world, index), display)


def seen_in(after: Snapshot, display: TaskDisplay | None = None) -> Observation:
    """The observation a world's ``snapshot`` holds."""
    return Observation(after.t, after.grasped, after.position, after.orientation, after.touching, display,
                       after.velocity, after.angular_velocity, after.grasped_by)
