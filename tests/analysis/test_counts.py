"""The count model (Poisson GEE, exchangeable correlation within participant) against R's geepack
(tests/analysis/r/expected/study/count_model_*.csv, reproduce.sh), and how sparse counts are handled."""

from __future__ import annotations

import pandas as pd
import pytest

from microg.analysis import count_model
from tests.analysis.r_compare import (
    R_COUNT_NUMBERS,
    STUDY,
    TRIALS_CSV,
    assert_same_numbers,
)


@pytest.mark.parametrize("interaction", ["impulse_penetration", "soft_hand"])
def test_wald_tests_match_geepack(interaction):
    trials = pd.read_csv(TRIALS_CSV)
    tasks = trials[(trials["phase"] != "training") & (trials["interaction"] == interaction)]
    table = count_model(tasks, "attempts", "object", "group", "participant")
    expected = pd.read_csv(STUDY / f"count_model_attempts_{interaction}.csv")
    assert_same_numbers(table, expected, ["term"], R_COUNT_NUMBERS)
    assert (table["model"] == "main effects and interaction").all()


def _tasks(drops_v: list[int], drops_b: list[int]) -> pd.DataFrame:
    """Four participants per group, each with a cube and a ball task; the drops in that order."""
    rows = []
    for group, drops in (("V", drops_v), ("B", drops_b)):
        for index, (cube, ball) in enumerate(zip(drops[::2], drops[1::2])):
            rows += [(f"{group}{index}", group, "cube", cube), (f"{group}{index}", group, "ball", ball)]
    return pd.DataFrame(rows, columns=["p", "g", "o", "drops"])


def test_no_events_at_all_is_said_not_modelled():
    table = count_model(_tasks([0] * 8, [0] * 8), "drops", "o", "g", "p")
    assert table["chi2"].isna().all() and (table["model"] == "none").all()
    assert table["note"].iloc[0] == "no events: every drops is 0, nothing to model"
    assert table["share_zero"].iloc[0] == 1.0


def test_a_group_without_events_is_not_estimable():
    table = count_model(_tasks([0] * 8, [1, 2, 0, 3, 1, 1, 2, 0]), "drops", "o", "g", "p")
    assert table["chi2"].isna().all()
    assert "no drops at all in g V" in table["note"].iloc[0]


def test_an_empty_cell_leaves_the_main_effects():
    # V never drops the ball (every second value), but drops the cube; B drops both
    table = count_model(_tasks([1, 0, 2, 0, 1, 0, 3, 0], [1, 2, 0, 3, 1, 1, 2, 1]), "drops", "o", "g", "p")
    assert (table["model"] == "main effects only").all()
    assert table["chi2"].iloc[:2].notna().all() and pd.isna(table["chi2"].iloc[2])
    assert "the interaction is not estimable (no drops in V x ball)" in table["note"].iloc[0]
