"""The pick-and-place task's numbers: where the object starts, the places, the holds and limits."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TaskRules:
    """The pick-and-place task (``microg.task.stages`` applies them; a protocol's ``task`` table sets them)."""

    start: tuple[float, float, float]
    start_orientation: tuple[float, float, float, float]
    places: tuple[tuple[float, float, float], ...]
    place_radius: float
    hold_s: float
    timeout_s: float
    grasp_settle_s: float
    drop_grace_s: float
    workspace_min: tuple[float, float, float]
    workspace_max: tuple[float, float, float]
