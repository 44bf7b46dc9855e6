"""The vectorised tests give the report's numbers: microg.analysis' mixed_anova, sphericity_correction
and posthoc run one data set at a time, compared to 1e-9."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import warnings

import numpy as np
import pandas as pd
import pytest

import microg.analysis.anova
import microg.power
from microg.analysis import mixed_anova, posthoc, sphericity_correction
from microg.power import effects_from_means, mixed_anova_many, posthoc_many, simulate
from microg.power.batch import ROUND_OFF
from microg.power.montecarlo import analyse_batch

ANOVA_NUMBERS = ["SS", "SS_error", "df1", "df2", "F", "p_unc", "eps_GG", "p_GG", "W_mauchly", "p_mauchly"]
POSTHOC_NUMBERS = ["estimate", "SE", "df", "T", "p_unc", "p_bonf"]


def draws(seed: int, count: int, sizes, covariance, means=None) -> pd.DataFrame:
    """``count`` long data sets, groups of ``sizes``, values normal with ``covariance`` (numpy only)."""
    rng = np.random.default_rng(seed)
    covariance = np.asarray(covariance, float)
    k = len(covariance)
    means = np.zeros((len(sizes), k)) if means is None else np.asarray(means, float)
    rows = []
    for s in range(count):
        number = 0
        for g, size in enumerate(sizes):
            values = rng.multivariate_normal(means[g], covariance, size=size)
            for person in values:
                number += 1
                rows += [(s, f"s{number:02d}", f"g{g}", f"L{j}", v) for j, v in enumerate(person)]
    return pd.DataFrame(rows, columns=["set", "subject", "group", "level", "y"])


CASES = {
    "compound symmetry, 2 x 3, n = 6": {"sizes": (6, 6), "covariance": [[4, 2, 2], [2, 4, 2], [2, 2, 4]],
                                        "means": [[0, 1, 2], [1, 1, 3]]},
    "sphericity violated, 2 x 3, n = 10": {"sizes": (10, 10), "covariance": np.diag([1.0, 30.0, 400.0]) + 0.5},
    "too few to estimate sphericity, n = 2": {"sizes": (2, 2), "covariance": np.eye(3) + 0.3},
    "unequal groups 5 and 8": {"sizes": (5, 8), "covariance": [[2, 1, 0], [1, 3, 1], [0, 1, 5]],
                               "means": [[0, 0, 1], [2, 0, 1]]},
    "two levels": {"sizes": (7, 7), "covariance": [[2, 1], [1, 2]], "means": [[0, 1], [1, 1]]},
    "3 groups x 4 levels": {"sizes": (5, 5, 5), "covariance": np.eye(4) * 3 + 1,
                            "means": np.arange(12).reshape(3, 4) / 4},
}  # fmt: skip


@pytest.mark.parametrize("case", list(CASES))
def test_mixed_anova_many_equals_the_report_one_data_set_at_a_time(case):
    data = draws(sum(map(ord, case)), 5, **CASES[case])
    many = mixed_anova_many(data, "y", "level", "group", "subject", "set")
    for s, one in data.groupby("set"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            report = mixed_anova(one, "y", "level", "group", "subject")
        corrected = sphericity_correction(report)
        mine = many[many["dataset"] == s].reset_index(drop=True)
        assert list(mine["source"]) == list(report["source"])
        for column in ANOVA_NUMBERS:
            assert np.allclose(mine[column], report[column], rtol=1e-9, atol=1e-9, equal_nan=True), (case, s, column)
        assert np.allclose(mine["p"], corrected["p"], rtol=1e-9, atol=1e-9)
        assert list(mine["correction"]) == list(corrected["correction"])


def test_the_violated_case_does_apply_greenhouse_geisser():
    data = draws(1, 8, **CASES["sphericity violated, 2 x 3, n = 10"])
    many = mixed_anova_many(data, "y", "level", "group", "subject", "set")
    assert (many["correction"] == "Greenhouse-Geisser").sum() >= 2


@pytest.mark.parametrize("case", list(CASES))
def test_posthoc_many_equals_the_report_one_data_set_at_a_time(case):
    data = draws(sum(map(ord, case)) + 1, 4, **CASES[case])
    many = posthoc_many(data, "y", "level", "group", "subject", "set")
    for s, one in data.groupby("set"):
        report = posthoc(one, "y", "level", "group", "subject", within_by_group=True)
        mine = many[many["dataset"] == s].reset_index(drop=True)
        assert len(mine) == len(report)
        for column in ("factor", "A", "B"):
            assert list(mine[column]) == list(report[column])
        assert list(mine["at"].fillna("-")) == list(report["at"].fillna("-"))
        for column in POSTHOC_NUMBERS:
            assert np.allclose(mine[column], report[column], rtol=1e-9, atol=1e-9), (case, s, column)


def test_the_monte_carlo_engine_reads_the_report_p_of_every_test(design):
    """What a Dask task computes for each simulated data set equals the report's own analysis of it."""
    means = pd.DataFrame({"group": np.repeat(design.groups, 3), "object": list(design.levels) * 2,
                          "mean": [45.0, 55, 55, 55, 70, 70]})  # fmt: skip
    effects = effects_from_means(means, design, sd=20.0, correlation=0.5)
    n, indices = 6, [0, 3, 11]
    y = simulate(effects, n, indices, seed=4)
    engine = analyse_batch(effects, y, n, indices, alpha=0.05)
    for s, index in enumerate(indices):
        data = pd.DataFrame([(f"p{i}", design.groups[i // n], level, y[s, i, j])
                             for i in range(2 * n) for j, level in enumerate(design.levels)],
                            columns=["participant", "group", "object", "value"])  # fmt: skip
        anova = sphericity_correction(mixed_anova(data, "value", "object", "group", "participant"))
        post = posthoc(data, "value", "object", "group", "participant", within_by_group=True)
        found = {(r.factor, None if pd.isna(r.at) else r.at, frozenset((r.A, r.B))): r.p_bonf
                 for r in post.itertuples(index=False)}  # fmt: skip
        expected = list(anova["p"]) + [found[(c.factor, c.at, frozenset(c.pair))] for c in design.contrasts]
        mine = engine[engine["sim"] == index]
        assert list(mine["term"]) == list(design.tests)
        assert np.allclose(mine["p"], expected, rtol=1e-9, atol=1e-9)


def test_round_off_is_the_reports():
    assert ROUND_OFF == microg.analysis.anova.ROUND_OFF


MODULES = [importlib.import_module(f"microg.power.{info.name}") for info in pkgutil.iter_modules(microg.power.__path__)]


@pytest.mark.parametrize("module", MODULES, ids=lambda module: module.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS, verbose=False)
    assert result.failed == 0
