"""The pick-and-place state machine on scripted observations: the rules of the paper's task."""

from __future__ import annotations

import math

import pytest

from microg.task.rules import TaskRules
from microg.task import COMPLETED, KINDS, TIMEOUT, Observation, TaskState

KIND = KINDS["pick_and_place"]
MANIPULATION, MAINTENANCE, RELEASE = "manipulation", "maintenance", "release"

RATE = 100.0
START = (0.0, 0.2, 0.0)
PLACES = ((0.1, 0.2, 0.0), (0.2, 0.2, 0.0), (0.3, 0.2, 0.0))
RULES = TaskRules(start=START, start_orientation=(1.0, 0.0, 0.0, 0.0), places=PLACES, place_radius=0.02,
                  hold_s=3.0, timeout_s=60.0, grasp_settle_s=0.1, drop_grace_s=0.25,
                  workspace_min=(-1.0, -1.0, -1.0), workspace_max=(1.0, 1.0, 1.0))


def play(script, rules=RULES):
    """Feed ``script``: a list of (duration_s, grasped, position); returns final state and events."""
    state, events, t = KIND.start(), [], 0.0
    for duration, is_grasped, position in script:
        for _ in range(round(duration * RATE)):
            state, new = KIND.advance(state, Observation(t, is_grasped, position), rules)
            events += new
            t = round(t + 1 / RATE, 9)
    return state, events


def kinds(events):
    return [e.kind for e in events]


def visit(place, seconds):
    return (seconds, True, PLACES[place])


CLEAN = [(0.5, False, START), (0.5, True, START)] + [visit(k, 3.2) for k in range(3)] + [(0.5, False, PLACES[2])]


def test_a_clean_run_completes_with_no_attempts_and_its_time_runs_to_the_release():
    state, events = play(CLEAN)
    assert state.stage == COMPLETED and state.attempts == 0
    # the grasp ends at 0.5 + 0.5 + 3 x 3.2 = 10.6 s; the first frame was at 0
    assert state.completion_time == pytest.approx(10.6, abs=1e-6)
    assert kinds(events).count("place_done") == 3
    stages = [e.data["stage"] for e in events if e.kind == "stage"]
    assert stages == [MANIPULATION, MAINTENANCE, RELEASE]


def test_a_hold_shorter_than_three_seconds_does_not_count():
    short = [(0.5, True, START), visit(0, 2.9), (0.5, True, START), visit(0, 2.9)]
    state, events = play(short)
    assert state.stage == MAINTENANCE and state.place == 0
    assert "place_done" not in kinds(events)
    assert kinds(events).count("place_lit") == 2 and kinds(events).count("place_dark") == 1


def test_a_hold_of_three_seconds_counts_and_the_timer_starts_when_the_object_arrives():
    state, events = play([(0.5, True, START), visit(0, 3.05)])
    lit = next(e for e in events if e.kind == "place_lit")
    done = next(e for e in events if e.kind == "place_done")
    assert lit.t == pytest.approx(0.5) and done.t - lit.t == pytest.approx(3.0, abs=1 / RATE)
    assert state.place == 1


def test_places_count_only_in_order():
    state, events = play([(0.5, True, START), visit(2, 3.5), visit(1, 3.5)])
    assert state.place == 0 and "place_lit" not in kinds(events)


def test_a_drop_adds_an_attempt_resets_the_place_and_the_task_goes_on():
    script = [(0.5, True, START), visit(0, 3.2), visit(1, 1.5), (1.0, False, PLACES[1]), (0.5, True, PLACES[1]),
              visit(1, 3.2), visit(2, 3.2), (0.5, False, PLACES[2])]
    state, events = play(script)
    assert state.stage == COMPLETED and state.attempts == 1
    drop = next(e for e in events if e.kind == "drop")
    assert drop.data["since"] == pytest.approx(0.5 + 3.2 + 1.5) and drop.data["place"] == 1
    assert kinds(events).count("place_done") == 3
    assert kinds(events).index("drop") < kinds(events).index("place_done", kinds(events).index("drop"))


def test_a_grasp_that_flickers_off_for_less_than_the_grace_is_not_a_drop():
    flicker = [(0.5, True, START), visit(0, 1.0), (0.2, False, PLACES[0]), visit(0, 3.2)]
    state, events = play(flicker)
    assert state.attempts == 0 and "drop" not in kinds(events)
    assert state.place == 1  # the timer ran through the flicker: 1.0 + 0.2 + 3.2 >= 3


def test_letting_go_after_the_last_place_is_the_release_not_a_drop():
    state, events = play(CLEAN)
    assert "drop" not in kinds(events) and "release" in kinds(events)


def test_a_touch_too_short_to_be_a_hold_and_then_nothing_is_no_attempt():
    state, _ = play([(0.05, True, START), (1.0, False, START)])
    assert state.attempts == 0 and state.stage == MANIPULATION and not state.held


def test_a_timeout_ends_the_task_as_not_completed():
    rules = TaskRules(**{**RULES.__dict__, "timeout_s": 5.0})
    state, events = play([(0.5, True, START), visit(0, 10.0)], rules)
    assert state.stage == TIMEOUT and state.completion_time is None and state.finished
    assert events[-1].kind == "timeout" and events[-1].t == pytest.approx(5.0)
    assert state.place == 1  # the place done before the timeout stays done


def test_nothing_happens_after_the_task_ended():
    state, _ = play(CLEAN)
    after, events = KIND.advance(state, Observation(100.0, True, PLACES[0]), RULES)
    assert after == state and events == []


def test_the_place_timer_reads_zero_when_dark():
    assert KIND.start().place_timer(3.0) == 0.0
    lit = KIND.new_task()
    lit["lit_since"] = 1.0
    assert math.isclose(TaskState(KIND, lit).place_timer(3.5), 2.5)
