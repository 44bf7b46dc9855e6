"""Comparing our tables with R's (tests/analysis/r/expected/, made by reproduce.sh)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

RTOL = 1e-6
ATOL = 1e-12  # for quantities that are exactly zero in R (an estimate of 0 vs -1.7e-16)
R_DIR = Path(__file__).parent / "r"
MIXED = R_DIR / "expected" / "mixed"
STUDY = R_DIR / "expected" / "study"
TRIALS_CSV = R_DIR / "study_trials.csv"
ANSWERS_CSV = R_DIR / "study_questionnaire.csv"
R_ANOVA_NUMBERS = ["SS", "SS_error", "df1", "df2", "F", "p_unc", "np2", "ges", "np2_ci_low", "np2_ci_high",
                   "eps_GG", "p_GG", "eps_HF", "p_HF", "W_mauchly", "p_mauchly"]  # fmt: skip
R_POSTHOC_NUMBERS = ["estimate", "SE", "df", "T", "p_unc", "p_bonf", "ci_low", "ci_high", "ci_low_bonf", "ci_high_bonf"]
R_SIMPLE_NUMBERS = ["df1", "df2", "F", "p_unc", "p_bonf"]
R_ASSUMPTION_NUMBERS = ["statistic", "df1", "df2", "p"]
R_CELL_NUMBERS = ["n", "mean", "sd", "se", "share_zero"]
R_COUNT_NUMBERS = ["chi2", "df", "p_unc", "correlation", "n_tasks"]


def assert_same_numbers(ours: pd.DataFrame, theirs: pd.DataFrame, keys: list[str], numbers: list[str]) -> None:
    """Rows matched on ``keys``; equal to RTOL (ATOL near zero); NaN where R has NA."""
    ours, theirs = ours.copy(), theirs.copy()
    for frame in (ours, theirs):
        for key in keys:
            frame[key] = frame[key].fillna("").astype(str)
    merged = ours.merge(theirs, on=keys, how="outer", suffixes=("", "_r"), indicator=True)
    assert (merged["_merge"] == "both").all(), merged[keys + ["_merge"]]
    for column in numbers:
        np.testing.assert_allclose(merged[column].astype(float), merged[f"{column}_r"].astype(float),
                                   rtol=RTOL, atol=ATOL, err_msg=column)  # fmt: skip


INTERACTIONS_NUMBERS = ["n", "mean_interaction", "sd_interaction", "mean_baseline", "sd_baseline", "mean_diff", "T",
                        "dof", "p_t", "cohen_d", "V", "p_wilcoxon", "rbc", "p_shapiro", "diff_ci_low", "diff_ci_high",
                        "d_z", "d_z_ci_low", "d_z_ci_high", "rbc_ci_low", "rbc_ci_high", "n_nonzero"]  # fmt: skip
LIKERT_NUMBERS = ["n", "V", "p_unc", "z", "r", "rbc", "p_bonf", "rbc_ci_low", "rbc_ci_high"]
INTERACTIONS = ("impulse_penetration", "soft_hand")
MEASURES = {"time_s": "time", "attempts": "attempts"}  # measure -> our file's name for it
TIDY = {  # our tidy CSV -> keys, numbers; R writes one file per measure and interaction
    "simple_effects": (["effect", "at"], R_SIMPLE_NUMBERS),
    "simple_pairs": (["factor", "at", "A", "B"], R_POSTHOC_NUMBERS),
    "assumptions": (["check", "at"], R_ASSUMPTION_NUMBERS),
    "cell_means": (["group", "object"], R_CELL_NUMBERS),
}


def assert_study_matches(ours: Path, theirs: Path) -> None:
    """Every table ``microg report`` wrote into ``ours`` equals R's (reference.R "study" mode) in ``theirs``."""
    for interaction in INTERACTIONS:
        suffix = "" if interaction == INTERACTIONS[0] else f"_{interaction}"
        for dv, short in MEASURES.items():
            assert_same_numbers(
                pd.read_csv(ours / f"anova_{short}{suffix}.csv"),
                pd.read_csv(theirs / f"anova_{dv}_{interaction}.csv"),
                ["source"],
                R_ANOVA_NUMBERS,
            )
            assert_same_numbers(pd.read_csv(ours / f"posthoc_{short}{suffix}.csv"),
                                pd.read_csv(theirs / f"posthoc_{dv}_{interaction}.csv"), ["factor", "at", "A", "B"],
                                R_POSTHOC_NUMBERS)  # fmt: skip
            for name, (keys, numbers) in TIDY.items():
                table = pd.read_csv(ours / f"{name}.csv", dtype={"at": str})
                part = table[(table["interaction"] == interaction) & (table["measure"] == dv)]
                expected = pd.read_csv(theirs / f"{name}_{dv}_{interaction}.csv", dtype={"at": str})
                assert_same_numbers(part, expected, keys, numbers)
        counts = pd.read_csv(ours / "count_model.csv")
        expected = pd.read_csv(theirs / f"count_model_attempts_{interaction}.csv")
        assert_same_numbers(counts[counts["interaction"] == interaction], expected, ["term"], R_COUNT_NUMBERS)
    interactions = pd.read_csv(ours / "interactions.csv")
    expected = pd.read_csv(theirs / "interactions.csv")
    assert_same_numbers(interactions, expected, ["measure", "interaction", "baseline"], INTERACTIONS_NUMBERS)
    # effectsize's own d_z interval (its optimiser stops near 1e-7 relative) and, where no paired
    # difference is zero (effectsize ranks zeros its own way), its rank-biserial correlation and interval
    merged = interactions.merge(expected, on="measure", suffixes=("", "_r"))
    for column in ("d_z_ci_low", "d_z_ci_high", "rbc", "rbc_ci_low", "rbc_ci_high"):
        known = merged[f"{column}_effectsize"].notna()
        np.testing.assert_allclose(merged.loc[known, column], merged.loc[known, f"{column}_effectsize"], rtol=1e-5,
                                   err_msg=column)  # fmt: skip
    assert_models_match(ours, theirs)
    likert = pd.read_csv(ours / "likert.csv")
    numbers = ["n", "median", "q1", "q3", "mean", *[f"count_{score}" for score in range(11)]]
    assert_same_numbers(likert, pd.read_csv(theirs / "likert_summary.csv"), ["item", "interaction"], numbers)
    tests = likert.drop_duplicates("item").drop(columns="n").rename(columns={"n_pairs": "n"})
    assert (tests["test_interaction"] == INTERACTIONS[0]).all() and (tests["test_baseline"] == INTERACTIONS[1]).all()
    assert_same_numbers(tests[["item", *LIKERT_NUMBERS]], pd.read_csv(theirs / "likert_tests.csv"), ["item"],
                        LIKERT_NUMBERS)  # fmt: skip


