"""Monte Carlo power agrees with exact power, and each data set depends only on the seed, n and its index."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from microg.power import (
    exact_power,
    montecarlo_batch,
    power_table,
    read_effects,
    simulate,
)


def test_monte_carlo_power_lies_within_its_99_percent_interval_of_the_exact_power(effects_file, design):
    effects = read_effects(effects_file, design)
    sizes, sims = (6, 12), 400
    simulations = pd.concat([montecarlo_batch(effects, n, range(sims), seed=11, alpha=0.05) for n in sizes])
    counted = power_table(simulations, 0.05, "montecarlo", confidence=0.99).set_index(["n_per_group", "term"])
    exact = exact_power(effects, sizes, 0.05).set_index(["n_per_group", "term"])
    assert set(counted.index) == set(exact.index)
    assert (counted["sims"] == sims).all()
    for key, row in counted.iterrows():
        assert row["ci_low"] <= exact.loc[key, "power"] <= row["ci_high"], (key, row["power"], exact.loc[key, "power"])


def test_the_interval_is_clopper_pearson():
    p = [0.01] * 7 + [0.5] * 13 + [0.04] * 5
    simulations = pd.DataFrame({"n_per_group": 5, "sim": range(len(p)), "term": "group", "p": p})
    row = power_table(simulations, 0.05, "montecarlo").iloc[0]
    expected = stats.binomtest(12, 25).proportion_ci(0.95, method="exact")
    assert row["power"] == 12 / 25
    assert np.isclose(row["ci_low"], expected.low, atol=1e-12) and np.isclose(row["ci_high"], expected.high, atol=1e-12)
    never = power_table(simulations.assign(p=0.9), 0.05, "montecarlo").iloc[0]
    assert never["ci_low"] == 0 and np.isclose(never["ci_high"], 1 - 0.025 ** (1 / 25))


def test_a_missing_p_is_not_significant():
    simulations = pd.DataFrame({"n_per_group": 5, "sim": range(4), "term": "group", "p": [0.01, np.nan, 0.01, 0.3]})
    assert power_table(simulations, 0.05, "montecarlo").iloc[0]["power"] == 0.5


def test_a_data_set_is_the_same_whichever_batch_draws_it(effects_file, design):
    effects = read_effects(effects_file, design)
    whole = simulate(effects, 7, range(10), seed=3)
    assert np.array_equal(simulate(effects, 7, [6, 2], seed=3), whole[[6, 2]])
    assert not np.array_equal(simulate(effects, 7, [2], seed=4)[0], whole[2])
    assert not np.array_equal(simulate(effects, 8, [2], seed=3)[0, :14], whole[2])


def test_unequal_groups_in_monte_carlo_agree_with_exact_power(effects_file, design):
    """Under compound symmetry the uncorrected test's exact power is its true power: the Monte Carlo
    power of groups of 9 and 5 lies within its 99 % interval for every test."""
    effects = read_effects(effects_file, design)
    sims = 600
    rows = montecarlo_batch(effects, (9, 5), range(sims), seed=4, alpha=0.05, correction="none")
    assert set(rows["n_per_group"]) == {"veteran=9,beginner=5"}
    counted = power_table(rows, 0.05, "montecarlo", confidence=0.99).set_index("term")
    exact = exact_power(effects, [(9, 5)], 0.05).set_index("term")
    for term, row in counted.iterrows():
        assert row["ci_low"] <= exact.loc[term, "power"] <= row["ci_high"], (term, row["power"], exact.loc[term, "power"])


def test_equal_groups_draw_the_same_data_sets_however_they_are_named(effects_file, design):
    effects = read_effects(effects_file, design)
    assert np.array_equal(simulate(effects, 6, [3], seed=2), simulate(effects, (6, 6), [3], seed=2))
    assert simulate(effects, (7, 4), [0], seed=2).shape == (1, 11, 3)
