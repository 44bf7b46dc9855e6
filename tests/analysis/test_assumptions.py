"""Assumption checks and cell means against R: car::leveneTest (centre = median, its default),
rstatix::box_m, shapiro.test of afex's residuals, and aggregate() for mean, SD, n per cell
(tests/analysis/r/expected/mixed/, reproduce.sh)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from microg.analysis import assumption_checks, cell_means
from tests.analysis.r_compare import (
    MIXED,
    R_ASSUMPTION_NUMBERS,
    R_CELL_NUMBERS,
    R_DIR,
    assert_same_numbers,
)


@pytest.mark.parametrize("dataset", ["mixed_anova", "mixed_anova_unbalanced"])
def test_levene_box_m_and_shapiro_match_r(dataset):
    checks = assumption_checks(pg.read_dataset(dataset), "Scores", "Time", "Group", "Subject")
    expected = pd.read_csv(MIXED / f"{dataset}_type3_assumptions.csv")
    assert_same_numbers(checks, expected, ["check", "at"], R_ASSUMPTION_NUMBERS)
    assert checks["consequence"].str.len().gt(20).all()


@pytest.mark.parametrize("dataset", ["mixed_anova", "mixed_anova_unbalanced"])
def test_cell_means_match_r(dataset):
    table = cell_means(pg.read_dataset(dataset), "Scores", "Time", "Group")
    expected = pd.read_csv(MIXED / f"{dataset}_type3_cell_means.csv")
    assert_same_numbers(table, expected, ["Group", "Time"], R_CELL_NUMBERS)


def test_identical_groups_have_box_m_0_and_the_consequence_is_stated():
    data = pd.read_csv(R_DIR / "zero_effect.csv")
    checks = assumption_checks(data, "attempts", "object", "group", "participant")
    expected = pd.read_csv(MIXED / "zero_effect_type3_assumptions.csv")
    assert_same_numbers(checks, expected, ["check", "at"], R_ASSUMPTION_NUMBERS)
    box = checks.set_index("check").loc["Box's M"]
    assert not box["violated"] and "pooling them is justified" in box["consequence"]


def test_violations_are_flagged_with_what_follows():
    data = pg.read_dataset("mixed_anova").copy()
    spread = (data["Group"] == "Meditation") & (data["Time"] == "June")
    data.loc[spread, "Scores"] = data.loc[spread, "Scores"] * 6
    checks = assumption_checks(data, "Scores", "Time", "Group", "Subject").set_index(["check", "at"])
    levene = checks.loc[("Levene", "June")]
    assert levene["violated"] and "read those with caution" in levene["consequence"]
    assert checks.loc[("Box's M", "")]["violated"]


def test_checks_the_data_cannot_support_say_why():
    data = pd.DataFrame({"s": list("aaabbbcccddd"), "g": list("xxxxxxyyyyyy"), "w": list("123") * 4,
                         "v": [0.0] * 12})  # fmt: skip
    checks = assumption_checks(data, "v", "w", "g", "s")
    assert checks["p"].isna().all() and not checks["violated"].any()
    assert checks["consequence"].str.contains("cannot be computed").all()
    assert np.isnan(checks["statistic"]).all()


def test_levene_with_two_participants_a_group_says_it_cannot_be_computed_without_a_warning():
    """Two values a group are each as far from their median: the distances do not vary, so the
    test's F would divide by zero (a study of two participants per group)."""
    import warnings

    data = pd.DataFrame({"s": list("aabbccdd"), "g": list("xxxxyyyy"), "w": list("12") * 4,
                         "v": [1.0, 2.0, 3.0, 5.0, 2.0, 2.5, 7.0, 4.0]})  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        checks = assumption_checks(data, "v", "w", "g", "s")
    levene = checks[checks["check"] == "Levene"]
    assert len(levene) == 2 and levene["statistic"].isna().all()
    assert levene["consequence"].str.contains("distances from their group's median do not vary").all()
