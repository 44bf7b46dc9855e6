"""Exact power, the ANOVA_exact way: one data set whose cell means, SDs and correlations are
exactly the expected ones, analysed by the report's own ANOVA and post hoc tests.

On that data set each test's statistic is its noncentrality: lambda = F x df1 for an ANOVA term,
delta = T for a contrast. Power is the chance that the noncentral F (or t) exceeds the critical
value at alpha (alpha / family size for the Bonferroni post hoc). Sphericity is assumed: the
uncorrected degrees of freedom are used whatever the covariance. With n - 1 < levels the sample
covariance cannot equal a full-rank one; the data set is then built at n = levels + 1 and lambda
scaled by n / (levels + 1) (delta by its square root): in a balanced design the noncentrality
grows in proportion to n.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats
from scipy.linalg import null_space

from microg.power.effects import Effects

EXACT_COLUMNS = ("n_per_group", "term", "power", "ci_low", "ci_high", "method", "noncentrality", "df1", "df2")


def exact_dataset(effects: Effects, n_per_group: int) -> pd.DataFrame:
    """A long data set with ``n_per_group`` participants per group whose cell means and within-group
    covariances (n - 1 denominator) equal the effects' exactly; needs n - 1 >= levels.

    Each group's values are mean + sqrt(n - 1) Q L': Q holds k orthonormal columns that each sum to
    0 and L L' is the covariance, so the column means are the means and the sample covariance is
    L Q'Q L' = the covariance.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> from microg.power import design_from_protocol, effects_from_means
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> means = pd.DataFrame({"group": ["veteran"] * 3 + ["beginner"] * 3, "object": list(design.levels) * 2,
    ...                       "mean": [45.0, 55, 55, 55, 70, 70]})
    >>> data = exact_dataset(effects_from_means(means, design, sd=20.0, correlation=0.5), 8)
    >>> data.groupby(["group", "object"], sort=False)["value"].agg(["mean", "std"]).round(6).head(3)
                              mean   std
    group   object
    veteran cube              45.0  20.0
            flat_cuboid       55.0  20.0
            long_cuboid       55.0  20.0
    """
    d = effects.design
    k = len(d.levels)
    if n_per_group - 1 < k:
        raise ValueError(f"an exact data set of {k} levels needs n_per_group >= {k + 1}, not {n_per_group}")
    basis = null_space(np.ones((1, n_per_group)))[:, :k]
    rows = []
    for i, group in enumerate(d.groups):
        values = effects.means[i] + np.sqrt(n_per_group - 1) * basis @ np.linalg.cholesky(effects.covariances[i]).T
        for p in range(n_per_group):
            rows += [(f"{group}{p + 1}", group, level, values[p, j]) for j, level in enumerate(d.levels)]
    return pd.DataFrame(rows, columns=["participant", d.between, d.within, "value"])


def exact_power(effects: Effects, n_per_group, alpha: float = 0.05) -> pd.DataFrame:
    """Power of every ANOVA term and post hoc contrast of the report, for each group size.

    Parameters
    ----------
    effects : Effects
        Expected means and covariances.
    n_per_group : int or sequence of int
        Participants per group.
    alpha : float
        Significance level (Bonferroni: alpha / family size for a contrast).

    Returns
    -------
    pandas.DataFrame
        EXACT_COLUMNS: one row per group size and test (``Design.tests`` order); ``ci_low`` and
        ``ci_high`` equal ``power`` (an exact computation has no simulation error); the
        noncentrality (lambda, or delta for a contrast) and the degrees of freedom.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> from microg.power import design_from_protocol, effects_from_means
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> means = pd.DataFrame({"group": ["veteran"] * 3 + ["beginner"] * 3, "object": list(design.levels) * 2,
    ...                       "mean": [45.0, 55, 55, 55, 70, 70]})
    >>> table = exact_power(effects_from_means(means, design, sd=20.0, correlation=0.5), [10, 20])
    >>> table.loc[table["term"].isin(design.terms), ["n_per_group", "term", "power", "noncentrality"]].round(4)
        n_per_group          term   power  noncentrality
    0            10         group  0.4085         3.3333
    1            10        object  0.7973        10.4167
    2            10  group:object  0.0800         0.4167
    15           20         group  0.7110         6.6667
    16           20        object  0.9853        20.8333
    17           20  group:object  0.1152         0.8333
    """
    from microg.analysis import mixed_anova, posthoc

    d = effects.design
    g, k = len(d.groups), len(d.levels)
    sizes = [n_per_group] if np.isscalar(n_per_group) else list(n_per_group)
    contrasts = d.contrasts
    family_size = {c.family: sum(o.family == c.family for o in contrasts) for c in contrasts}
    tables = []
    for n in sizes:
        d.check_sample(n)
        built = max(n, k + 1)
        data = exact_dataset(effects, built)
        scale = n / built
        anova = mixed_anova(data, "value", d.within, d.between, "participant")
        lam = anova["F"].to_numpy() * anova["df1"].to_numpy() * scale
        df1 = anova["df1"].to_numpy(float)
        df2 = np.array([g * (n - 1), (k - 1) * g * (n - 1), (k - 1) * g * (n - 1)], dtype=float)
        term_power = [_f_power(*args, alpha) for args in zip(lam, df1, df2)]
        post = posthoc(data, "value", d.within, d.between, "participant", within_by_group=True)
        delta = {_pair_key(r.factor, r.at, r.A, r.B): (r.A, r.T * np.sqrt(scale)) for r in post.itertuples(index=False)}
        rows = [(n, term, power, lam_i, df1_i, df2_i)
                for term, power, lam_i, df1_i, df2_i in zip(d.terms, term_power, lam, df1, df2)]
        for c in contrasts:
            first, ncp = delta[(c.factor, c.at, frozenset(c.pair))]
            ncp = ncp if first == c.pair[0] else -ncp  # the sign of the contrast as named
            rows.append((n, c.name, _t_power(ncp, g * (n - 1), alpha / family_size[c.family]), ncp, 1.0,
                         float(g * (n - 1))))
        table = pd.DataFrame(rows, columns=["n_per_group", "term", "power", "noncentrality", "df1", "df2"])
        tables.append(table.assign(ci_low=table["power"], ci_high=table["power"], method="exact"))
    return pd.concat(tables, ignore_index=True)[list(EXACT_COLUMNS)]


def _f_power(lam: float, df1: float, df2: float, alpha: float) -> float:
    """P(F' > F_crit) for the noncentral F with noncentrality ``lam``."""
    critical = stats.f.isf(alpha, df1, df2)
    return float(stats.ncf.sf(critical, df1, df2, lam)) if lam > 0 else alpha


def _t_power(delta: float, df: float, alpha: float) -> float:
    """P(|T'| > t_crit) for the two-sided t test, T' noncentral t with noncentrality ``delta``."""
    critical = stats.t.isf(alpha / 2, df)
    return float(stats.nct.sf(critical, df, delta) + stats.nct.cdf(-critical, df, delta))


def _pair_key(factor, at, a, b) -> tuple:
    """A post hoc row's identity whatever the order of its pair (power does not depend on the sign)."""
    return factor, (None if pd.isna(at) else at), frozenset((a, b))
