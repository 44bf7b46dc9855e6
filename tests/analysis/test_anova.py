"""Mixed ANOVA against R's afex (values from tests/analysis/r/reference.R, see reproduce.sh).

Data: pingouin's shipped datasets ``mixed_anova`` (2 groups x 30, 3 times, balanced) and
``mixed_anova_unbalanced`` (groups of 7, 10 and 9, 4 times).
R: afex 1.2-1 ``aov_ez(..., type = 3 or 2)``, ``summary(fit$Anova, multivariate = FALSE)`` for the
sums of squares, Mauchly's test and the Greenhouse-Geisser and Huynh-Feldt epsilons and p (R 4.2.2,
Debian bookworm); the newer columns are compared with tests/analysis/r/expected/mixed/ (reproduce.sh).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from microg.analysis import (
    ANOVA_COLUMNS,
    AnalysisInputError,
    mixed_anova,
    posthoc,
    sphericity_correction,
)
from tests.analysis.r_compare import MIXED, R_ANOVA_NUMBERS, R_DIR, assert_same_numbers

RTOL = 1e-6
COLUMNS = ["SS", "df1", "df2", "F", "p_unc", "np2", "eps_GG", "p_GG", "W_mauchly", "p_mauchly"]
NA = np.nan

# afex aov_ez(id="Subject", dv="Scores", between="Group", within="Time", type=3) on mixed_anova.csv
AFEX_BALANCED = {
    "Group": [5.45996328685603, 1, 58, 5.05170878609196, 0.028419776007486, 0.0801200932274539, NA, NA, NA, NA],
    "Time": [7.62842835649281, 2, 116, 4.02739419113443, 0.02036941261283, 0.0649292823542483,
             0.998120270774494, 0.0204376569647503, 0.998116730738223, 0.947693844217539],
    "Group:Time": [5.16719196171499, 2, 116, 2.72799558684655, 0.0695448074359955, 0.0449215482988446,
                   0.998120270774494, 0.0696550310187487, 0.998116730738223, 0.947693844217539],
}  # fmt: skip
# the same on mixed_anova_unbalanced.csv, type = 3 (afex's default)
AFEX_UNBALANCED_TYPE3 = {
    "Group": [3.56483105330055, 2, 23, 2.30264156342949, 0.122591327600996, 0.166826150838431, NA, NA, NA, NA],
    "Time": [5.00283704239967, 3, 69, 1.53913775728604, 0.212156569601361, 0.062721753816678,
             0.925373973335584, 0.21538706474383, 0.885031779667749, 0.753523776797631],
    "Group:Time": [5.77091647127531, 6, 69, 0.887719843741232, 0.508790044498513, 0.0716612786645916,
                   0.925373973335584, 0.503080294029912, 0.885031779667749, 0.753523776797631],
}  # fmt: skip
# and type = 2: only the within main effect differs
AFEX_UNBALANCED_TYPE2_TIME = [5.54865217076207, 3, 69, 1.7070594116275, 0.173606627760472, 0.0690919701607281,
                              0.925373973335584, 0.177920493294535, 0.885031779667749, 0.753523776797631]  # fmt: skip


def _expected(rows: dict) -> pd.DataFrame:
    return pd.DataFrame.from_dict(rows, orient="index", columns=COLUMNS)


def _assert_matches(table: pd.DataFrame, expected: pd.DataFrame) -> None:
    assert list(table["source"]) == list(expected.index)
    got = table.set_index("source")[COLUMNS]
    np.testing.assert_allclose(got.to_numpy(float), expected.to_numpy(float), rtol=RTOL)


def test_balanced_matches_afex_type3():
    data = pg.read_dataset("mixed_anova")
    table = mixed_anova(data, "Scores", "Time", "Group", "Subject")
    assert list(table.columns) == list(ANOVA_COLUMNS)
    _assert_matches(table, _expected(AFEX_BALANCED))


def test_unbalanced_matches_afex_type3():
    data = pg.read_dataset("mixed_anova_unbalanced")
    table = mixed_anova(data, "Scores", "Time", "Group", "Subject", ss_type=3)
    _assert_matches(table, _expected(AFEX_UNBALANCED_TYPE3))


def test_unbalanced_type2_matches_afex_type2():
    data = pg.read_dataset("mixed_anova_unbalanced")
    table = mixed_anova(data, "Scores", "Time", "Group", "Subject", ss_type=2)
    expected = _expected({**AFEX_UNBALANCED_TYPE3, "Time": AFEX_UNBALANCED_TYPE2_TIME})
    _assert_matches(table, expected)


def test_greenhouse_geisser_df_are_epsilon_times_df():
    table = mixed_anova(pg.read_dataset("mixed_anova_unbalanced"), "Scores", "Time", "Group", "Subject")
    within = table.iloc[1:]
    np.testing.assert_allclose(within["df1_GG"], within["df1"] * 0.925373973335584, rtol=RTOL)
    np.testing.assert_allclose(within["df2_GG"], within["df2"] * 0.925373973335584, rtol=RTOL)
    np.testing.assert_allclose(table["MS"], table["SS"] / table["df1"], rtol=RTOL)


def test_missing_cell_drops_the_participant_with_a_warning():
    data = pg.read_dataset("mixed_anova_unbalanced")
    lost = data["Subject"].iloc[0]
    holed = data.drop(index=data.index[(data["Subject"] == lost) & (data["Time"] == "T2")])
    with pytest.warns(UserWarning, match=rf"dropped 1 Subject.*{lost}: no Scores for Time T2"):
        table = mixed_anova(holed, "Scores", "Time", "Group", "Subject")
    without = mixed_anova(data[data["Subject"] != lost], "Scores", "Time", "Group", "Subject")
    pd.testing.assert_frame_equal(table, without)


def test_two_within_levels_f_is_the_squared_posthoc_t():
    """With two levels the within F equals the square of the emmeans-style contrast's t, and
    sphericity holds trivially."""
    data = pg.read_dataset("mixed_anova_unbalanced")
    data = data[data["Time"].isin(["T0", "T3"])]
    table = mixed_anova(data, "Scores", "Time", "Group", "Subject").set_index("source")
    contrast = posthoc(data, "Scores", "Time", "Group", "Subject").iloc[0]
    assert table.loc["Time", "F"] == pytest.approx(contrast["T"] ** 2, rel=RTOL)
    assert table.loc["Time", "eps_GG"] == pytest.approx(1.0)
    assert np.isnan(table.loc["Time", "W_mauchly"])
    decision = sphericity_correction(table.reset_index()).set_index("source")
    assert decision.loc["Time", "correction"] == "none"


def test_sphericity_correction_uses_greenhouse_geisser_when_mauchly_rejects():
    table = mixed_anova(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject")
    table.loc[1, "p_mauchly"] = 0.01  # as if sphericity failed for Time only
    decision = sphericity_correction(table).set_index("source")
    assert decision.loc["Time", "correction"] == "Greenhouse-Geisser"
    assert decision.loc["Time", "p"] == table.loc[1, "p_GG"]
    assert decision.loc["Time", "df2"] == table.loc[1, "df2_GG"]
    assert "sphericity violated" in decision.loc["Time", "reason"]
    assert decision.loc["Group:Time", "correction"] == "none"
    assert decision.loc["Group", "p"] == table.loc[0, "p_unc"]


def test_too_few_error_degrees_of_freedom_is_an_input_error():
    data = pd.DataFrame(
        {"s": ["a", "a", "b", "b"], "g": ["x", "x", "y", "y"], "w": ["1", "2", "1", "2"], "v": [1.0, 2, 3, 5]}
    )
    with pytest.raises(
        AnalysisInputError, match="leave 0 error degrees of freedom; the 2 levels of column 'w' need at least 1"
    ):
        mixed_anova(data, "v", "w", "g", "s")


@pytest.mark.parametrize("dataset, ss_type", [("mixed_anova", 3), ("mixed_anova", 2), ("mixed_anova_unbalanced", 3),
                                              ("mixed_anova_unbalanced", 2)])  # fmt: skip
def test_every_column_matches_r(dataset, ss_type):
    """Generalised eta squared (afex), the Huynh-Feldt epsilon and p (car), the CI of partial eta
    squared (the noncentral F inverted in R; effectsize to its optimiser's 1e-5) and the rest."""
    table = mixed_anova(pg.read_dataset(dataset), "Scores", "Time", "Group", "Subject", ss_type=ss_type)
    expected = pd.read_csv(MIXED / f"{dataset}_type{ss_type}_anova.csv")
    assert_same_numbers(table, expected, ["source"], R_ANOVA_NUMBERS)
    merged = table.merge(expected, on="source", suffixes=("", "_r"))
    for bound in ("np2_ci_low", "np2_ci_high"):
        np.testing.assert_allclose(merged[bound], merged[f"{bound}_effectsize"], rtol=1e-4, atol=1e-6)


def test_an_effect_with_a_sum_of_squares_of_zero_has_f_0_and_p_1_as_in_r():
    """Both groups hold the same values: afex gives F = 0 (to 1e-30) and p = 1 for group and the
    interaction; statsmodels' multivariate test used to crash there."""
    data = pd.read_csv(R_DIR / "zero_effect.csv")
    table = mixed_anova(data, "attempts", "object", "group", "participant")
    assert_same_numbers(table, pd.read_csv(MIXED / "zero_effect_type3_anova.csv"), ["source"], R_ANOVA_NUMBERS)
    zero = table.set_index("source").loc[["group", "group:object"]]
    assert (zero["SS"] == 0).all() and (zero["F"] == 0).all() and (zero["p_unc"] == 1).all()
    assert (zero["np2"] == 0).all() and (zero["ges"] == 0).all()


def test_a_measure_without_variation_gives_f_0_and_p_1_not_a_crash():
    """A constant measure (every drop count 0): nothing to test. R's afex divides 0 by 0 there (NaN
    for the within effects, rounding noise for the between effect); we report F = 0 and p = 1."""
    data = pd.DataFrame({"s": list("aaabbbcccddd"), "g": list("xxxxxxyyyyyy"), "w": list("123") * 4,
                         "v": [0.0] * 12})  # fmt: skip
    table = mixed_anova(data, "v", "w", "g", "s")
    assert (table["F"] == 0).all() and (table["p_unc"] == 1).all()
    assert table["eps_GG"].isna().all()
    assert (sphericity_correction(table)["p"] == 1).all()
