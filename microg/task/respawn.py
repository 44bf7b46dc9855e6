"""Putting a lost object back: what the researcher does when the object leaves the workspace.

An object that leaves the workspace (``workspace_min`` .. ``workspace_max``) while not held,
drifting away in microgravity or falling off the table, goes back to its start pose moving as the
task started it: at rest for a pick-and-place, launched again for a catch, spinning again for a
stop of a spin.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from microg.sim import World

from .rules import TaskRules
from .stages import TaskEvent, TaskState, rules_of


@njit(cache=True)
def lost(rules, held, position):
    """Whether an object at ``position`` is lost: out of the workspace while not held (``rules``
    a ``stages.RULES`` record)."""
    if held:
        return False
    for i in range(3):
        if not rules.workspace_min[i] <= position[i] <= rules.workspace_max[i]:
            return True
    return False


def inside_workspace(rules: TaskRules, position) -> bool:
    return not lost(rules_of(rules), False, np.asarray(position, dtype=np.float64))


def respawn(world: World, rules: TaskRules, state: TaskState, start, position) -> tuple[World, list[TaskEvent]]:
    """``world`` with object 0 (now at ``position``) back at ``start`` (position, orientation,
    velocity, angular velocity) if it left the workspace while not held; a new World (the argument
    is left as it was)."""
    if not lost(rules_of(rules), state.held, np.asarray(position, dtype=np.float64)):
        return world, []
    data = world.data.copy()
    data.position[0], data.orientation[0], data.velocity[0], data.angular_velocity[0] = start
    return World(world.model, data), [TaskEvent(data.frame_time, "respawn", {"position": [float(v) for v in position]})]
