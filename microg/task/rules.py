"""A task's numbers: where the object starts, the limits every kind shares, and each kind's own.

A protocol's ``task`` table sets the numbers every task shares (the start, the timeout, the hold's
settle and grace times, the workspace, and the pick-and-place's places and holds, which a task
without places ignores); each kind with numbers of its own reads them from its table,
``[task.NAME]`` (``microg.task.kind.Kind.read``). ``TaskRules`` holds both: ``rules.catch`` is the
catch's numbers (None when the protocol has no ``[task.catch]``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class TaskRules:
    """A task's numbers (a protocol's ``task`` table sets them), and the kind that judges it."""

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
    kind: str = "pick_and_place"
    """Which kind's rules judge the task (``microg.task.KINDS``)."""
    tables: tuple[tuple[str, object], ...] = ()
    """Each kind's own numbers by the kind's name, for the kinds the protocol gives a table."""

    def __getattr__(self, name: str):
        """A kind's own numbers by its name (``rules.catch``): None when the protocol has none."""
        from .kinds import KINDS

        if name in KINDS:
            return dict(self.tables).get(name)
        raise AttributeError(f"TaskRules has no {name!r}")

    def with_numbers(self, kind: str, numbers) -> TaskRules:
        """These rules with ``numbers`` as kind ``kind``'s own."""
        return replace(self, tables=tuple((k, n) for k, n in self.tables if k != kind) + ((kind, numbers),))


def timeout_reason(rules: TaskRules) -> str:
    """Why a task that ran out of time was not completed, as its run records it."""
    return f"not completed within timeout_s = {rules.timeout_s:g} s"
