"""Linear mixed models of the trials against R's lme4 1.1-31 and lmerTest 3.1-3 (REML, sum-to-zero
coding, Satterthwaite df, ``anova(type = 3)``; tests/analysis/r/reference.R, stored in
tests/analysis/r/expected/ by reproduce.sh), and against the ANOVA it must equal on complete
balanced data.

R fits with bobyqa at rhoend = 1e-12, so both sides sit on the REML optimum; lmerTest
differentiates numerically (its own 1-df and F-test df agree to about 1e-7), we analytically:
everything is compared at 1e-6 relative.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from microg.analysis import (
    COEFFICIENT_COLUMNS,
    MODEL_ANOVA_COLUMNS,
    AnalysisInputError,
    mixed_anova,
    trial_model,
)
from tests.analysis.r_compare import (
    PRACTICE,
    PRACTICE_CSV,
    R_ART_NUMBERS,
    R_MODEL_COEFFICIENT_NUMBERS,
    R_MODEL_RANDOM_NUMBERS,
    STUDY,
    TRIALS_CSV,
    assert_same_numbers,
)


def _assert_model_matches(model, expected_dir, prefix="trial_model_"):
    assert list(model.anova.columns) == list(MODEL_ANOVA_COLUMNS)
    assert list(model.coefficients.columns) == list(COEFFICIENT_COLUMNS)
    assert_same_numbers(model.coefficients, pd.read_csv(expected_dir / f"{prefix}coefficients.csv"), ["term"],
                        R_MODEL_COEFFICIENT_NUMBERS)  # fmt: skip
    assert_same_numbers(model.anova, pd.read_csv(expected_dir / f"{prefix}anova.csv"), ["source"], R_ART_NUMBERS)
    random = pd.read_csv(expected_dir / f"{prefix}random.csv")
    assert_same_numbers(model.random, random, ["name"], R_MODEL_RANDOM_NUMBERS)
    assert model.n_trials == random["n_trials"].iloc[0]
    return random["slope"].iloc[0]


def test_a_random_slope_of_practice_matches_lmertest():
    trials = pd.read_csv(PRACTICE_CSV)
    model = trial_model(trials, "time_s", "group * object + task_index", "participant", "log", slope="task_index")
    assert _assert_model_matches(model, PRACTICE)
    assert model.formula == "log(time_s) ~ group * object + task_index + (1 + task_index | participant)"
    assert model.n_trials == trials["time_s"].notna().sum() < len(trials)  # unfinished tasks left out


def test_a_singular_slope_is_dropped_as_lme4_flags_it():
    """The study export's participants share one practice rate: lme4 fits the slope's variance at 0
    (isSingular), and both sides fall back to the random intercept."""
    trials = pd.read_csv(TRIALS_CSV)
    rows = trials[(trials["phase"] != "training") & trials["completed"]]
    model = trial_model(rows, "time_s", "group * object * interaction + task_index", "participant", "log",
                        slope="task_index")  # fmt: skip
    assert not _assert_model_matches(model, STUDY)
    assert "random slope of task_index is singular" in model.note
    assert model.formula.endswith("+ (1 | participant)")
    assert list(model.anova["source"]) == ["group", "object", "interaction", "task_index", "group:object",
                                           "group:interaction", "object:interaction", "group:object:interaction"]


def test_on_complete_data_the_model_is_the_anova():
    """One value per subject and level, a random intercept: the type 3 F tests equal the mixed
    ANOVA's uncorrected ones, with its df (N - groups, (k - 1)(N - groups)), when the subjects'
    variance is not at 0."""
    data = pg.read_dataset("mixed_anova")
    model = trial_model(data, "Scores", "Group * Time", "Subject")
    anova = mixed_anova(data, "Scores", "Time", "Group", "Subject")
    np.testing.assert_allclose(model.anova["F"], anova["F"], rtol=1e-6)
    np.testing.assert_allclose(model.anova["df2"], anova["df2"], rtol=1e-6)
    np.testing.assert_allclose(model.anova["p_unc"], anova["p_unc"], rtol=1e-5)
    assert "singular" not in model.note


def test_a_subject_variance_at_zero_is_said():
    """In pingouin's unbalanced set the subjects' means vary less than the errors: REML puts their
    variance at 0 (lme4: a singular fit), where the model is no longer the ANOVA."""
    model = trial_model(pg.read_dataset("mixed_anova_unbalanced"), "Scores", "Group * Time", "Subject")
    assert "singular fit" in model.note
    assert model.random["variance"].iloc[0] < 1e-6 * model.random["variance"].iloc[-1]


def test_log_needs_positive_values():
    trials = pd.read_csv(PRACTICE_CSV)
    trials.loc[5, "time_s"] = 0.0
    with pytest.raises(AnalysisInputError, match=r"column 'time_s' value 0.0 cannot be log-transformed \(data row 6, participant 'P01'\)"):
        trial_model(trials, "time_s", "group * object", "participant", "log")


@pytest.mark.parametrize("fixed, message", [
    ("group:object", "group:object without group"),
    ("group * shape", "missing column 'shape'"),
    ("  + ", "name no column"),
])  # fmt: skip
def test_bad_formulas_are_refused(fixed, message):
    with pytest.raises(AnalysisInputError, match=message):
        trial_model(pd.read_csv(PRACTICE_CSV), "time_s", fixed, "participant")


def test_a_cell_without_trials_cannot_be_estimated():
    trials = pd.read_csv(PRACTICE_CSV)
    trials = trials[~((trials["group"] == "V") & (trials["object"] == "cube"))]
    with pytest.raises(AnalysisInputError, match="cannot estimate"):
        trial_model(trials, "time_s", "group * object", "participant")
