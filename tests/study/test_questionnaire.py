"""The questionnaire: the paper's items on 0-10, bad answers asked again with a clear message."""

from __future__ import annotations

import pytest

from microg.paths import PROTOCOLS
from microg.study.protocol import load_protocol
from microg.study.questionnaire import RatingError, TerminalRater, parse_rating

PROTOCOL = load_protocol(PROTOCOLS / "paper.toml")


@pytest.mark.parametrize("text, value", [("0", 0), ("10", 10), (" 7 ", 7), ("+3", 3)])
def test_ratings_on_the_scale_are_taken_as_answered(text, value):
    assert parse_rating(text, 0, 10) == value


@pytest.mark.parametrize("text, message", [
    ("", "no answer: type a whole number from 0 to 10"),
    ("seven", "'seven' is not a whole number: type a whole number from 0 to 10"),
    ("7.5", "'7.5' is not a whole number"),
    ("11", "11 is off the scale: type a whole number from 0 to 10"),
    ("-1", "-1 is off the scale"),
])
def test_answers_off_the_scale_are_rejected_saying_what_is_expected(text, message):
    with pytest.raises(RatingError) as error:
        parse_rating(text, 0, 10)
    assert message in str(error.value)


def test_the_terminal_asks_the_papers_question_and_asks_again_until_the_answer_is_valid():
    feed = iter(["", "ten", "10.0", "11", " 8 "])
    shown, prompts, rejected = [], [], []
    rater = TerminalRater(read=lambda prompt: prompts.append(prompt) or next(feed), write=shown.append,
                          on_rejected=lambda item, phase, text, message: rejected.append(text))
    item = PROTOCOL.questionnaire.items[0]
    phase = PROTOCOL.phases[1]
    assert rater.rate(item, phase, PROTOCOL.questionnaire) == 8
    assert shown[0] == ("System 2: How natural did the sensation of the average task completion experience feel?\n"
                        "  (0: Extremely unnatural, 10: Extremely natural)")
    assert len(prompts) == 5 and all(p == "Rating (0-10): " for p in prompts)
    assert rejected == ["", "ten", "10.0", "11"]
    assert [line.strip() for line in shown[1:]] == [
        "no answer: type a whole number from 0 to 10",
        "'ten' is not a whole number: type a whole number from 0 to 10",
        "'10.0' is not a whole number: type a whole number from 0 to 10",
        "11 is off the scale: type a whole number from 0 to 10"]
