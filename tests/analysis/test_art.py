"""The aligned rank transform ANOVA and ART-C contrasts against R's ARTool 0.11.2
(tests/analysis/r/reference.R, stored in tests/analysis/r/expected/ by reproduce.sh).

ARTool's aligned ranks (``art``; ``art.con``'s alignment of the joined factor for the crossed
term), then: type 2, ARTool's own ``anova`` of ``art(y ~ between * within + Error(subject))``;
type 3, afex's ``aov_ez`` of the ranks; contrasts, emmeans on afex's model of each term's ranks.
Data: pingouin's balanced ``mixed_anova`` and unbalanced ``mixed_anova_unbalanced``, the study
export's cells (participants with a missing cell: complete cases), the study's 0-10 ratings, and
``zero_effect.csv`` (both groups hold the same values).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from microg.analysis import ART_COLUMNS, art_anova, art_contrasts, mixed_anova, participant_cells
from microg.analysis.art import aligned_ranks
from tests.analysis.r_compare import (
    ANSWERS_CSV,
    MIXED,
    R_ART_CONTRAST_NUMBERS,
    R_ART_NUMBERS,
    R_DIR,
    STUDY,
    TRIALS_CSV,
    assert_same_numbers,
)

TERMS = ("Group", "Time", "Group:Time")


def _contrasts(data, dv, within, between, subject) -> pd.DataFrame:
    terms = (between, within, f"{between}:{within}")
    return pd.concat([art_contrasts(data, dv, within, between, subject, term) for term in terms], ignore_index=True)


@pytest.mark.parametrize("dataset", ["mixed_anova", "mixed_anova_unbalanced"])
@pytest.mark.parametrize("ss_type", [2, 3])
def test_art_anova_and_contrasts_match_artool(dataset, ss_type):
    data = pg.read_dataset(dataset)
    table = art_anova(data, "Scores", "Time", "Group", "Subject", ss_type)
    assert list(table.columns) == list(ART_COLUMNS) and list(table["source"]) == list(TERMS)
    assert_same_numbers(table, pd.read_csv(MIXED / f"{dataset}_type{ss_type}_art_anova.csv"), ["source"], R_ART_NUMBERS)
    expected = pd.read_csv(MIXED / f"{dataset}_type{ss_type}_art_contrasts.csv")
    assert_same_numbers(_contrasts(data, "Scores", "Time", "Group", "Subject"), expected, ["term", "A", "B"],
                        R_ART_CONTRAST_NUMBERS)  # fmt: skip


def test_type_2_and_3_differ_only_for_the_within_effect_of_unequal_groups():
    data = pg.read_dataset("mixed_anova_unbalanced")
    two, three = (art_anova(data, "Scores", "Time", "Group", "Subject", t).set_index("source")["F"] for t in (2, 3))
    assert two["Group"] == pytest.approx(three["Group"], rel=1e-12)
    assert two["Group:Time"] == pytest.approx(three["Group:Time"], rel=1e-12)
    assert abs(two["Time"] - three["Time"]) > 0.05


@pytest.mark.parametrize("item", ["efficiency", "naturalness"])
def test_ratings_match_artool(item):
    answers = pd.read_csv(ANSWERS_CSV)
    ratings = answers[answers["item"] == item]
    table = art_anova(ratings, "rating", "interaction", "group", "participant")
    assert_same_numbers(table, pd.read_csv(STUDY / f"art_anova_{item}.csv"), ["source"], R_ART_NUMBERS)
    assert_same_numbers(_contrasts(ratings, "rating", "interaction", "group", "participant"),
                        pd.read_csv(STUDY / f"art_contrasts_{item}.csv"), ["term", "A", "B"],
                        R_ART_CONTRAST_NUMBERS)  # fmt: skip


@pytest.mark.filterwarnings("ignore:dropped")
@pytest.mark.parametrize("dv", ["time_s", "attempts"])
@pytest.mark.parametrize("interaction", ["impulse_penetration", "soft_hand"])
def test_incomplete_cells_match_artool_on_the_complete_cases(dv, interaction):
    trials = pd.read_csv(TRIALS_CSV)
    rows = trials[(trials["phase"] != "training") & (trials["interaction"] == interaction)]
    cells = participant_cells(rows, dv, completed="completed" if dv == "time_s" else None)
    table = art_anova(cells, dv, "object", "group", "participant")
    contrasts = _contrasts(cells, dv, "object", "group", "participant")
    assert_same_numbers(table, pd.read_csv(STUDY / f"art_anova_{dv}_{interaction}.csv"), ["source"], R_ART_NUMBERS)
    assert_same_numbers(contrasts, pd.read_csv(STUDY / f"art_contrasts_{dv}_{interaction}.csv"), ["term", "A", "B"],
                        R_ART_CONTRAST_NUMBERS)  # fmt: skip


def test_identical_groups_have_no_group_effect():
    data = pd.read_csv(R_DIR / "zero_effect.csv")
    table = art_anova(data, "attempts", "object", "group", "participant").set_index("source")
    assert table.loc["group", "F"] == pytest.approx(0, abs=1e-12) and table.loc["group", "p_unc"] == pytest.approx(1)
    assert_same_numbers(table.reset_index(), pd.read_csv(MIXED / "zero_effect_type3_art_anova.csv"), ["source"],
                        R_ART_NUMBERS)  # fmt: skip


def test_each_effect_is_aligned_so_that_only_it_remains():
    """Aligned for an effect, the values' other effects are 0: the ANOVA of the aligned values (not
    their ranks) has F = 0 for every other source (ARTool's check that ART applies)."""
    data = pg.read_dataset("mixed_anova_unbalanced")
    values = data["Scores"].to_numpy(float)
    factors = ["Group", "Time"]
    cell = data.groupby(factors)["Scores"].transform("mean")
    for effect in ("Group", "Time", "Group:Time"):
        parts = effect.split(":")
        estimate = _estimate(data, parts)
        aligned = data.assign(Scores=values - cell + estimate)
        table = mixed_anova(aligned, "Scores", "Time", "Group", "Subject", 2).set_index("source")
        others = [source for source in table.index if source != effect]
        assert np.allclose(table.loc[others, "F"], 0, atol=1e-9), (effect, table.loc[others, "F"])
        assert table.loc[effect, "F"] > 0.1


def _estimate(data, parts):
    mean = data["Scores"].mean()
    if len(parts) == 1:
        return data.groupby(parts[0])["Scores"].transform("mean") - mean
    both = data.groupby(parts)["Scores"].transform("mean")
    return both - data.groupby(parts[0])["Scores"].transform("mean") - data.groupby(parts[1])["Scores"].transform(
        "mean") + mean


def test_ties_share_their_average_rank_after_rounding_noise():
    data = pd.DataFrame({"a": ["x", "x", "y", "y"], "b": ["u", "v", "u", "v"], "y": [1.0, 1.0 + 1e-12, 2.0, 2.0]})
    ranks = aligned_ranks(data, "y", ["a", "b"])
    assert ranks["a"].tolist() == [1.5, 1.5, 3.5, 3.5]


def test_an_unknown_term_is_refused():
    with pytest.raises(ValueError, match="term must be"):
        art_contrasts(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject", "Time:Group")
