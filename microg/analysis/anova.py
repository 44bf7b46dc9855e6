"""Mixed ANOVA (one between factor x one within factor) with the numbers R's afex reports.

Sums of squares come from the multivariate linear model of the wide data (one column per
within level, between factor in sum-to-zero coding), as afex/car compute them: type 3 by default,
type 2 on request; the two differ only for the within main effect and only when groups are unequal.
Mauchly's test and the Greenhouse-Geisser epsilon come from pingouin's mixed_anova, which uses the
pooled within-group covariance (as afex does), not from pingouin.sphericity, which ignores groups.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import stats
from scipy.linalg import null_space
from statsmodels.multivariate.manova import MANOVA

from microg.analysis.tables import AnalysisInputError, complete_cases

ANOVA_COLUMNS = (
    "source", "SS", "df1", "df2", "MS", "F", "p_unc", "np2",
    "eps_GG", "df1_GG", "df2_GG", "p_GG", "W_mauchly", "p_mauchly",
)  # fmt: skip
SPHERICITY_ALPHA = 0.05


def mixed_anova(data: pd.DataFrame, dv: str, within: str, between: str, subject: str, ss_type: int = 3) -> pd.DataFrame:
    """Mixed ANOVA of ``dv``: rows ``between``, ``within``, ``between:within``; columns ANOVA_COLUMNS.

    ``data`` is long: one row per subject and within level (several rows are averaged). Subjects
    missing a within level are dropped with a warning that names them (complete cases, as afex).
    The Greenhouse-Geisser columns are filled for every within effect; whether to use them is
    :func:`sphericity_correction`'s call. With two within levels sphericity holds trivially
    (epsilon 1, no Mauchly test); with fewer error degrees of freedom than within levels there is
    too little data to test or estimate it (epsilon and Mauchly NaN).
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
    if n - len(levels) < k - 1:
        raise AnalysisInputError(
            f"{n} complete {subject}s in {len(levels)} groups of column {between!r} leave {n - len(levels)} error "
            f"degrees of freedom; the {k} levels of column {within!r} need at least {k - 1}"
        )
    try:
        hypotheses = _mlm_sums_of_squares(wide.to_numpy(), groups, levels, ss_type)
    except np.linalg.LinAlgError:
        raise AnalysisInputError(
            f"the {n} complete {subject}s' {dv} values leave the within-{subject} covariance singular (too few "
            f"{subject}s, or a level of column {within!r} without variation)"
        ) from None
    df_between, df_within = len(levels) - 1, k - 1
    df_error = n - len(levels)
    if df_error < k:
        eps, w_mauchly, p_mauchly = np.nan, np.nan, np.nan
    else:
        eps, w_mauchly, p_mauchly = _sphericity(wide, groups, dv, within, between, subject)

    table = pd.DataFrame(
        {
            "source": [between, within, f"{between}:{within}"],
            "SS": [hypotheses[name][0] for name in ("between", "within", "interaction")],
            "SS_error": [hypotheses[name][1] for name in ("between", "within", "interaction")],
            "df1": [df_between, df_within, df_between * df_within],
            "df2": [df_error, df_within * df_error, df_within * df_error],
        }
    )
    table["MS"] = table["SS"] / table["df1"]
    table["F"] = table["MS"] / (table["SS_error"] / table["df2"])
    table["p_unc"] = stats.f.sf(table["F"], table["df1"], table["df2"])
    table["np2"] = table["SS"] / (table["SS"] + table["SS_error"])
    repeated = np.array([False, True, True])
    table["eps_GG"] = np.where(repeated, eps, np.nan)
    table["df1_GG"] = table["df1"] * table["eps_GG"]
    table["df2_GG"] = table["df2"] * table["eps_GG"]
    table["p_GG"] = stats.f.sf(table["F"], table["df1_GG"], table["df2_GG"])
    table["W_mauchly"] = np.where(repeated, w_mauchly, np.nan)
    table["p_mauchly"] = np.where(repeated, p_mauchly, np.nan)
    return table[list(ANOVA_COLUMNS)]