R_ART_NUMBERS = ["F", "df1", "df2", "p_unc"]
R_ART_CONTRAST_NUMBERS = ["estimate", "SE", "df", "T", "p_unc", "p_bonf"]
R_MODEL_COEFFICIENT_NUMBERS = ["estimate", "SE", "df", "t", "p_unc"]
R_MODEL_RANDOM_NUMBERS = ["variance", "sd", "correlation"]
PRACTICE = R_DIR / "expected" / "practice"
PRACTICE_CSV = R_DIR / "practice_trials.csv"


def assert_models_match(ours: Path, theirs: Path) -> None:
    """The report's trial model (trial_model_*.csv) and the questionnaire's ART (art_anova.csv,
    art_contrasts.csv) equal R's (lme4/lmerTest; ARTool with afex and emmeans)."""
    models = pd.read_csv(ours / "trial_models.csv")
    random = pd.read_csv(theirs / "trial_model_random.csv")
    assert models["n_trials"].iloc[0] == random["n_trials"].iloc[0]
    assert ("+ task_index |" in models["formula"].iloc[0]) == bool(random["slope"].iloc[0]), models["formula"].iloc[0]
    for name, keys, numbers in (("coefficients", ["term"], R_MODEL_COEFFICIENT_NUMBERS),
                                ("anova", ["source"], R_ART_NUMBERS), ("random", ["name"], R_MODEL_RANDOM_NUMBERS)):
        table = pd.read_csv(ours / f"trial_model_{name}.csv")
        assert_same_numbers(table[table["measure"] == "time_s"], pd.read_csv(theirs / f"trial_model_{name}.csv"),
                            keys, numbers)  # fmt: skip
    for name, keys, numbers in (("art_anova", ["source"], R_ART_NUMBERS),
                                ("art_contrasts", ["term", "A", "B"], R_ART_CONTRAST_NUMBERS)):  # fmt: skip
        table = pd.read_csv(ours / f"{name}.csv")
        for item, rows in table.groupby("item"):
            assert_same_numbers(rows, pd.read_csv(theirs / f"{name}_{item}.csv"), keys, numbers)


