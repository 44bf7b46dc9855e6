"""Mixed ANOVA (one between factor x one within factor) with the numbers R's afex reports.

Sums of squares come from the multivariate linear model of the wide data (one column per within
level, between factor in sum-to-zero coding), as afex/car compute them: type 3 by default, type 2
on request; the two differ only for the within main effect and only when groups are unequal.
Mauchly's test and the Greenhouse-Geisser epsilon come from pingouin's mixed_anova, which uses the
pooled within-group covariance (as afex does), not from pingouin.sphericity, which ignores groups;
the Huynh-Feldt epsilon follows from it by car's formula.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import optimize, stats
from scipy.linalg import null_space

from microg.analysis.tables import AnalysisInputError, complete_cases, incomplete_cases

ANOVA_COLUMNS = (
    "source", "SS", "df1", "df2", "MS", "F", "p_unc", "np2",
    "eps_GG", "df1_GG", "df2_GG", "p_GG", "W_mauchly", "p_mauchly",
    "ges", "np2_ci_low", "np2_ci_high", "eps_HF", "df1_HF", "df2_HF", "p_HF", "SS_error",
)  # fmt: skip
CORRECTION_COLUMNS = ("source", "correction", "reason", "df1", "df2", "p", "epsilon")
SPHERICITY_ALPHA = 0.05
CONFIDENCE = 0.95
ROUND_OFF = 1e-12
"""A sum of squares below this share of the data's sum of squares is rounding noise: it is 0."""


