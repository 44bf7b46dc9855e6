"""Proficiency criteria and staircases on hand-made sequences of tasks, and the calendar of a
training program's sessions (``microg.study.progression``, ``microg.study.schedule``)."""

from __future__ import annotations

import datetime

import pytest

from microg.study.progression import FinishedTask, next_difficulty, progress
from microg.study.protocol import Criterion, SessionPlan, Staircase
from microg.study.schedule import Sitting, due_date, overdue_from

CLEAN, SLOW, DROPPED, MISSED = (FinishedTask("C", True, 20.0, 0), FinishedTask("C", True, 40.0, 0), FinishedTask("C", True, 20.0, 1),
                                FinishedTask("C", False, None, 0))
TWO_CLEAN = Criterion(time_s=30.0, attempts=0, consecutive=2)


@pytest.mark.parametrize("outcomes, in_a_row, met_at", [
    ([], 0, None),
    ([CLEAN], 1, None),
    ([CLEAN, CLEAN], 2, 2),
    ([CLEAN, SLOW, CLEAN], 1, None),          # a task over time_s breaks the run
    ([CLEAN, DROPPED, CLEAN, CLEAN], 2, 4),   # so does a drop (attempts above 0)
    ([MISSED, CLEAN, CLEAN, SLOW], 0, 3),     # met once is met: later tasks do not undo it
])
def test_a_criterion_counts_clean_tasks_in_a_row(outcomes, in_a_row, met_at):
    reached = progress(TWO_CLEAN, outcomes)
    assert (reached.tasks, reached.in_a_row, reached.met_at) == (len(outcomes), in_a_row, met_at)


def test_what_the_participant_hears_after_each_task():
    assert progress(TWO_CLEAN, [CLEAN]).describe() == "One more clean task in a row"
    assert progress(Criterion(30.0, 0, 3), [CLEAN]).describe() == "Two more clean tasks in a row"
    assert progress(TWO_CLEAN, [CLEAN, CLEAN]).describe() == "Criterion met: well done!"


def test_an_objects_own_thresholds_replace_the_phases_for_its_tasks():
    lenient = Criterion(30.0, 0, 1, objects=(("L", 60.0, 2),))
    assert progress(lenient, [FinishedTask("L", True, 50.0, 2)]).met
    assert not progress(lenient, [FinishedTask("C", True, 50.0, 0)]).met


def test_a_two_down_one_up_staircase_steps_by_its_factor_within_its_bounds():
    """Levitt's 2-down-1-up on a number whose larger values are harder: two successes in a row
    multiply it by the factor, one failure divides it; the count starts again after each change."""
    stairs = Staircase("catch.speed", start=0.2, step=None, factor=2.0, rule="2-down-1-up", minimum=0.1, maximum=0.5)
    values = [next_difficulty(stairs, None, [FinishedTask("C", ok, 1.0, 0) for ok in done], harder=1)
              for done in ([], [True], [True, True], [True, True, False], [True, True, False, False],
                           [True, True, True, True, True, True])]
    assert values == [0.2, 0.2, 0.4, 0.2, 0.1, 0.5]   # 0.2, 0.4, 0.8 -> 0.5 at its max


def test_a_staircase_on_a_number_whose_smaller_values_are_harder_moves_the_other_way():
    radius = Staircase("place_radius", start=0.04, step=0.01, factor=None, rule="1-up-1-down", minimum=0.015,
                       maximum=0.06)
    assert next_difficulty(radius, None, [CLEAN], harder=-1) == pytest.approx(0.03)
    assert next_difficulty(radius, None, [MISSED], harder=-1) == pytest.approx(0.05)
    assert next_difficulty(radius, None, [CLEAN] * 4, harder=-1) == pytest.approx(0.015)
    assert next_difficulty(radius, TWO_CLEAN, [SLOW], harder=-1) == pytest.approx(0.05)  # the criterion decides


def test_a_sessions_due_date_and_window():
    plan = SessionPlan("retention", ("test",), after_days=7, within_days=2)
    post = Sitting("posttest", datetime.date(2026, 3, 2), "completed")
    assert due_date(plan, [post], datetime.date(2026, 1, 1)) == datetime.date(2026, 3, 9)
    assert due_date(plan, [], datetime.date(2026, 1, 1)) == datetime.date(2026, 1, 1)
    assert overdue_from(plan, datetime.date(2026, 3, 9)) == datetime.date(2026, 3, 12)
    assert overdue_from(SessionPlan("any", ("test",), 1), datetime.date(2026, 3, 9)) is None