def sphericity_correction(anova: pd.DataFrame, alpha: float = SPHERICITY_ALPHA) -> pd.DataFrame:
    """Which p to read for each source, and why: Greenhouse-Geisser when Mauchly's test rejects
    sphericity at ``alpha``, the uncorrected p otherwise (and always for the between factor)."""
    rows = []
    for index, row in enumerate(anova.itertuples(index=False)):
        if index == 0:
            rows.append((row.source, "none", "between-participant effect", row.df1, row.df2, row.p_unc))
        elif np.isnan(row.eps_GG):
            why = f"too few participants to test sphericity (error df {row.df2 / row.df1:g} < within levels)"
            rows.append((row.source, "none", why, row.df1, row.df2, row.p_unc))
        elif np.isnan(row.p_mauchly):
            rows.append((row.source, "none", "two levels: sphericity holds", row.df1, row.df2, row.p_unc))
        elif row.p_mauchly < alpha:
            why = f"Mauchly W = {row.W_mauchly:.3f}, p = {row.p_mauchly:.3g} < {alpha}: sphericity violated"
            rows.append((row.source, "Greenhouse-Geisser", why, row.df1_GG, row.df2_GG, row.p_GG))
        else:
            why = f"Mauchly W = {row.W_mauchly:.3f}, p = {row.p_mauchly:.3g} >= {alpha}: sphericity holds"
            rows.append((row.source, "none", why, row.df1, row.df2, row.p_unc))
    return pd.DataFrame(rows, columns=["source", "correction", "reason", "df1", "df2", "p"])


def wide_complete(
    data: pd.DataFrame, dv: str, within: str, between: str, subject: str
) -> tuple[pd.DataFrame, np.ndarray]:
    """Subjects x within levels (sorted) for the complete cases, and each subject's group.

    Warns, naming them, about the subjects dropped for a missing cell.
    """
    complete, dropped = complete_cases(data, dv, within, subject)
    if len(dropped):
        listed = "; ".join(f"{p}: {r}" for p, r in dropped.itertuples(index=False))
        warnings.warn(f"dropped {len(dropped)} {subject}(s) with missing cells: {listed}", stacklevel=3)
    wide = complete.pivot_table(index=subject, columns=within, values=dv, aggfunc="mean", observed=True)
    wide = wide[sorted(wide.columns)]
    groups = complete.drop_duplicates(subject).set_index(subject)[between].loc[wide.index].to_numpy()
    return wide, groups


def _mlm_sums_of_squares(y: np.ndarray, groups: np.ndarray, levels: list, ss_type: int) -> dict:
    """Hypothesis and error sums of squares (trace of H and E) per effect from the multivariate model."""
    n, k = y.shape
    last = groups == levels[-1]
    sum_coded = [(groups == level).astype(float) - last for level in levels[:-1]]
    x = np.column_stack([np.ones(n), *sum_coded])
    contrasts = null_space(np.ones((1, k)))  # orthonormal within-level contrasts
    average = np.full((k, 1), 1 / np.sqrt(k))  # the subject's mean, scaled to unit length
    group_terms = np.eye(len(levels))[1:]
    if ss_type == 3:  # equal-weight mean of the group means
        grand = np.eye(len(levels))[:1]
    else:  # size-weighted mean of the group means
        sizes = np.array([np.sum(groups == level) for level in levels])
        grand = np.concatenate([[1.0], (sizes[:-1] - sizes[-1]) / n])[None, :]
    tests = MANOVA(y, x).mv_test(
        [
            ("between", group_terms, average),
            ("within", grand, contrasts),
            ("interaction", group_terms, contrasts),
        ]
    )
    return {name: (np.trace(r["H"]), np.trace(r["E"])) for name, r in tests.results.items()}


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