def mixed_anova(data: pd.DataFrame, dv: str, within: str, between: str, subject: str, ss_type: int = 3) -> pd.DataFrame:
    """Mixed ANOVA of ``dv`` with one between and one within factor, as R's afex computes it.

    Parameters
    ----------
    data : pandas.DataFrame
        Long table: one row per subject and ``within`` level (several rows are averaged).
        Subjects missing a level are dropped with a warning that names them (complete cases, as
        afex).
    dv, within, between, subject : str
        Columns of the measure, the within factor, the between factor and the subject id.
    ss_type : {3, 2}
        Type of the sums of squares: 3 (afex's default; equal weight per group) or 2.

    Returns
    -------
    pandas.DataFrame
        One row per source (``between``, ``within``, ``between:within``); columns ANOVA_COLUMNS:
        SS, df1, df2, MS, F, p_unc; np2 (partial eta squared) and its 95 % CI from the noncentral F
        (np2_ci_low, np2_ci_high; as R's effectsize::F_to_eta2); ges (generalised eta squared,
        afex's default effect size); the Greenhouse-Geisser epsilon, df and p (eps_GG, df1_GG,
        df2_GG, p_GG); the Huynh-Feldt epsilon (uncapped, as car prints it) with df and p using
        min(1, epsilon) (eps_HF, df1_HF, df2_HF, p_HF); Mauchly's W and p; SS_error. Epsilons and
        Mauchly are filled for every within effect; whether to use them is
        :func:`sphericity_correction`'s call. With two within levels sphericity holds trivially
        (epsilon 1, no Mauchly test); with fewer error degrees of freedom than levels, or errors
        that do not vary, it cannot be estimated (NaN). An effect whose sum of squares is 0 has
        F = 0 and p = 1, as in R.

    Raises
    ------
    AnalysisInputError
        When fewer than two groups or levels, or too few subjects, are left.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import mixed_anova
    >>> data = pg.read_dataset("mixed_anova")
    >>> table = mixed_anova(data, dv="Scores", within="Time", between="Group", subject="Subject")
    >>> table[["source", "df1", "df2", "F", "p_unc", "ges"]].round(3)
           source  df1  df2      F  p_unc    ges
    0       Group    1   58  5.052  0.028  0.031
    1        Time    2  116  4.027  0.020  0.042
    2  Group:Time    2  116  2.728  0.070  0.029
    """
    if ss_type not in (2, 3):
        raise ValueError(f"ss_type must be 2 or 3, not {ss_type!r}")
    wide, groups = wide_complete(data, dv, within, between, subject)
    n, k = wide.shape
    levels = sorted(set(groups))
    if len(levels) < 2 or k < 2:
        raise AnalysisInputError(
            f"{n} complete {subject}s in {len(levels)} group(s) of column {between!r} with {k} level(s) of "
            f"column {within!r}: a mixed ANOVA needs at least two of each"
        )
    df_error = n - len(levels)
    if df_error < k - 1:
        raise AnalysisInputError(
            f"{n} complete {subject}s in {len(levels)} groups of column {between!r} leave {df_error} error "
            f"degrees of freedom; the {k} levels of column {within!r} need at least {k - 1}"
        )
    sums = _sums_of_squares(wide.to_numpy(float), groups, levels, ss_type)
    df_between, df_within = len(levels) - 1, k - 1
    table = pd.DataFrame(
        {
            "source": [between, within, f"{between}:{within}"],
            "SS": [sums[name][0] for name in ("between", "within", "interaction")],
            "SS_error": [sums[name][1] for name in ("between", "within", "interaction")],
            "df1": [df_between, df_within, df_between * df_within],
            "df2": [df_error, df_within * df_error, df_within * df_error],
        }
    )
    no_effect = table["SS"] == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        table["MS"] = table["SS"] / table["df1"]
        table["F"] = np.where(no_effect, 0.0, table["MS"] / (table["SS_error"] / table["df2"]))
        table["np2"] = np.where(no_effect, 0.0, table["SS"] / (table["SS"] + table["SS_error"]))
        errors = table["SS_error"].iloc[0] + table["SS_error"].iloc[1]
        table["ges"] = np.where(no_effect, 0.0, table["SS"] / (table["SS"] + errors))
    table["p_unc"] = stats.f.sf(table["F"], table["df1"], table["df2"])
    bounds = [partial_eta_squared_ci(*row) for row in table[["F", "df1", "df2"]].itertuples(index=False)]
    table["np2_ci_low"], table["np2_ci_high"] = np.array(bounds).T

    singular = np.linalg.matrix_rank(sums["within_errors"]) < k - 1
    if df_error < k or singular:
        eps, w_mauchly, p_mauchly = np.nan, np.nan, np.nan
    else:
        eps, w_mauchly, p_mauchly = _sphericity(wide, groups, dv, within, between, subject)
    repeated = np.array([False, True, True])
    table["eps_GG"] = np.where(repeated, eps, np.nan)
    table["eps_HF"] = np.where(repeated, _huynh_feldt(eps, df_error, df_within), np.nan)
    for name, epsilon in (("GG", table["eps_GG"]), ("HF", np.minimum(1.0, table["eps_HF"]))):
        table[f"df1_{name}"] = table["df1"] * epsilon
        table[f"df2_{name}"] = table["df2"] * epsilon
        table[f"p_{name}"] = stats.f.sf(table["F"], table[f"df1_{name}"], table[f"df2_{name}"])
    table["W_mauchly"] = np.where(repeated, w_mauchly, np.nan)
    table["p_mauchly"] = np.where(repeated, p_mauchly, np.nan)
    return table[list(ANOVA_COLUMNS)]


