"""Proficiency-based progression: when a phase trained to a criterion has met it, and how a
staircase moves its task's difficulty from task to task.

Both read a phase's finished tasks in order, each as a ``FinishedTask`` (its object, whether it was
completed, its time and attempts, and the difficulty it ran with), so a resumed session finds the
same state its tasks left.

The staircase is a transformed up-down rule (Levitt 1971, *J. Acoust. Soc. Am.* 49: 467-477):
after ``n`` successes in a row the task gets harder by one step, after one failure easier by one
step (``"1-up-1-down"`` tracks 50 % success, ``"2-down-1-up"`` 70.7 %, ``"3-down-1-up"`` 79.4 %); the
count of successes starts again after every change. "Harder" is the direction the kind declares for
the number (``Kind.difficulty``: a faster catch, a smaller place radius). A step adds or subtracts
``step``, or multiplies or divides by ``factor``; the value stays within ``min`` .. ``max``. A
library was considered: PsychoPy's ``StairHandler`` brings about sixty packages (a GUI toolkit,
OpenCV) into a study's environment, and ``questplus`` implements QUEST+ only, so these few lines are
written here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from .protocol import STAIRCASE_RULES, Criterion, Staircase


@dataclass(frozen=True)
class FinishedTask:
    """A finished task of a phase as progression reads it."""

    object_code: str
    completed: bool
    time_s: float | None
    attempts: int | None
    difficulty: float | None = None


@dataclass(frozen=True)
class Progress:
    """Where a phase trained to a criterion stands after its tasks so far."""

    tasks: int
    in_a_row: int
    """Tasks in a row, up to the last, that count toward the criterion."""
    needed: int
    """The criterion's ``consecutive``."""
    met_at: int | None
    """The 1-based task at which the criterion was met (None: not yet)."""

    @property
    def met(self) -> bool:
        return self.met_at is not None

    def describe(self) -> str:
        """What the participant is told after a task: how far they are."""
        if self.met:
            return "Criterion met: well done!"
        left = self.needed - self.in_a_row
        return f"{_count(left)} more clean task{'s' if left > 1 else ''} in a row"


def _count(n: int) -> str:
    words = ("no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten")
    return (words[n] if n < len(words) else str(n)).capitalize()


def counts(criterion: Criterion | None, task: FinishedTask) -> bool:
    """Whether ``task`` counts toward ``criterion`` (without one: whether it was completed)."""
    if criterion is None:
        return task.completed
    return criterion.counts(task.object_code, task.completed, task.time_s, task.attempts)


def progress(criterion: Criterion, finished: Sequence[FinishedTask]) -> Progress:
    """How a phase trained to ``criterion`` stands after ``finished`` (its finished tasks, in order)."""
    in_a_row, met_at = 0, None
    for number, task in enumerate(finished, start=1):
        in_a_row = in_a_row + 1 if counts(criterion, task) else 0
        if met_at is None and in_a_row >= criterion.consecutive:
            met_at = number
    return Progress(len(finished), in_a_row, criterion.consecutive, met_at)


def next_difficulty(staircase: Staircase, criterion: Criterion | None, finished: Sequence[FinishedTask],
                    harder: int) -> float:
    """The value the next task runs with: ``staircase.start``, moved by its rule over ``finished``
    (each with the difficulty it ran with). ``harder``: +1 when a larger value is harder, -1 when
    a smaller one is."""
    value, successes = staircase.start, 0
    needed = STAIRCASE_RULES[staircase.rule]
    for task in finished:
        if counts(criterion, task):
            successes += 1
            if successes < needed:
                continue
            direction = harder
        else:
            direction = -harder
        successes = 0
        value = _moved(staircase, value, direction)
    return value


def _moved(staircase: Staircase, value: float, direction: int) -> float:
    """``value`` one step up (``direction`` +1) or down (-1), within the staircase's bounds."""
    if staircase.factor is not None:
        moved = value * staircase.factor ** direction
    else:
        moved = value + direction * staircase.step
    return min(staircase.maximum, max(staircase.minimum, moved))
