"""Putting a lost object back: what the researcher does when the object leaves the workspace.

An object that leaves the workspace (``workspace_min`` .. ``workspace_max``) while not held,
drifting away in microgravity or falling off the table, goes back to its start pose, at rest.
"""

from __future__ import annotations

from microg.sim import World

from .rules import TaskRules
from .stages import TaskEvent, TaskState


def inside_workspace(rules: TaskRules, position) -> bool:
    return all(lo <= p <= hi for lo, p, hi in zip(rules.workspace_min, position, rules.workspace_max))


def respawn(world: World, rules: TaskRules, state: TaskState, start, position) -> tuple[World, list[TaskEvent]]:
    """``world`` with object 0 (now at ``position``) back at ``start`` (position, orientation), at
    rest, if it left the workspace while not held; a new World (the argument is left as it was)."""
    if state.held or inside_workspace(rules, position):
        return world, []
    data = world.data.copy()
    data.position[0], data.orientation[0] = start
    data.velocity[0] = 0.0
    data.angular_velocity[0] = 0.0
    return World(world.model, data), [TaskEvent(data.frame_time, "respawn", {"position": [float(v) for v in position]})]