def partial_eta_squared_ci(F: float, df1: float, df2: float, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Confidence interval of partial eta squared by inverting the noncentral F distribution.

    Each bound is the noncentrality lambda whose F distribution puts the observed F at the
    (1 +- confidence) / 2 quantile, turned into lambda / (lambda + df2) (the point estimate's formula
    at lambda = F df1; R's effectsize::F_to_eta2); a bound below which no lambda reaches is 0.

    Parameters
    ----------
    F, df1, df2 : float
        The F statistic and its degrees of freedom.
    confidence : float
        Two-sided confidence level.

    Returns
    -------
    tuple of (float, float)
        The lower and upper bound.

    Examples
    --------
    >>> from microg.analysis.anova import partial_eta_squared_ci
    >>> [round(bound, 3) for bound in partial_eta_squared_ci(5.0517, 1, 58)]
    [0.0, 0.237]
    """
    if not np.isfinite(F):
        return (np.nan, np.nan) if np.isnan(F) else (1.0, 1.0)
    tail = (1 - confidence) / 2
    low, high = (noncentrality(lambda ncp: stats.ncf.cdf(F, df1, df2, ncp), p) for p in (1 - tail, tail))
    return low / (low + df2), high / (high + df2)


def noncentrality(cdf, probability: float, floor: float | None = 0.0) -> float:
    """The noncentrality at which ``cdf`` (of the observed statistic, falling as the noncentrality
    grows) equals ``probability``; ``floor`` when the root would lie below it (0 for F, None for t,
    whose noncentrality has no floor).

    Root-finding on scipy's distribution functions: scipy.special's ``ncfdtrinc`` and
    ``nctdtrinc`` are off by up to 1e-4 here.

    Examples
    --------
    >>> from scipy import stats
    >>> from microg.analysis.anova import noncentrality
    >>> round(noncentrality(lambda ncp: stats.ncf.cdf(19.69, 2, 26, ncp), 0.975), 6)
    12.458824
    """
    if floor is not None and cdf(floor) <= probability:
        return floor
    low, high = (-1.0 if floor is None else floor), 1.0
    while cdf(low) < probability:
        low *= 2
    while cdf(high) > probability:
        high *= 2
    return float(optimize.brentq(lambda ncp: cdf(ncp) - probability, low, high, xtol=1e-12, rtol=1e-14))


def sphericity_correction(anova: pd.DataFrame, alpha: float = SPHERICITY_ALPHA) -> pd.DataFrame:
    """Which p to read for each source of a :func:`mixed_anova` table, and why.

    Greenhouse-Geisser when Mauchly's test rejects sphericity at ``alpha``; the uncorrected p
    otherwise, and always for the between factor.

    Parameters
    ----------
    anova : pandas.DataFrame
        A :func:`mixed_anova` table.
    alpha : float
        Level of Mauchly's test.

    Returns
    -------
    pandas.DataFrame
        Columns ``source, correction, reason, df1, df2, p, epsilon`` (epsilon empty when none).

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import mixed_anova, sphericity_correction
    >>> table = mixed_anova(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject")
    >>> sphericity_correction(table)[["source", "correction"]]
           source correction
    0       Group       none
    1        Time       none
    2  Group:Time       none
    """
    rows = []
    for index, row in enumerate(anova.itertuples(index=False)):
        uncorrected = (row.df1, row.df2, row.p_unc, np.nan)
        if index == 0:
            rows.append((row.source, "none", "between-participant effect", *uncorrected))
        elif np.isnan(row.eps_GG):
            why = "sphericity cannot be estimated (too few participants, or errors without variation)"
            rows.append((row.source, "none", why, *uncorrected))
        elif np.isnan(row.p_mauchly):
            rows.append((row.source, "none", "two levels: sphericity holds", *uncorrected))
        elif row.p_mauchly < alpha:
            why = f"Mauchly W = {row.W_mauchly:.3f}, p = {row.p_mauchly:.3g} < {alpha}: sphericity violated"
            rows.append((row.source, "Greenhouse-Geisser", why, row.df1_GG, row.df2_GG, row.p_GG, row.eps_GG))
        else:
            why = f"Mauchly W = {row.W_mauchly:.3f}, p = {row.p_mauchly:.3g} >= {alpha}: sphericity holds"
            rows.append((row.source, "none", why, *uncorrected))
    return pd.DataFrame(rows, columns=list(CORRECTION_COLUMNS))


def wide_complete(
    data: pd.DataFrame, dv: str, within: str, between: str, subject: str
) -> tuple[pd.DataFrame, np.ndarray]:
    """Subjects x within levels (sorted) for the complete cases, and each subject's group.

    Warns, naming them, about the subjects dropped for a missing cell.
    """
    dropped = incomplete_cases(data, dv, within, subject)
    if len(dropped):
        listed = "; ".join(f"{p}: {r}" for p, r in dropped.itertuples(index=False))
        warnings.warn(f"dropped {len(dropped)} {subject}(s) with missing cells: {listed}", stacklevel=3)
    complete = complete_cases(data, dv, within, subject)
    wide = complete.pivot_table(index=subject, columns=within, values=dv, aggfunc="mean", observed=True)
    wide = wide[sorted(wide.columns)]
    groups = complete.drop_duplicates(subject).set_index(subject)[between].loc[wide.index].to_numpy()
    return wide, groups


def group_residuals(wide: pd.DataFrame, groups: np.ndarray) -> pd.DataFrame:
    """Each subject's values minus its group's mean at each level: the ANOVA model's residuals
    (R: ``residuals()`` of afex's multivariate model)."""
    return wide - wide.groupby(groups).transform("mean")


def _sums_of_squares(y: np.ndarray, groups: np.ndarray, levels: list, ss_type: int) -> dict:
    """Hypothesis and error sums of squares (traces of H and E) per effect of the multivariate model
    Y = X B + error; H = (L B M)' (L (X'X)^-1 L')^-1 (L B M), E = M' R' R M."""
    n, k = y.shape
    last = groups == levels[-1]
    sum_coded = [(groups == level).astype(float) - last for level in levels[:-1]]
    x = np.column_stack([np.ones(n), *sum_coded])
    coef = np.linalg.lstsq(x, y, rcond=None)[0]
    residuals = y - x @ coef
    xtx_inv = np.linalg.inv(x.T @ x)
    contrasts = null_space(np.ones((1, k)))  # orthonormal within-level contrasts
    average = np.full((k, 1), 1 / np.sqrt(k))  # the subject's mean, scaled to unit length
    group_terms = np.eye(len(levels))[1:]
    if ss_type == 3:  # equal-weight mean of the group means
        grand = np.eye(len(levels))[:1]
    else:  # size-weighted mean of the group means
        sizes = np.array([np.sum(groups == level) for level in levels])
        grand = np.concatenate([[1.0], (sizes[:-1] - sizes[-1]) / n])[None, :]
    noise = ROUND_OFF * float(np.sum(y**2))
    sums = {}
    for name, rows, columns in (
        ("between", group_terms, average),
        ("within", grand, contrasts),
        ("interaction", group_terms, contrasts),
    ):
        estimate = rows @ coef @ columns
        hypothesis = estimate.T @ np.linalg.solve(rows @ xtx_inv @ rows.T, estimate)
        errors = columns.T @ residuals.T @ residuals @ columns
        sums[name] = tuple(0.0 if value <= noise else value for value in (np.trace(hypothesis), np.trace(errors)))
        if name == "within":
            sums["within_errors"] = np.where(np.abs(errors) <= noise, 0.0, errors)
    return sums


def _huynh_feldt(eps_gg: float, df_error: int, df_within: int) -> float:
    """Huynh-Feldt epsilon from Greenhouse-Geisser's, as car's summary.Anova.mlm (not capped at 1)."""
    return ((df_error + 1) * df_within * eps_gg - 2) / (df_within * (df_error - df_within * eps_gg))


def _sphericity(wide, groups, dv, within, between, subject) -> tuple[float, float, float]:
    long = wide.assign(**{between: groups}).reset_index()
    long = long.melt(id_vars=[subject, between], var_name=within, value_name=dv)
    with warnings.catch_warnings():  # pingouin 0.7 calls a pandas method that pandas 3 deprecates
        warnings.filterwarnings("ignore", message="The inplace keyword")
        aov = pg.mixed_anova(long, dv=dv, within=within, between=between, subject=subject, correction=True)
    eps = float(aov["eps"].iloc[1])
    if "W_spher" not in aov.columns:  # two levels
        return eps, np.nan, np.nan
    return eps, float(aov["W_spher"].iloc[1]), float(aov["p_spher"].iloc[1])
