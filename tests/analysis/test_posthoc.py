"""Post hoc comparisons against R's emmeans on afex's multivariate model (emmeans 1.8.4-1).

R (tests/analysis/r/reference.R, "mixed" mode; see reproduce.sh):
  fit <- aov_ez(id = "Subject", dv = "Scores", between = "Group", within = "Time", type = 3)
  summary(pairs(emmeans(fit, ~ Time)), by = NULL, adjust = "bonferroni")
  summary(pairs(emmeans(fit, ~ Group | Time)), by = NULL, adjust = "bonferroni")
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from microg.analysis import POSTHOC_COLUMNS, posthoc, simple_effects
from tests.analysis.r_compare import (
    MIXED,
    R_POSTHOC_NUMBERS,
    R_SIMPLE_NUMBERS,
    assert_same_numbers,
)

RTOL = 1e-6
NUMBERS = ["estimate", "SE", "df", "T", "p_unc", "p_bonf"]

# pingouin's mixed_anova dataset (balanced)
EMMEANS_BALANCED = [
    ("Time", None, "August", "January", -0.316903530487015, 0.181338529290947, 58, -1.74757968825567, 0.0858293654955377, 0.257488096486613),
    ("Time", None, "August", "June", -0.498142541076425, 0.174865763351036, 58, -2.84871395938395, 0.0060648774331796, 0.0181946322995388),
    ("Time", None, "January", "June", -0.18123901058941, 0.176762703505255, 58, -1.02532382111943, 0.309467816357479, 0.928403449072436),
    ("Group", "August", "Control", "Meditation", 0.0757020973426968, 0.239546948145518, 58, 0.316021965333951, 0.753120305493897, 1),
    ("Group", "January", "Control", "Meditation", -0.366982306356934, 0.25596419014476, 58, -1.43372518690754, 0.157019977775615, 0.471059933326844),
    ("Group", "June", "Control", "Meditation", -0.753704315929174, 0.274644502297311, 58, -2.74429056334529, 0.00805764069446998, 0.0241729220834099),
]  # fmt: skip
# pingouin's mixed_anova_unbalanced dataset: the time pairs and the group pairs at T2
EMMEANS_UNBALANCED = [
    ("Time", None, "T0", "T1", -0.231038323802443, 0.251954939860291, 23, -0.916982710998064, 0.368667440545976, 1),
    ("Time", None, "T0", "T2", -0.382958690903554, 0.326867993677577, 23, -1.17160045740454, 0.253351848817624, 1),
    ("Time", None, "T0", "T3", -0.608627147721196, 0.313082610911468, 23, -1.94398259919105, 0.0642298716819751, 0.385379230091851),
    ("Time", None, "T1", "T2", -0.151920367101111, 0.282437622145756, 23, -0.53788998061565, 0.595820090879451, 1),
    ("Time", None, "T1", "T3", -0.377588823918753, 0.288803751741945, 23, -1.30742354156168, 0.203988425738582, 1),
    ("Time", None, "T2", "T3", -0.225668456817642, 0.282541165055588, 23, -0.798710010179378, 0.432629328283325, 1),
    ("Group", "T2", "Control", "Meditation", -1.24652156088273, 0.511736576217185, 23, -2.43586567545582, 0.0230159492564695, 0.276191391077634),
    ("Group", "T2", "Control", "Therapy", -0.292991157428205, 0.523312049961607, 23, -0.559878484452442, 0.580974800265037, 1),
    ("Group", "T2", "Meditation", "Therapy", 0.95353040345452, 0.477118838167295, 23, 1.99851761694678, 0.057615598780577, 0.691387185366924),
]  # fmt: skip


def _matched(table: pd.DataFrame, expected: list) -> tuple[np.ndarray, np.ndarray]:
    got, want = [], []
    for factor, at, a, b, *numbers in expected:
        row = table[(table["factor"] == factor) & (table["A"] == a) & (table["B"] == b)]
        if at is not None:
            row = row[row["at"] == at]
        assert len(row) == 1, (factor, at, a, b)
        got.append(row[NUMBERS].to_numpy(float)[0])
        want.append(numbers)
    return np.array(got), np.array(want, float)


def test_balanced_matches_emmeans():
    table = posthoc(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject")
    assert list(table.columns) == list(POSTHOC_COLUMNS)
    assert len(table) == len(EMMEANS_BALANCED)
    got, want = _matched(table, EMMEANS_BALANCED)
    np.testing.assert_allclose(got, want, rtol=RTOL)


def test_unbalanced_three_groups_matches_emmeans():
    table = posthoc(pg.read_dataset("mixed_anova_unbalanced"), "Scores", "Time", "Group", "Subject")
    assert len(table) == 6 + 4 * 3  # time pairs, then 3 group pairs at each of 4 times
    got, want = _matched(table, EMMEANS_UNBALANCED)
    np.testing.assert_allclose(got, want, rtol=RTOL)


def test_stars_follow_the_corrected_p():
    table = posthoc(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject").set_index(["A", "B"])
    assert table.loc[("August", "June"), "stars"] == "*"  # p_bonf .018
    assert table.loc[("August", "January"), "stars"] == ""  # p_bonf .26
    assert table.loc[("Control", "Meditation")].set_index("at").loc["June", "stars"] == "*"


def test_pooled_within_group_variance_differs_from_a_groupless_paired_t():
    """pingouin's paired t-tests ignore the groups: different SE and df, so a different p."""
    data = pg.read_dataset("mixed_anova_unbalanced")
    ours = posthoc(data, "Scores", "Time", "Group", "Subject").iloc[2]  # T0 - T3
    paired = pg.pairwise_tests(data, dv="Scores", within="Time", subject="Subject")
    groupless = paired[(paired["A"] == "T0") & (paired["B"] == "T3")].iloc[0]
    assert ours["df"] == 23 and groupless["dof"] == 25
    assert abs(ours["p_unc"] - groupless["p_unc"]) > 1e-3


