"""Exact power, the ANOVA_exact way: one data set whose cell means, SDs and correlations are
exactly the expected ones, analysed by the report's own ANOVA and post hoc tests.

On that data set each test's statistic is its noncentrality: lambda = F x df1 for an ANOVA term,
delta = T for a contrast. Power is the chance that the noncentral F (or t) exceeds the critical
value at alpha (alpha / family size for the Bonferroni post hoc). With n - 1 < levels in a group
the sample covariance cannot equal a full-rank one; the data set is then built with every group m
times as large (m the smallest whole number that makes it possible) and lambda divided by m (delta
by its square root): lambda grows in proportion to the group sizes when they all grow alike.

Sphericity: by default the uncorrected degrees of freedom are used whatever the covariance
(``correction="none"``). With ``"GG"`` or ``"HF"`` a within effect is tested as Superpower's
``ANOVA_exact(correction = ...)`` tests it: df1, df2 and lambda all multiplied by the epsilon of the
pooled covariance (Greenhouse-Geisser's, or Huynh-Feldt's capped at 1), which is what the corrected
F test of the exact data set reads.

Effect sizes follow Superpower's convention (its default, ``liberal_lambda = FALSE``): partial eta
squared is that of the exact data set at the planned n, np2 = lambda / (lambda + df2), Cohen's
f = sqrt(np2 / (1 - np2)) = sqrt(lambda / df2), so lambda = f^2 df2 with df2 the error df (for a
contrast, t^2 = f^2 df, as Superpower's ``emmeans_power``). Other programs put f^2 (df1 + df2 + 1)
(Superpower's ``liberal_lambda``, R's pwr.f2.test) or f^2 N (G*Power's F tests; its repeated-measures
procedures define f on the raw means, with the correlation apart): the same lambda is reached with
f'^2 = lambda / (df1 + df2 + 1) or lambda / N. The tables list lambda, so any convention converts.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import optimize, stats
from scipy.linalg import null_space

from microg.power.design import Design, PowerInputError
from microg.power.effects import Effects

EXACT_COLUMNS = ("n_per_group", "term", "power", "ci_low", "ci_high", "method", "noncentrality", "df1", "df2",
                 "np2", "cohen_f", "epsilon")  # fmt: skip
SENSITIVITY_COLUMNS = ("n_per_group", "term", "scale", "np2", "cohen_f", "noncentrality", "df1", "df2", "epsilon",
                       "power")  # fmt: skip
EXACT_CORRECTIONS = ("none", "GG", "HF")
EFFECT_SIZE_KINDS = ("f", "np2")
NO_EFFECT = 1e-12
"""A noncentrality (lambda, or delta squared) below this is the rounding noise of an effect the pattern
does not have (its exact t or F is about 1e-15): no scaling of the pattern reaches any power with it."""


def exact_dataset(effects: Effects, n_per_group) -> pd.DataFrame:
    """A long data set with ``n_per_group`` participants per group (one number, or one per group)
    whose cell means and within-group covariances (n - 1 denominator) equal the effects' exactly;
    needs n - 1 >= levels in every group.

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
    veteran cube         45.0  20.0
            flat_cuboid  55.0  20.0
            long_cuboid  55.0  20.0
    """
    d = effects.design
    k = len(d.levels)
    rows = []
    for i, (group, size) in enumerate(zip(d.groups, d.group_sizes(n_per_group))):
        if size - 1 < k:
            raise ValueError(f"an exact data set of {k} levels needs groups of at least {k + 1}, not {size}")
        basis = null_space(np.ones((1, size)))[:, :k]
        values = effects.means[i] + np.sqrt(size - 1) * basis @ np.linalg.cholesky(effects.covariances[i]).T
        for p in range(size):
            rows += [(f"{group}{p + 1}", group, level, values[p, j]) for j, level in enumerate(d.levels)]
    return pd.DataFrame(rows, columns=["participant", d.between, d.within, "value"])


def exact_power(effects: Effects, n_per_group, alpha: float = 0.05, correction: str = "none") -> pd.DataFrame:
    """Power of every ANOVA term and post hoc contrast of the report, for each sample.

    Parameters
    ----------
    effects : Effects
        Expected means and covariances.
    n_per_group : int, dict, or a sequence of samples
        Participants per group: one number (every group) or a mapping group -> size, or a sequence of
        samples, each a number, a mapping or a tuple of one size per group (the design's order).
    alpha : float
        Significance level (Bonferroni: alpha / family size for a contrast).
    correction : {"none", "GG", "HF"}
        Sphericity correction of the within effects (see the module docstring).

    Returns
    -------
    pandas.DataFrame
        EXACT_COLUMNS: one row per sample and test (``Design.tests`` order; ``n_per_group`` is
        ``Design.sample_key``); ``ci_low`` and ``ci_high`` equal ``power`` (an exact computation has
        no simulation error); the noncentrality (lambda, or delta for a contrast), the uncorrected
        degrees of freedom, the effect size (np2, cohen_f: Superpower's convention) and the epsilon
        applied (1 when none).

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
    _check_correction(correction)
    d = effects.design
    tables = []
    for sample in _samples(d, n_per_group):
        tests = noncentralities(effects, sample, alpha)
        epsilon = tests[f"eps_{correction}"] if correction != "none" else pd.Series(1.0, index=tests.index)
        power = [_power(row.noncentrality, row.df1, row.df2, row.alpha, eps, row.contrast)
                 for row, eps in zip(tests.itertuples(), epsilon)]  # fmt: skip
        table = _sized(tests.assign(power=power, epsilon=epsilon), d, sample)
        tables.append(table.assign(ci_low=table["power"], ci_high=table["power"], method="exact"))
    return pd.concat(tables, ignore_index=True)[list(EXACT_COLUMNS)]


def sensitivity(design: Design, n_per_group, alpha: float = 0.05, target: float = 0.8,
                effects: Effects | None = None, correction: str = "none") -> pd.DataFrame:
    """The smallest effect each test detects with power ``target`` at each sample (sensitivity).

    Parameters
    ----------
    design : Design
        The design.
    n_per_group : int, dict, or a sequence of samples
        As for :func:`exact_power`.
    alpha, target : float
        Significance level (alpha / family size for a contrast) and the power to reach.
    effects : Effects, optional
        The expected pattern of means and covariances: gives ``scale``, the factor by which every
        mean's deviation from the grand mean must be multiplied for the test to reach the target
        (1: the pattern as given; inf: the pattern has no such effect, its noncentrality below
        NO_EFFECT), and the epsilon a correction
        needs. Without it only the effect sizes are given (sphericity assumed).
    correction : {"none", "GG", "HF"}
        Sphericity correction of the within effects (needs ``effects``).

    Returns
    -------
    pandas.DataFrame
        SENSITIVITY_COLUMNS: per sample and test, the scale, the smallest partial eta squared and
        Cohen's f (Superpower's convention: lambda = f^2 df2), the noncentrality lambda (delta^2 for a
        contrast), the uncorrected df, the epsilon applied, and the power reached (the target).

    Examples
    --------
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> from microg.power import design_from_protocol
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> table = sensitivity(design, 15)
    >>> table.loc[:2, ["term", "np2", "cohen_f", "noncentrality", "df2"]].round(4)
               term     np2  cohen_f  noncentrality   df2
    0         group  0.2313   0.5485         8.4238  28.0
    1        object  0.1537   0.4261        10.1692  56.0
    2  group:object  0.1537   0.4261        10.1692  56.0
    """
    _check_correction(correction)
    if correction != "none" and effects is None:
        raise PowerInputError(f"--correction {correction}: a sphericity correction needs the covariance of --effects")
    rows = []
    for sample in _samples(design, n_per_group):
        tests = noncentralities(effects, sample, alpha) if effects is not None else _degrees(design, sample, alpha)
        epsilon = tests[f"eps_{correction}"] if correction != "none" else pd.Series(1.0, index=tests.index)
        for row, eps in zip(tests.itertuples(), epsilon):
            needed = _needed(row.df1, row.df2, row.alpha, eps, row.contrast, target)
            given = row.noncentrality**2 if row.contrast else row.noncentrality
            scale = np.sqrt(needed / given) if given > NO_EFFECT else np.inf
            reached = _power(np.sqrt(needed) if row.contrast else needed, row.df1, row.df2, row.alpha, eps,
                             row.contrast)  # fmt: skip
            rows.append((row.term, scale if effects is not None else np.nan, needed, row.df1, row.df2, eps, reached))
    table = pd.DataFrame(rows, columns=["term", "scale", "noncentrality", "df1", "df2", "epsilon", "power"])
    table.insert(0, "n_per_group", np.repeat([design.sample_key(s) for s in _samples(design, n_per_group)],
                                             len(design.tests)))  # fmt: skip
    table["np2"] = table["noncentrality"] / (table["noncentrality"] + table["df2"])
    table["cohen_f"] = np.sqrt(table["noncentrality"] / table["df2"])
    return table[list(SENSITIVITY_COLUMNS)]


def effect_size_power(design: Design, effect_sizes: dict, n_per_group, alpha: float = 0.05) -> pd.DataFrame:
    """Power of tests whose effect is given as Cohen's f or partial eta squared (Superpower's
    convention: lambda = f^2 df2 at each sample, f^2 = np2 / (1 - np2); sphericity assumed).

    Parameters
    ----------
    design : Design
        The design.
    effect_sizes : dict
        Test (a name of ``Design.tests``) -> (``"f"`` or ``"np2"``, value).
    n_per_group : int, dict, or a sequence of samples
        As for :func:`exact_power`.
    alpha : float
        Significance level (alpha / family size for a contrast).

    Returns
    -------
    pandas.DataFrame
        EXACT_COLUMNS for the tests named, in ``Design.tests`` order.

    Examples
    --------
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> from microg.power import design_from_protocol
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> table = effect_size_power(design, {"object": ("f", 0.25), "group": ("np2", 0.06)}, [15, 30])
    >>> table[["n_per_group", "term", "power", "noncentrality", "df2"]].round(4)
       n_per_group    term   power  noncentrality    df2
    0           15   group  0.2524         1.7872   28.0
    1           15  object  0.3518         3.5000   56.0
    2           30   group  0.4730         3.7021   58.0
    3           30  object  0.6597         7.2500  116.0
    """
    unknown = [test for test in effect_sizes if test not in design.tests]
    if unknown:
        raise PowerInputError(f"--effect-size {unknown[0]!r}: no such test (tests: {', '.join(design.tests)})")
    tables = []
    for sample in _samples(design, n_per_group):
        tests = _degrees(design, sample, alpha)
        tests = tests[tests["term"].isin(effect_sizes)]
        f_squared = np.array([_f_squared(*effect_sizes[term], term) for term in tests["term"]])
        lam = f_squared * tests["df2"].to_numpy()
        ncp = np.where(tests["contrast"], np.sqrt(lam), lam)
        power = [_power(value, row.df1, row.df2, row.alpha, 1.0, row.contrast)
                 for value, row in zip(ncp, tests.itertuples())]  # fmt: skip
        table = _sized(tests.assign(noncentrality=ncp, power=power, epsilon=1.0), design, sample)
        tables.append(table.assign(ci_low=table["power"], ci_high=table["power"], method="exact"))
    return pd.concat(tables, ignore_index=True)[list(EXACT_COLUMNS)]


def noncentralities(effects: Effects, sample, alpha: float = 0.05) -> pd.DataFrame:
    """Each test's noncentrality at one sample, from the exact data set analysed by the report's
    mixed ANOVA and post hoc tests (lambda for a term, delta for a contrast, signed as named); with
    the uncorrected df, the test's alpha (alpha / family size for a contrast) and the epsilons of the
    pooled covariance (``eps_GG``; ``eps_HF`` capped at 1; 1 for the between effect and the contrasts)."""
    from microg.analysis import mixed_anova, posthoc

    d = effects.design
    sizes = np.array(d.group_sizes(sample))
    k = len(d.levels)
    times = math.ceil((k + 1) / sizes.min()) if sizes.min() - 1 < k else 1
    data = exact_dataset(effects, tuple(int(size) for size in sizes * times))
    anova = mixed_anova(data, "value", d.within, d.between, "participant")
    post = posthoc(data, "value", d.within, d.between, "participant", within_by_group=True)
    delta = {(r.factor, None if pd.isna(r.at) else r.at, frozenset((r.A, r.B))): (r.A, r.T / np.sqrt(times))
             for r in post.itertuples(index=False)}  # fmt: skip
    contrasts = []
    for c in d.contrasts:
        first, value = delta[(c.factor, c.at, frozenset(c.pair))]
        contrasts.append(value if first == c.pair[0] else -value)  # the sign of the contrast as named
    tests = _degrees(d, sample, alpha)
    tests["noncentrality"] = np.concatenate([anova["F"].to_numpy() * anova["df1"].to_numpy() / times, contrasts])
    gg, hf = _epsilons(effects, sizes)
    within = np.isin(np.arange(len(tests)), [1, 2])
    tests["eps_GG"] = np.where(within, gg, 1.0)
    tests["eps_HF"] = np.where(within, hf, 1.0)
    return tests


def _degrees(design: Design, sample, alpha: float) -> pd.DataFrame:
    """Each test of ``design.tests`` at one sample: its df, its alpha, whether it is a contrast."""
    d = design
    g, k = len(d.groups), len(d.levels)
    error = float(sum(d.group_sizes(sample)) - g)
    family_size = {c.family: sum(o.family == c.family for o in d.contrasts) for c in d.contrasts}
    rows = [(d.terms[0], g - 1, error, alpha, False), (d.terms[1], k - 1, (k - 1) * error, alpha, False),
            (d.terms[2], (g - 1) * (k - 1), (k - 1) * error, alpha, False)]  # fmt: skip
    rows += [(c.name, 1, error, alpha / family_size[c.family], True) for c in d.contrasts]
    table = pd.DataFrame(rows, columns=["term", "df1", "df2", "alpha", "contrast"])
    return table.assign(df1=table["df1"].astype(float), eps_GG=1.0, eps_HF=1.0, noncentrality=np.nan)


def _epsilons(effects: Effects, sizes: np.ndarray) -> tuple[float, float]:
    """Greenhouse-Geisser's epsilon of the pooled covariance (weights n - 1, as the report's ANOVA
    pools) and Huynh-Feldt's from it by car's formula, capped at 1."""
    d = effects.design
    k, g = len(d.levels), len(d.groups)
    pooled = np.tensordot(sizes - 1, effects.covariances, axes=1) / (sizes.sum() - g)
    contrasts = null_space(np.ones((1, k))).T
    spread = contrasts @ pooled @ contrasts.T
    gg = float(np.trace(spread) ** 2 / ((k - 1) * np.trace(spread @ spread)))
    error = float(sizes.sum() - g)
    below = (k - 1) * (error - (k - 1) * gg)
    hf = ((error + 1) * (k - 1) * gg - 2) / below if below > 0 else np.inf  # so few that it exceeds 1
    return gg, float(min(1.0, hf))


def _power(noncentrality: float, df1: float, df2: float, alpha: float, epsilon: float, contrast: bool) -> float:
    """P(significant at ``alpha``): a term's F test (noncentral F) with df1, df2 and lambda multiplied by
    ``epsilon``; a contrast's two-sided t test with noncentrality delta, as the F test of t^2 with
    (1, df) and lambda = delta^2 (the same probability; scipy's noncentral t is NaN far in its tails)."""
    if contrast:
        df1, lam = 1.0, noncentrality**2
    else:
        df1, df2, lam = df1 * epsilon, df2 * epsilon, noncentrality * epsilon
    critical = stats.f.isf(alpha, df1, df2)
    return float(stats.ncf.sf(critical, df1, df2, lam)) if lam > 0 else alpha


def _needed(df1: float, df2: float, alpha: float, epsilon: float, contrast: bool, target: float) -> float:
    """The noncentrality lambda (delta^2 for a contrast) at which the test's power is ``target``; 0 when
    even no effect reaches it (target <= alpha)."""
    def shortfall(lam: float) -> float:
        return _power(np.sqrt(lam) if contrast else lam, df1, df2, alpha, epsilon, contrast) - target

    if shortfall(0.0) >= 0:
        return 0.0
    high = 1.0
    while shortfall(high) < 0:
        high *= 2
    return float(optimize.brentq(shortfall, 0.0, high, xtol=1e-12, rtol=1e-14))


def _samples(design: Design, n_per_group) -> list:
    samples = design.samples(n_per_group)
    for sample in samples:
        design.check_sample(sample)
    return samples


def _sized(tests: pd.DataFrame, design: Design, sample) -> pd.DataFrame:
    """The test rows keyed by the sample, with Superpower's effect sizes of their noncentrality."""
    lam = np.where(tests["contrast"], tests["noncentrality"] ** 2, tests["noncentrality"])
    np2 = lam / (lam + tests["df2"])
    return tests.assign(n_per_group=design.sample_key(sample), np2=np2, cohen_f=np.sqrt(lam / tests["df2"]))


def _f_squared(kind: str, value: float, test: str) -> float:
    if kind not in EFFECT_SIZE_KINDS:
        raise PowerInputError(f"--effect-size {test}:{kind}={value!r}: the effect size is f or np2")
    if kind == "f":
        if not (math.isfinite(value) and value >= 0):
            raise PowerInputError(f"--effect-size {test}:f={value!r}: Cohen's f must be 0 or more")
        return value**2
    if not 0 <= value < 1:
        raise PowerInputError(f"--effect-size {test}:np2={value!r}: partial eta squared must lie in [0, 1)")
    return value / (1 - value)


def _check_correction(correction: str) -> None:
    if correction not in EXACT_CORRECTIONS:
        raise PowerInputError(f"--correction {correction}: exact power reads {', '.join(EXACT_CORRECTIONS)} "
                              "(the report's Mauchly rule needs simulated data sets: --method montecarlo)")
