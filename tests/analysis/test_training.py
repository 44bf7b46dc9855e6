"""The report's training section (microg.analysis.training, survival) against R on a fixed program
(tests/analysis/r/training_trials.csv, made by tests/analysis/training_data.py: make_training(2026);
R's numbers in tests/analysis/r/expected/training/ by reference.R "training": nls, lme4/lmerTest,
survival's survfit, quantile and survdiff, afex/emmeans, stats), the section's presence, its
sentences' format, and what the training functions refuse."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main

from microg.analysis import (
    AnalysisInputError,
    analyse_training,
    is_training,
    kaplan_meier,
    median_survival,
    session_roles,
    write_report,
)
from microg.analysis import results as r
from microg.analysis.tables import check_training
from microg.analysis.training import add_practice
from tests.analysis.r_compare import TRAINING, TRAINING_CSV, TRIALS_CSV, assert_training_matches
from tests.analysis.training_data import MAX_TASKS, make_training

pytestmark = pytest.mark.filterwarnings("ignore")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("training_report")
    write_report(TRAINING_CSV, None, out, title="Training program")
    return out


@pytest.fixture(scope="module")
def program():
    return analyse_training(pd.read_csv(TRAINING_CSV))


def test_every_number_of_the_section_equals_r(report):
    assert_training_matches(report / "training", TRAINING)


def test_the_section_is_in_a_programs_report(report):
    markdown = (report / "report.md").read_text(encoding="utf-8")
    html = (report / "report.html").read_text(encoding="utf-8")
    assert "## Training program" in markdown and "<h2>Training program</h2>" in html
    assert markdown.index("## Training program") < markdown.index("## Methods")
    for stem in ("training_learning_time", "training_learning_attempts", "training_criterion", "training_tests"):
        assert (report / "figures" / f"{stem}.png").stat().st_size > 0
        assert f"figures/{stem}.png" in html
    assert "Tasks to criterion (microg.analysis.training" not in markdown
    assert "Training program (microg.analysis.training)" in markdown  # its methods


def test_the_papers_report_has_no_training_section(tmp_path):
    trials = pd.read_csv(TRIALS_CSV)
    assert not is_training(trials)
    write_report(trials, None, tmp_path)
    assert "Training program" not in (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "Training program" not in (tmp_path / "report.html").read_text(encoding="utf-8")
    assert not (tmp_path / "training").exists() and not list((tmp_path / "figures").glob("training_*"))


def test_one_session_with_a_criterion_is_a_program():
    trials = pd.DataFrame({"participant": ["P1", "P1"], "session_index": 1, "criterion_met": [None, "True"]})
    assert is_training(trials) and not is_training(trials.assign(criterion_met=None))


def test_roles_follow_the_session_order_and_can_be_named(program):
    assert program.roles == {"pretest": "pretest", "posttest": "posttest", "retention": "retention"}
    assert list(program.sessions["role"]) == ["pretest", "training", "training", "training", "posttest", "retention"]
    trials = pd.read_csv(TRAINING_CSV)
    named = session_roles(trials, posttest="retention", retention=None)
    assert dict(zip(named["session"], named["role"]))["retention"] == "posttest"
    assert "retention" not in set(named["role"])
    with pytest.raises(AnalysisInputError, match=r"the posttest session 'post' is not in column 'session' "
                                                 r"\(sessions: pretest, train1"):
        session_roles(trials, posttest="post")


def test_two_test_sessions_are_a_pretest_and_a_posttest():
    trials = pd.read_csv(TRAINING_CSV)
    trials = trials[trials["session"] != "retention"]
    program = analyse_training(trials)
    assert program.roles == {"pretest": "pretest", "posttest": "posttest"}
    assert len(program.test_anova) == 3 and program.retention.empty
    paragraphs = r.training_paragraphs(program)
    assert not any(p.startswith("Retention loss") for p in paragraphs)


def test_tasks_to_criterion_censor_at_the_bound(program):
    reached = program.criterion
    trials = make_training(2026)
    assert len(reached) == 16 * 3
    censored = reached[~reached["criterion_met"]]
    assert (censored["tasks"] == MAX_TASKS).all() and (censored["at_tasks"] == MAX_TASKS).all()
    assert censored["tasks_to_criterion"].isna().all()
    met = reached[reached["criterion_met"]].merge(
        trials[trials["criterion_met"] == True], on=["participant", "session"])  # noqa: E712
    assert (met["tasks_to_criterion"] == met["task_in_phase"]).all()  # the task that met it
    assert len(met) == reached["criterion_met"].sum()


def test_practice_counts_every_task_that_ran_across_sessions():
    trials = pd.DataFrame({"participant": ["P1"] * 5 + ["P2"], "session_index": [2, 1, 1, 2, 1, 1],
                           "task_index": [0, 1, 0, 1, 2, 0], "attempts": [0, 3, 1, np.nan, 0, 0]})
    assert add_practice(trials)["practice"].tolist() == [4, 2, 1, pd.NA, 3, 1]


def test_a_median_on_a_plateau_is_its_middle_as_in_r():
    """S = 0.5 exactly from 4 to 6 tasks: R's quantile.survfit gives 5 (statsmodels' rule would give 4)."""
    data = pd.DataFrame({"tasks": [2, 3, 4, 4, 6, 7, 8, 8], "met": True})
    assert median_survival(data, "tasks", "met")["median"].iloc[0] == 5.0
    km = kaplan_meier(data, "tasks", "met")
    assert km.loc[km["time"] == 4, "surv"].iloc[0] == 0.5


def test_apa_sentences(program):
    learning, *criteria = r.training_paragraphs(program)[:4]
    number = r"-?\d+\.\d{2}"
    assert re.search(rf"group B: completion time = {number} × practice\^{number} \(slope b = -?\d\.\d{{3}}, SE = "
                     rf"\d\.\d{{3}}, t\({number}\) = {number}, p (< \.001|= \.\d{{3}})\)", learning)
    assert re.search(rf"The groups' slopes (did not )?differ(ed)? significantly, F\(1, {number}\) = {number}, p "
                     r"(< \.001|= \.\d{3}) \(group × log practice\)", learning)
    assert re.search(r"median c = \d\.\d{2} \(IQR \d\.\d{2}-\d\.\d{2}, n = 8\)", learning)
    first = criteria[0]
    assert first.startswith("Tasks to criterion, train1 (training): 3 of 8 in B, 7 of 8 in P met the criterion")
    assert "B, Mdn not reached, 95 % CI [14, not reached]; P, Mdn = 4.5, 95 % CI [3, not reached]" in first
    assert re.search(r"log-rank χ²\(1\) = 7\.19, p = \.007\.$", first)
    tests = next(p for p in r.training_paragraphs(program) if p.startswith("Tests ("))
    assert re.search(rf"a significant main effect of session, F\({number}, {number}\) = {number}, p < \.001, ηp² = "
                     r"\.\d{2}, 95 % CI \[\.\d{2}, \.\d{2}\], ηG² = \.\d{2} "
                     r"\(Greenhouse-Geisser corrected, ε = \.\d{2}\)",
                     tests)
    retention = r.training_paragraphs(program)[-1]
    assert re.search(rf"^Retention loss \(retention − posttest, .*group B \(n = 8\): M = {number} vs {number}, "
                     rf"loss M "
                     rf"= {number}, 95 % CI \[{number}, {number}\], t\(7\) = {number}, p = \.\d{{3}}, d_z = {number}, "
                     rf"95 % CI \[{number}, {number}\]; Wilcoxon signed-rank V = \d+\.\d, p = \.\d{{3}}", retention)
    assert r.median_text(2.0, 2.0, float("nan")) == "Mdn = 2, 95 % CI [2, not reached]"


def test_a_withdrawn_trainee_is_left_out():
    trials = pd.read_csv(TRAINING_CSV)
    trials.loc[trials["participant"] == "T03", "withdrawn"] = True
    program = analyse_training(trials)
    assert "T03" not in set(program.power_law["participant"]) and "Withdrawn, left out: T03." in program.notes
    assert program.criterion["participant"].nunique() == 15


@pytest.mark.parametrize("column, value, message", [
    ("session_index", 0, r"column 'session_index' value 0 is not a whole number of 1 or more \(data row 3, "
                         r"participant 'T01'\)"),
    ("task_in_phase", 1.5, r"column 'task_in_phase' value 1.5 is not a whole number of 1 or more"),
    ("criterion_met", "maybe", r"column 'criterion_met' value 'maybe' is not True, False or empty \(data row 3"),
    ("session", " ", r"column 'session' value ' ' is empty \(data row 3"),
])  # fmt: skip
def test_bad_session_columns_are_refused_naming_file_column_and_row(column, value, message):
    trials = pd.read_csv(TRAINING_CSV)
    trials[column] = trials[column].astype(object)
    trials.loc[2, column] = value
    with pytest.raises(AnalysisInputError, match=f"^training.csv: {message}"):
        check_training(trials, "training.csv")


def test_a_session_with_two_indexes_is_refused():
    trials = pd.read_csv(TRAINING_CSV)
    trials.loc[2, "session_index"] = 3
    with pytest.raises(AnalysisInputError, match=r"participant 'T01' has 1 and 3 in column 'session_index' for session "
                                                 r"'pretest'; one is allowed"):
        analyse_training(trials)


def test_microg_report_names_the_test_sessions(tmp_path):
    args = ["report", "--trials", str(TRAINING_CSV), "--out", str(tmp_path / "r")]
    result = CliRunner().invoke(main, [*args, "--posttest", "train3", "--exclude-phase", "warm-up"])
    assert result.exit_code == 0, result.output
    sessions = pd.read_csv(tmp_path / "r" / "training" / "sessions.csv")
    assert dict(zip(sessions["session"], sessions["role"])) == {
        "pretest": "pretest", "train1": "training", "train2": "training", "train3": "posttest", "posttest": "test",
        "retention": "retention"}
    assert "Retention loss (retention \u2212 train3" in (tmp_path / "r" / "report.md").read_text(encoding="utf-8")
    result = CliRunner().invoke(main, [*args, "--retention", "week"])
    assert result.exit_code == 1
    assert "the retention session 'week' is not in column 'session'" in result.output
    assert "Traceback" not in result.output


def test_a_test_session_without_tasks_to_analyse_is_said():
    """The last training session named the post-test while its phase (training) is left out of the tests."""
    program = analyse_training(pd.read_csv(TRAINING_CSV), posttest="train3", excluded_phases=("training",))
    assert "The posttest session train3 has no completed task outside the phases left out (training): it is not " \
           "analysed." in program.notes
    assert program.test_order() == ["pretest", "retention"] and program.retention.empty
    assert set(program.test_cells["session"]) == {"pretest", "retention"} and len(program.test_anova) == 3


def test_a_phase_nobody_passed_is_reported_without_a_test():
    trials = pd.read_csv(TRAINING_CSV)
    trials.loc[trials["session"] == "train1", "criterion_met"] = False
    program = analyse_training(trials)
    assert "No log-rank test for train1, training: log-rank test: 2 group(s) in column 'group' and 0 event(s) in " \
           "column 'criterion_met': it needs two groups and an event." in program.notes
    first = next(p for p in r.training_paragraphs(program) if p.startswith("Tasks to criterion, train1"))
    assert "0 of 8 in B, 0 of 8 in P met the criterion" in first and "B, Mdn not reached, 95 % CI [not reached, " \
           "not reached]" in first and first.endswith("No log-rank test (one group, or nobody met the criterion).")


def test_every_column_may_have_another_name(program):
    names = {"participant": "pid", "group": "cohort", "session": "visit", "session_index": "visit_order",
             "task_index": "trial", "task_in_phase": "trial_in_block", "criterion_met": "proficient", "phase": "block",
             "time_s": "rt", "attempts": "drops", "completed": "done"}  # fmt: skip
    trials = pd.read_csv(TRAINING_CSV).rename(columns=names)
    renamed = analyse_training(trials, subject="pid", group="cohort", session="visit", session_index="visit_order",
                               task_index="trial", task_in_phase="trial_in_block", criterion="proficient",
                               phase="block", dv="rt", attempts="drops", completed="done")  # fmt: skip
    back = {new: old for old, new in names.items()}
    for table in ("medians", "logrank", "power_law", "retention", "test_anova", "kaplan_meier", "criterion"):
        sources = {"cohort": "group", "visit": "session", "cohort:visit": "group:session"}
        ours = getattr(renamed, table).rename(columns=back).replace({"measure": {"rt": "time_s"}, "source": sources})
        pd.testing.assert_frame_equal(ours, getattr(program, table), check_dtype=False, obj=table)
    assert renamed.practice_model.formula == "log(rt) ~ cohort * log_practice + (1 + log_practice | pid)"
    assert len(r.training_paragraphs(renamed)) == len(r.training_paragraphs(program))
