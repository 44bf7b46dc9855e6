"""The questionnaire: each item for each interaction model, on the protocol's scale (the paper: 0-10).

``TerminalRater`` asks in the terminal with the paper's question text and anchors, and asks again
on anything that is not a whole number on the scale. Simulated participants answer through the
rating model (``microg.study.model_rater``); those answers are marked ``source = model``.
"""

from __future__ import annotations

from typing import Callable, Protocol as Interface

from .protocol import Item, Questionnaire, TaskPhase


class RatingError(ValueError):
    """An answer that is not a rating on the scale; the message says what is expected."""


class Rater(Interface):
    source: str
    """``participant`` (a person answered) or ``model`` (a simulated participant's rating model)."""

    def rate(self, item: Item, phase: TaskPhase, questionnaire: Questionnaire) -> int: ...


def parse_rating(text: str, low: int, high: int) -> int:
    """The rating in ``text``, or RatingError naming the answer and the scale."""
    answer = text.strip()
    if not answer:
        raise RatingError(f"no answer: type a whole number from {low} to {high}")
    try:
        value = int(answer)
    except ValueError:
        raise RatingError(f"{answer!r} is not a whole number: type a whole number from {low} to {high}") from None
    if not low <= value <= high:
        raise RatingError(f"{value} is off the scale: type a whole number from {low} to {high}")
    return value


def question_text(item: Item, phase: TaskPhase, questionnaire: Questionnaire) -> str:
    q = questionnaire
    return (f"{phase.label}: {item.question}\n"
            f"  ({q.scale_min}: {item.low}, {q.scale_max}: {item.high})")


class TerminalRater:
    """Asks a person; ``read`` and ``write`` default to the terminal."""

    source = "participant"

    def __init__(self, read: Callable[[str], str] = input, write: Callable[[str], None] = print,
                 on_rejected: Callable[[Item, TaskPhase, str, str], None] | None = None):
        self.read, self.write, self.on_rejected = read, write, on_rejected

    def rate(self, item: Item, phase: TaskPhase, questionnaire: Questionnaire) -> int:
        self.write(question_text(item, phase, questionnaire))
        while True:
            text = self.read(f"Rating ({questionnaire.scale_min}-{questionnaire.scale_max}): ")
            try:
                return parse_rating(text, questionnaire.scale_min, questionnaire.scale_max)
            except RatingError as error:
                self.write(f"  {error}")
                if self.on_rejected:
                    self.on_rejected(item, phase, text, str(error))
