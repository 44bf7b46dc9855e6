"""A trainee's page's numbers: the cohort's band (quantiles as R's type 7) and the trainee's
sessions, on a small table worked by hand."""

from __future__ import annotations

import pandas as pd
import pytest

from microg.analysis.tables import AnalysisInputError
from microg.analysis.trainee import trainee_summary
from microg.analysis.training import cohort_band


def test_the_cohorts_band_is_each_practices_quantiles():
    tasks = pd.DataFrame({"group": ["P"] * 5 + ["S"], "practice": [1, 1, 1, 1, 2, 1],
                          "time_s": [10.0, 20.0, 30.0, 40.0, 5.0, 99.0]})
    band = cohort_band(tasks, low=0.25, high=0.75)
    p1 = band[(band.group == "P") & (band.practice == 1)].iloc[0]
    # R: quantile(c(10, 20, 30, 40), c(.25, .5, .75)) = 17.5 25 32.5
    assert (p1.n, p1.low, p1["median"], p1.high) == (4, 17.5, 25.0, 32.5)
    assert band[band.group == "S"].iloc[0][["low", "high"]].tolist() == [99.0, 99.0]


def test_a_trainees_sessions_in_order_with_the_task_that_met_each_criterion():
    trials = pd.DataFrame({
        "participant": ["T1"] * 6 + ["T2"], "session": ["pre", "t1", "t1", "t1", "t2", "t2", "pre"],
        "session_index": [1, 2, 2, 2, 3, 3, 1], "session_date": ["d1", "d2", "d2", "d2", "d3", "d3", "d1"],
        "phase": ["test", "train", "train", "train", "train", "train", "test"],
        "task_in_phase": [1, 1, 2, 3, 1, 2, 1], "completed": [True, False, True, True, True, True, True],
        "time_s": [50.0, None, 40.0, 20.0, 30.0, 10.0, 70.0], "attempts": [0, 2, 0, 0, 0, 0, 1],
        "criterion_met": [None, False, False, True, False, False, None]})
    summary = trainee_summary(trials, "T1")
    assert summary.session.tolist() == ["pre", "t1", "t2"]
    assert summary.tasks.tolist() == [1, 3, 2] and summary.completed.tolist() == [1, 2, 2]
    assert summary.median_time_s.tolist() == [50.0, 30.0, 20.0]
    assert summary.criterion_met.tolist()[1:] == [True, False] and pd.isna(summary.criterion_met[0])
    assert summary.tasks_to_criterion.tolist()[1] == 3 and summary.tasks_to_criterion.isna().tolist() == [True, False,
                                                                                                          True]
    with pytest.raises(AnalysisInputError, match="participant 'T9': no such participant"):
        trainee_summary(trials, "T9")