@pytest.mark.parametrize("dataset", ["mixed_anova", "mixed_anova_unbalanced"])
def test_confidence_intervals_and_simple_effects_match_emmeans(dataset):
    """95 % CIs (unadjusted and Bonferroni-adjusted, emmeans' confint), the simple effects
    (joint_tests by group) and the pairs within each group, on balanced and unbalanced data."""
    data = pg.read_dataset(dataset)
    prefix = MIXED / f"{dataset}_type3"
    table = posthoc(data, "Scores", "Time", "Group", "Subject", within_by_group=True)
    classic = table[~(table["at"].notna() & (table["factor"] == "Time"))]
    assert_same_numbers(classic, pd.read_csv(f"{prefix}_posthoc.csv"), ["factor", "at", "A", "B"], R_POSTHOC_NUMBERS)
    within_groups = table[table["at"].notna() & (table["factor"] == "Time")]
    assert_same_numbers(within_groups, pd.read_csv(f"{prefix}_simple_pairs.csv"), ["factor", "at", "A", "B"],
                        R_POSTHOC_NUMBERS)  # fmt: skip
    effects = simple_effects(data, "Scores", "Time", "Group", "Subject")
    assert_same_numbers(effects, pd.read_csv(f"{prefix}_simple_effects.csv"), ["effect", "at"], R_SIMPLE_NUMBERS)


def test_the_bonferroni_interval_excludes_zero_exactly_when_the_bonferroni_p_is_below_05():
    table = posthoc(pg.read_dataset("mixed_anova_unbalanced"), "Scores", "Time", "Group", "Subject")
    excludes = (table["ci_low_bonf"] > 0) | (table["ci_high_bonf"] < 0)
    assert (excludes == (table["p_bonf"] < 0.05)).all()