TRAINING = R_DIR / "expected" / "training"
TRAINING_CSV = R_DIR / "training_trials.csv"
R_POWER_LAW_NUMBERS = ["n", "a", "b", "c", "a_se", "b_se", "c_se", "rss", "sigma"]
R_KAPLAN_MEIER_NUMBERS = ["n_risk", "n_event", "surv", "se", "ci_low", "ci_high"]
R_MEDIAN_NUMBERS = ["n", "events", "median", "ci_low", "ci_high"]
R_LOGRANK_NUMBERS = ["chi2", "df", "p_unc", "n", "events"]
R_RETENTION_NUMBERS = ["n", "mean_posttest", "sd_posttest", "mean_retention", "sd_retention", "mean_diff",
                       "diff_ci_low", "diff_ci_high", "T", "dof", "p_t", "d_z", "d_z_ci_low", "d_z_ci_high", "cohen_d",
                       "V", "p_wilcoxon", "rbc", "rbc_ci_low", "rbc_ci_high", "n_nonzero", "p_shapiro"]  # fmt: skip
TRAINING_FILES = {  # our file in the report's training/ -> R's file, keys, numbers
    "power_law": ("power_law", ["participant", "group"], R_POWER_LAW_NUMBERS),
    "group_curves": ("group_curves", ["group", "parameter"], R_MODEL_COEFFICIENT_NUMBERS),
    "practice_model_coefficients": ("practice_model_coefficients", ["term"], R_MODEL_COEFFICIENT_NUMBERS),
    "practice_model_anova": ("practice_model_anova", ["source"], R_ART_NUMBERS),
    "practice_model_random": ("practice_model_random", ["name"], R_MODEL_RANDOM_NUMBERS),
    "kaplan_meier": ("kaplan_meier", ["session", "phase", "group", "time"], R_KAPLAN_MEIER_NUMBERS),
    "medians": ("medians", ["session", "phase", "group"], R_MEDIAN_NUMBERS),
    "logrank": ("logrank", ["session", "phase"], R_LOGRANK_NUMBERS),
    "session_anova": ("session_anova", ["source"], R_ANOVA_NUMBERS),
    "session_posthoc": ("session_posthoc", ["factor", "at", "A", "B"], R_POSTHOC_NUMBERS),
    "session_cell_means": ("session_cell_means", ["group", "session"], ["n", "mean", "sd", "se"]),
    "session_model_coefficients": ("session_model_coefficients", ["term"], R_MODEL_COEFFICIENT_NUMBERS),
    "session_model_anova": ("session_model_anova", ["source"], R_ART_NUMBERS),
    "session_model_random": ("session_model_random", ["name"], R_MODEL_RANDOM_NUMBERS),
    "retention": ("retention", ["group"], R_RETENTION_NUMBERS),
}


def assert_training_matches(ours: Path, theirs: Path) -> None:
    """Every table of the report's training section (``ours``: its training/ folder) equals R's
    (reference.R "training" mode, in ``theirs``); a power law only where R's nls converged."""
    for name, (file, keys, numbers) in TRAINING_FILES.items():
        table = pd.read_csv(ours / f"{name}.csv", dtype={"at": str})
        expected = pd.read_csv(theirs / f"{file}.csv", dtype={"at": str})
        if name == "power_law":
            assert set(table["participant"]) == set(expected["participant"])
            expected = expected[expected["converged"]]
            assert table.set_index("participant").loc[expected["participant"], "converged"].all()
            table = table[table["participant"].isin(expected["participant"])]
        if name.endswith("_random"):
            assert table.shape[0] == expected.shape[0]  # the random slope kept or dropped alike
        assert_same_numbers(table, expected, keys, numbers)
