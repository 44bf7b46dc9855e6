"""One task as whoever plays it knows it: the object, where it waits, the task's rules, the hand.

The study fills it in from its protocol (``microg.study.inputs.participant_plan``); benches and
tests build one directly. Positions are metres in the world (tracker) frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from microg.skeleton import SIDES
from microg.sim import ObjectSpec
from microg.task import TaskRules

from .population import check_earlier_sessions

Point = tuple[float, float, float]


@dataclass(frozen=True)
class TaskPlan:
    """One task for one participant, of the kind its ``rules`` say (the paper's pick-and-place,
    section 4.3; a catch; a stop of a spin).

    ``hand_start``: where the hand waits at the start (None: 10 cm above and 12 cm nearer the
    user than the object). ``release_position``: where to carry the object after the last place
    before letting go (None: let go at the last place). ``tasks_done``: tasks this participant did
    before this one in the session (its practice). ``participant`` and ``phase`` name the task in
    the study (empty outside one). ``participant_seed`` is the participant's own seed (a session's),
    from which a participant drawn from a population gets its parameters, the same in every task;
    ``first_with_object``: no earlier task of the session had this object. ``earlier_sessions``:
    for each earlier session of this participant, oldest first, (days from that session's date to
    this session's, tasks done in it); their practice carries over as much as it is retained
    (``population.effective_practice``).
    """

    object: ObjectSpec
    start: Point
    rules: TaskRules
    gravity: Point = (0.0, 0.0, 0.0)
    hand: str = "right"
    tasks_done: int = 0
    hand_start: Point | None = None
    release_position: Point | None = None
    participant: str = ""
    phase: str = ""
    participant_seed: int = 0
    first_with_object: bool = True
    earlier_sessions: tuple[tuple[float, int], ...] = ()

    def __post_init__(self) -> None:
        check_earlier_sessions(self.earlier_sessions, "TaskPlan.earlier_sessions")
        if self.hand not in SIDES:
            raise ValueError(f"TaskPlan.hand = {self.hand!r}: must be one of {SIDES}")
        if not self.rules.places:
            raise ValueError("TaskPlan.rules.places is empty: the task needs at least one place")
        for name in ("start", "gravity", "hand_start", "release_position"):
            value = getattr(self, name)
            if value is not None and (len(value) != 3 or not all(math.isfinite(float(v)) for v in value)):
                raise ValueError(f"TaskPlan.{name} = {value!r}: must be three finite numbers")
