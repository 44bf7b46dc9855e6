"""Monte Carlo power: simulated data sets from the effects, each analysed as the report analyses a
study, counted.

Data set ``i`` at ``n`` participants per group is drawn from its own random generator, seeded by
``numpy.random.SeedSequence(seed, spawn_key=(n, i))`` (``(n_1, ..., n_g, i)`` for unequal groups):
it is the same data set whichever batch, worker or run computes it, so the numbers do not depend on
how the work is split. A batch of data sets is analysed at once by :mod:`microg.power.batch` (the
report's ANOVA, the sphericity correction asked for, Bonferroni post hoc); a test counts as
significant when the p read is below alpha.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from microg.power.batch import anova_arrays, contrast_arrays
from microg.power.effects import Effects

SIMULATION_COLUMNS = ("n_per_group", "sim", "term", "p")
"""One row per simulated data set (``sim``) and test: the p the report reads."""
CONFIDENCE = 0.95


def simulation_seed(seed: int, n_per_group, index: int) -> np.random.SeedSequence:
    """The seed of data set ``index`` at ``n_per_group`` (a size, or one size per group): a function
    of the run's seed and these only."""
    sizes = tuple(n_per_group) if isinstance(n_per_group, (tuple, list)) else (n_per_group,)
    key = sizes[:1] if len(set(sizes)) == 1 else sizes
    return np.random.SeedSequence(seed, spawn_key=(*map(int, key), index))


def simulate(effects: Effects, n_per_group, indices, seed: int) -> np.ndarray:
    """The data sets ``indices`` at ``n_per_group`` (a size, or one size per group): (data sets,
    subjects ordered by group, levels), multivariate normal with the effects' means and covariances."""
    means, factors = effects.means, np.linalg.cholesky(effects.covariances)
    sizes = effects.design.group_sizes(n_per_group)
    member = np.repeat(np.arange(len(sizes)), sizes)
    generators = (np.random.default_rng(simulation_seed(seed, n_per_group, int(i))) for i in indices)
    draws = np.stack([rng.standard_normal((sum(sizes), means.shape[1])) for rng in generators])
    return means[member][None] + np.einsum("nkl,snl->snk", factors[member], draws)


def montecarlo_batch(effects: Effects, n_per_group, indices, seed: int, alpha: float,
                     correction: str = "mauchly") -> pd.DataFrame:
    """Simulate and analyse data sets ``indices`` at ``n_per_group``: one Dask task.

    Returns
    -------
    pandas.DataFrame
        SIMULATION_COLUMNS: for each data set and test (the ANOVA terms, then the contrasts, as
        ``Design.tests``), the p read (``correction``: by default the report's, Greenhouse-Geisser
        when Mauchly's p < alpha; Bonferroni within each post hoc family).
    """
    indices = np.asarray(indices, dtype=int)
    y = simulate(effects, n_per_group, indices, seed)
    return analyse_batch(effects, y, n_per_group, indices, alpha, correction)


def analyse_batch(effects: Effects, y: np.ndarray, n_per_group, indices, alpha: float,
                  correction: str = "mauchly") -> pd.DataFrame:
    """The p of every test of ``Design.tests`` for data sets ``y`` (data sets, subjects, levels)."""
    design = effects.design
    sizes = design.group_sizes(n_per_group)
    contrasts = design.contrasts
    families = [c.family for c in contrasts]
    anova = anova_arrays(y, sizes, alpha, correction)["p"]
    post = contrast_arrays(y, sizes, np.array([c.levels for c in contrasts]).T,
                           np.array([c.groups for c in contrasts]).T, np.array(families))["p_bonf"]
    p = np.hstack([anova, post])
    tests = design.tests
    return pd.DataFrame({
        "n_per_group": design.sample_key(n_per_group),
        "sim": np.repeat(indices, len(tests)),
        "term": np.tile(tests, len(indices)),
        "p": p.reshape(-1),
    })


def power_table(simulations: pd.DataFrame, alpha: float, method: str, confidence: float = CONFIDENCE) -> pd.DataFrame:
    """Power per sample size and test from simulated p values, with a Clopper-Pearson interval.

    Parameters
    ----------
    simulations : pandas.DataFrame
        SIMULATION_COLUMNS (a missing p, a data set the report could not analyse, is not significant).
    alpha : float
        A test is significant when p < alpha.
    method : str
        Written to the ``method`` column.
    confidence : float
        Level of the exact binomial interval.

    Returns
    -------
    pandas.DataFrame
        Columns n_per_group, term, power, ci_low, ci_high, method, sims; tests in the order they
        first appear.

    Examples
    --------
    >>> import pandas as pd
    >>> sims = pd.DataFrame({"n_per_group": 10, "sim": range(4), "term": "group", "p": [0.01, 0.2, 0.03, 0.5]})
    >>> power_table(sims, 0.05, "montecarlo")[["term", "power", "sims"]]
        term  power  sims
    0  group    0.5     4
    """
    significant = simulations.assign(hit=simulations["p"] < alpha)
    counted = significant.groupby(["n_per_group", "term"], sort=False)["hit"].agg(["sum", "size"]).reset_index()
    hits, total = counted["sum"].to_numpy(), counted["size"].to_numpy()
    tail = (1 - confidence) / 2
    low = np.where(hits > 0, stats.beta.ppf(tail, hits, total - hits + 1), 0.0)
    high = np.where(hits < total, stats.beta.ppf(1 - tail, hits + 1, total - hits), 1.0)
    table = pd.DataFrame({"n_per_group": counted["n_per_group"], "term": counted["term"], "power": hits / total,
                          "ci_low": low, "ci_high": high, "method": method, "sims": total})
    return table.sort_values("n_per_group", kind="stable").reset_index(drop=True)
