"""The questionnaires of a session: what each questionnaire phase of the timeline asks, and asking it.

A questionnaire phase asks its instruments (``microg.instruments``) in order, each once or once about
each interaction model it names (``Protocol.about``), item by item in the instrument's order:
``questions`` lists them. An answer is read by its item (``parse_answer``: a number on the item's
scale, or one of its choices) and asked again with a message on anything else. ``TerminalRater``
asks in the terminal; the participant's page asks on the screen or in the headset
(``microg.view.display.DisplayRater``); simulated participants answer through the rating model
(``microg.study.simulated_rater``), and those answers are marked ``source = model``.
"""

from __future__ import annotations

import time
import typing
from dataclasses import dataclass
from typing import Callable, NamedTuple

from microg.instruments import NUMBER, Instrument, Item

from .protocol import Phase, Protocol


class RatingError(ValueError):
    """An answer that is not an answer to its item; the message says what is expected."""


@dataclass(frozen=True)
class Question:
    """One item to ask: of which instrument, in which administration, about which interaction model."""

    instrument: Instrument
    item: Item
    administration: str
    interaction: str
    """The interaction model it is about; "" for none."""
    label: str
    """How the participant hears that interaction model named (the phase's label, "System 1"); "" for none."""
    number: int
    """The item's place in this filling-in of the instrument (1-based), of ``count``."""
    count: int

    @property
    def key(self) -> tuple[str, str, str, str]:
        """What the store keeps the answer under: instrument, administration, interaction, item."""
        return self.instrument.id, self.administration, self.interaction, self.item.id


class Answer(NamedTuple):
    value: float | int | str
    response_time_s: float | None
    """From showing the item to the answer that counted (rejected tries included); None for the rating model."""


class Rater(typing.Protocol):
    source: str
    """``participant`` (a person answered) or ``model`` (a simulated participant's rating model)."""

    def answer(self, question: Question) -> Answer:
        """Ask until an answer counts."""

    def saved(self, question: Question) -> None:
        """The answer is committed (the participant's page says so)."""


Rejected = Callable[[Question, str, str], None]
"""Called with the question, the answer as given and why it was refused (the session logs it)."""


def questions(protocol: Protocol, phase: Phase) -> list[Question]:
    """What a questionnaire phase asks, in order: each instrument, about each interaction model it names,
    item by item."""
    asked = []
    for name in phase.instruments:
        instrument = protocol.instruments[name]
        for about in protocol.about(phase):
            for number, item in enumerate(instrument.items, start=1):
                asked.append(Question(instrument, item, phase.administration, about.interaction if about else "",
                                      about.label if about else "", number, len(instrument.items)))
    return asked


def expected(question: Question) -> str:
    """What an answer must be, as the participant is told."""
    item, instrument = question.item, question.instrument
    if item.response.kind == "choice":
        return "type " + " or ".join(f"{k} for {instrument.choice_label(choice)}"
                                     for k, choice in enumerate(item.choices, start=1))
    response = item.response
    steps = f" in steps of {response.step:g}" if response.step != 1 else ""
    return f"type {'a whole number' if response.whole else 'a number'} from {response.low:g} to {response.high:g}{steps}"


def parse_answer(question: Question, text: str) -> float | int | str:
    """The answer in ``text`` (for a choice: its number, or the choice itself), or RatingError naming
    the answer and what is expected."""
    item, answer = question.item, text.strip()
    if not answer:
        raise RatingError(f"no answer: {expected(question)}")
    if item.response.kind == "choice":
        if answer.isdigit() and 1 <= int(answer) <= len(item.choices):
            return item.choices[int(answer) - 1]
        try:
            return item.read(answer)
        except ValueError:
            raise RatingError(f"{answer!r} is not one of the choices: {expected(question)}") from None
    try:
        if not NUMBER.fullmatch(answer):
            raise ValueError(answer)
        number = int(answer) if item.response.whole else float(answer)
    except ValueError:
        kind = "a whole number" if item.response.whole else "a number"
        raise RatingError(f"{answer!r} is not {kind}: {expected(question)}") from None
    try:
        return item.read(number)
    except ValueError:
        raise RatingError(f"{answer} is off the scale: {expected(question)}") from None


def question_text(question: Question) -> str:
    """The item as the terminal shows it: its interaction model's label, the text, and the anchors."""
    item = question.item
    head = f"{question.label}: {item.text}" if question.label else item.text
    if item.response.kind == "choice":
        return head + "\n" + "\n".join(f"  {k}: {question.instrument.choice_label(choice)}"
                                       for k, choice in enumerate(item.choices, start=1))
    words = ", ".join(f"{point}: {text}" for point, text in item.words)
    return head + (f"\n  ({words})" if words else "")


def prompt(item: Item) -> str:
    if item.response.kind == "choice":
        return f"Choice (1-{len(item.choices)}): "
    return f"Rating ({item.response.describe()}): "


class TerminalRater:
    """Asks a person; ``read`` and ``write`` default to the terminal."""

    source = "participant"

    def __init__(self, read: Callable[[str], str] = input, write: Callable[[str], None] = print,
                 on_rejected: Rejected | None = None):
        self.read, self.write, self.on_rejected = read, write, on_rejected
        self._heading: tuple | None = None

    def answer(self, question: Question) -> Answer:
        heading = (question.instrument.id, question.administration, question.interaction)
        if heading != self._heading and question.number == 1:
            self.write(f"\n== {question.instrument.title}" + (f": {question.label}" if question.label else "") + " ==")
            if question.instrument.instructions:
                self.write(question.instrument.instructions)
        self._heading = heading
        self.write(question_text(question))
        shown = time.monotonic()
        while True:
            text = self.read(prompt(question.item))
            try:
                return Answer(parse_answer(question, text), time.monotonic() - shown)
            except RatingError as error:
                self.write(f"  {error}")
                if self.on_rejected:
                    self.on_rejected(question, text, str(error))

    def saved(self, question: Question) -> None:
        pass
