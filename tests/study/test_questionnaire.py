"""Asking the questionnaires: an answer is read by its item's scale (the paper's 0-10, SSQ's 0-3,
NASA-TLX's steps of 5 and its pairs), and anything else is asked again with a clear message."""

from __future__ import annotations

import pytest

from microg.paths import PROTOCOLS
from microg.study.protocol import load_protocol
from microg.study.questionnaire import RatingError, TerminalRater, parse_answer, questions

PROTOCOL = load_protocol(PROTOCOLS / "paper.toml")
VR = load_protocol(PROTOCOLS / "paper-vr.toml")


def question(protocol, phase: str, item: str):
    entry = next(p for p in protocol.timeline if p.name == phase)
    return next(q for q in questions(protocol, entry) if q.item.id == item)


NATURALNESS = question(PROTOCOL, "questionnaire", "naturalness")
SSQ = question(VR, "pre", "ssq08")
EFFORT = question(VR, "after_stage1", "effort")
PAIR = question(VR, "after_stage1", "pair_mental_effort")


@pytest.mark.parametrize("asked, text, value", [
    (NATURALNESS, "0", 0), (NATURALNESS, "10", 10), (NATURALNESS, " 7 ", 7), (NATURALNESS, "+3", 3),
    (SSQ, "3", 3), (EFFORT, "85", 85), (PAIR, "2", "effort"), (PAIR, "mental", "mental"),
])
def test_answers_on_the_scale_are_taken_as_answered(asked, text, value):
    assert parse_answer(asked, text) == value


@pytest.mark.parametrize("asked, text, message", [
    (NATURALNESS, "", "no answer: type a whole number from 0 to 10"),
    (NATURALNESS, "seven", "'seven' is not a whole number: type a whole number from 0 to 10"),
    (NATURALNESS, "7.5", "'7.5' is not a whole number"),
    (NATURALNESS, "11", "11 is off the scale: type a whole number from 0 to 10"),
    (NATURALNESS, "-1", "-1 is off the scale"),
    (SSQ, "4", "4 is off the scale: type a whole number from 0 to 3"),
    (EFFORT, "82", "82 is off the scale: type a whole number from 0 to 100 in steps of 5"),
    (PAIR, "3", "'3' is not one of the choices: type 1 for Mental Demand or 2 for Effort"),
])
def test_answers_off_the_scale_are_rejected_saying_what_is_expected(asked, text, message):
    with pytest.raises(RatingError) as error:
        parse_answer(asked, text)
    assert message in str(error.value)


def test_the_terminal_asks_the_papers_question_and_asks_again_until_the_answer_is_valid():
    feed = iter(["", "ten", "10.0", "11", " 8 "])
    shown, prompts, rejected = [], [], []
    rater = TerminalRater(read=lambda prompt: prompts.append(prompt) or next(feed), write=shown.append,
                          on_rejected=lambda asked, text, message: rejected.append(text))
    asked = question(PROTOCOL, "questionnaire", "naturalness")
    second = next(q for q in questions(PROTOCOL, PROTOCOL.timeline[-1]) if q.label == "System 2")
    answer = rater.answer(second)
    assert answer.value == 8 and answer.response_time_s >= 0
    assert second.item == asked.item and second.key == ("paper", "questionnaire", "soft_hand", "naturalness")
    assert shown[0] == "\n== Naturalness and efficiency (the paper's items): System 2 =="
    assert shown[1] == ("System 2: How natural did the sensation of the average task completion experience feel?\n"
                        "  (0: Extremely unnatural, 10: Extremely natural)")
    assert len(prompts) == 5 and all(p == "Rating (0-10): " for p in prompts)
    assert rejected == ["", "ten", "10.0", "11"]
    assert [line.strip() for line in shown[2:]] == [
        "no answer: type a whole number from 0 to 10",
        "'ten' is not a whole number: type a whole number from 0 to 10",
        "'10.0' is not a whole number: type a whole number from 0 to 10",
        "11 is off the scale: type a whole number from 0 to 10"]


def test_the_terminal_shows_an_instruments_title_and_instructions_once_then_each_item_with_its_anchors():
    shown = []
    rater = TerminalRater(read=lambda prompt: "1", write=shown.append)
    asked = [q for q in questions(VR, VR.timeline[2])][:2]
    assert [rater.answer(q).value for q in asked] == [1, 1]
    assert shown == ["\n== Simulator Sickness Questionnaire (SSQ) ==",
                     "How much is each symptom below affecting you right now?",
                     "General discomfort\n  (0: None, 1: Slight, 2: Moderate, 3: Severe)",
                     "Fatigue\n  (0: None, 1: Slight, 2: Moderate, 3: Severe)"]
    shown.clear()
    assert rater.answer(PAIR).value == "mental"
    assert shown[-1] == ("System 1: Select the scale title that represents the more important contributor to "
                         "workload for the task you just did.\n  1: Mental Demand\n  2: Effort")
