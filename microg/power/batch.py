"""The report's tests on many data sets at once.

``microg.analysis`` analyses one study in about a second (pandas, pingouin and statsmodels per
test); a power simulation needs thousands. These functions compute the same numbers for a stack of
data sets with one array expression per quantity:

- the type 3 mixed ANOVA of ``microg.analysis.mixed_anova`` (the multivariate model of the wide
  data, as afex): sums of squares, F and p for the group, within and interaction terms;
- Mauchly's test and the Greenhouse-Geisser epsilon from the pooled within-group covariance (as
  pingouin's mixed_anova, which the report uses), and the p the report reads
  (``microg.analysis.sphericity_correction``: Greenhouse-Geisser when Mauchly's p < alpha);
- the Bonferroni-corrected pairwise comparisons of ``microg.analysis.posthoc`` (emmeans on afex's
  model): OLS on the groups of one derived column, pooled variance, N - groups degrees of freedom.

The tests check every number against the report's functions one data set at a time (1e-9). This
module imports nothing of ``microg.analysis`` (only the design's names), so that Dask workers stay
quick to start.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import stats
from scipy.linalg import null_space

from microg.power.design import CORRECTIONS

ROUND_OFF = 1e-12
"""A sum of squares below this share of the data's sum of squares is 0 (the report's rule,
``microg.analysis.anova.ROUND_OFF``)."""
SPHERICITY_ALPHA = 0.05

MANY_ANOVA_COLUMNS = ("dataset", "source", "SS", "SS_error", "df1", "df2", "F", "p_unc", "eps_GG", "p_GG",
                      "W_mauchly", "p_mauchly", "correction", "p")  # fmt: skip
MANY_POSTHOC_COLUMNS = ("dataset", "factor", "at", "A", "B", "estimate", "SE", "df", "T", "p_unc", "p_bonf")


def mixed_anova_many(
    data: pd.DataFrame, dv: str, within: str, between: str, subject: str, dataset: str,
    alpha: float = SPHERICITY_ALPHA, correction: str = "mauchly",
) -> pd.DataFrame:
    """Type 3 mixed ANOVA of every data set in ``data``, with the report's sphericity decision.

    Parameters
    ----------
    data : pandas.DataFrame
        Long table: one row per data set, subject and ``within`` level, no missing cells. Every data
        set must have the same number of subjects in each group.
    dv, within, between, subject : str
        Columns of the measure, the within factor, the between factor and the subject id.
    dataset : str
        Column that tells the data sets apart.
    alpha : float
        Level of Mauchly's test (the report uses its significance level).
    correction : {"mauchly", "none", "GG", "HF"}
        Which p a within effect reads (see :func:`anova_arrays`); ``mauchly`` is the report's rule.

    Returns
    -------
    pandas.DataFrame
        One row per data set and source (``between``, ``within``, ``between:within``): SS, SS_error,
        df1, df2, F, p_unc, eps_GG, p_GG, W_mauchly, p_mauchly (as ``microg.analysis.mixed_anova``),
        ``correction`` (``Greenhouse-Geisser``, ``Huynh-Feldt`` or ``none``) and ``p``, the p read.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.power.batch import mixed_anova_many
    >>> data = pg.read_dataset("mixed_anova").assign(draw=1)
    >>> table = mixed_anova_many(data, "Scores", "Time", "Group", "Subject", "draw")
    >>> table[["source", "df1", "df2", "F", "p"]].round(3)
           source  df1  df2      F      p
    0       Group    1   58  5.052  0.028
    1        Time    2  116  4.027  0.020
    2  Group:Time    2  116  2.728  0.070
    """
    keys, y, sizes, _, _ = _stack(data, dv, within, between, subject, dataset)
    result = anova_arrays(y, sizes, alpha, correction)
    sources = [between, within, f"{between}:{within}"]
    table = pd.DataFrame({
        "dataset": np.repeat(keys, 3),
        "source": sources * len(keys),
        **{name: result[name].reshape(-1) for name in
           ("SS", "SS_error", "df1", "df2", "F", "p_unc", "eps_GG", "p_GG", "W_mauchly", "p_mauchly", "p")},
    })
    table[["df1", "df2"]] = table[["df1", "df2"]].astype(int)
    table["correction"] = result["correction"].reshape(-1)
    return table[list(MANY_ANOVA_COLUMNS)]


def posthoc_many(data: pd.DataFrame, dv: str, within: str, between: str, subject: str, dataset: str) -> pd.DataFrame:
    """The report's post hoc comparisons (``microg.analysis.posthoc`` with ``within_by_group=True``)
    for every data set in ``data``.

    Parameters
    ----------
    data, dv, within, between, subject, dataset
        As for :func:`mixed_anova_many`.

    Returns
    -------
    pandas.DataFrame
        One row per data set and comparison, in the report's order: the family (``factor`` and
        ``at``), the pair A, B (estimate = A - B), SE, df, T, p_unc and the Bonferroni p within the
        family.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.power.batch import posthoc_many
    >>> data = pg.read_dataset("mixed_anova").assign(draw=1)
    >>> posthoc_many(data, "Scores", "Time", "Group", "Subject", "draw").loc[:2, ["A", "B", "T", "p_bonf"]].round(3)
             A        B      T  p_bonf
    0   August  January -1.748   0.257
    1   August     June -2.849   0.018
    2  January     June -1.025   0.928
    """
    keys, y, sizes, groups, levels = _stack(data, dv, within, between, subject, dataset)
    k, g = len(levels), len(groups)
    unit_level, unit_group = np.eye(k), np.eye(g)
    pairs = [(a, b) for a in range(k) for b in range(a + 1, k)]
    group_pairs = [(a, b) for a in range(g) for b in range(a + 1, g)]
    rows = [(within, np.nan, levels[a], levels[b], unit_level[a] - unit_level[b], np.full(g, 1 / g), 0)
            for a, b in pairs]
    rows += [(between, levels[j], groups[a], groups[b], unit_level[j], unit_group[a] - unit_group[b], 1)
             for j in range(k) for a, b in group_pairs]
    rows += [(within, groups[i], levels[a], levels[b], unit_level[a] - unit_level[b], unit_group[i], 2)
             for i in range(g) for a, b in pairs]
    result = contrast_arrays(y, sizes, np.array([r[4] for r in rows]).T, np.array([r[5] for r in rows]).T,
                             np.array([r[6] for r in rows]))
    m = len(rows)
    table = pd.DataFrame({
        "dataset": np.repeat(keys, m),
        "factor": [r[0] for r in rows] * len(keys),
        "at": pd.Series([r[1] for r in rows] * len(keys), dtype=object),
        "A": [r[2] for r in rows] * len(keys),
        "B": [r[3] for r in rows] * len(keys),
        **{name: result[name].reshape(-1) for name in ("estimate", "SE", "T", "p_unc", "p_bonf")},
        "df": float(sum(sizes) - g),
    })
    return table[list(MANY_POSTHOC_COLUMNS)]


def anova_arrays(y: np.ndarray, sizes: Sequence[int], alpha: float = SPHERICITY_ALPHA,
                 correction: str = "mauchly") -> dict[str, np.ndarray]:
    """The mixed ANOVA of data sets ``y`` (data sets, subjects, levels), subjects ordered by group
    with ``sizes`` subjects in each; every value (data sets, 3) for the group, within and
    interaction terms (the group term's sphericity values are NaN).

    ``correction`` (one of CORRECTIONS) says which p a within effect reads:
    ``mauchly`` the report's (Greenhouse-Geisser where Mauchly's p < alpha), ``none``, or always
    ``GG`` or ``HF`` (Huynh-Feldt's epsilon capped at 1, as afex and Superpower), the uncorrected p
    where epsilon cannot be estimated.

    Keys: SS, SS_error, df1, df2, F, p_unc, eps_GG, p_GG, eps_HF (uncapped, as car prints it), p_HF,
    W_mauchly, p_mauchly, correction (``none``, ``Greenhouse-Geisser`` or ``Huynh-Feldt``), p (the p
    read).
    """
    y = np.asarray(y, dtype=float)
    count, n, k = y.shape
    sizes = np.asarray(sizes)
    g = len(sizes)
    member = np.repeat(np.arange(g), sizes)
    means = np.stack([y[:, member == i].mean(axis=1) for i in range(g)], axis=1)  # (S, g, k)
    residuals = y - means[:, member]
    centring = np.eye(k) - 1 / k  # projects a row onto the within contrasts
    df_error = n - g

    subject_means = means.mean(axis=2)  # group means of a subject's mean over levels
    weighted = (sizes * subject_means).sum(axis=1, keepdims=True) / n
    ss_between = k * (sizes * (subject_means - weighted) ** 2).sum(axis=1)
    error_between = residuals.sum(axis=2) ** 2 / k
    ss_error_between = error_between.sum(axis=1)
    grand = means.mean(axis=1) @ centring  # the unweighted mean of the group means, centred over levels
    ss_within = (grand**2).sum(axis=1) / (np.sum(1 / sizes) / g**2)
    weighted_means = (sizes[:, None] * means).sum(axis=1, keepdims=True) / n
    ss_interaction = (sizes[:, None] * ((means - weighted_means) @ centring) ** 2).sum(axis=(1, 2))
    ss_error_within = (residuals**2).sum(axis=(1, 2)) - ss_error_between

    noise = ROUND_OFF * (y**2).sum(axis=(1, 2))
    ss = np.stack([ss_between, ss_within, ss_interaction], axis=1)
    ss_error = np.stack([ss_error_between, ss_error_within, ss_error_within], axis=1)
    ss, ss_error = (np.where(values <= noise[:, None], 0.0, values) for values in (ss, ss_error))
    df1 = np.array([g - 1, k - 1, (g - 1) * (k - 1)], dtype=float)
    df2 = np.array([df_error, (k - 1) * df_error, (k - 1) * df_error], dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        F = np.where(ss == 0, 0.0, (ss / df1) / (ss_error / df2))
    p_unc = stats.f.sf(F, df1, df2)

    eps, w, p_mauchly = _sphericity(residuals, df_error, noise)
    p_gg = stats.f.sf(F[:, 1:], df1[1:] * eps[:, None], df2[1:] * eps[:, None])
    d = k - 1
    with np.errstate(divide="ignore", invalid="ignore"):
        eps_hf = ((df_error + 1) * d * eps - 2) / (d * (df_error - d * eps))  # car's formula, uncapped as car prints
    capped = np.minimum(1.0, eps_hf)
    p_hf = stats.f.sf(F[:, 1:], df1[1:] * capped[:, None], df2[1:] * capped[:, None])
    estimable = ~np.isnan(eps)  # where epsilon cannot be estimated the report reads the uncorrected p
    if correction == "mauchly":
        chosen = np.where(p_mauchly < alpha, "Greenhouse-Geisser", "none")  # NaN (two levels) compares False
    elif correction in ("GG", "HF"):
        chosen = np.where(estimable, {"GG": "Greenhouse-Geisser", "HF": "Huynh-Feldt"}[correction], "none")
    elif correction == "none":
        chosen = np.full(count, "none")
    else:
        raise ValueError(f"correction must be one of {CORRECTIONS}, not {correction!r}")
    read = np.where((chosen == "Greenhouse-Geisser")[:, None], p_gg,
                    np.where((chosen == "Huynh-Feldt")[:, None], p_hf, p_unc[:, 1:]))  # fmt: skip
    nothing = np.full((count, 1), np.nan)
    return {
        "SS": ss, "SS_error": ss_error, "df1": np.broadcast_to(df1, ss.shape), "df2": np.broadcast_to(df2, ss.shape),
        "F": F, "p_unc": p_unc,
        "eps_GG": np.column_stack([nothing, eps, eps]), "p_GG": np.column_stack([nothing, p_gg]),
        "eps_HF": np.column_stack([nothing, eps_hf, eps_hf]), "p_HF": np.column_stack([nothing, p_hf]),
        "W_mauchly": np.column_stack([nothing, w, w]), "p_mauchly": np.column_stack([nothing, p_mauchly, p_mauchly]),
        "correction": np.column_stack([np.full(count, "none"), chosen, chosen]),
        "p": np.column_stack([p_unc[:, 0], read]),
    }  # fmt: skip


def contrast_arrays(
    y: np.ndarray, sizes: Sequence[int], level_weights: np.ndarray, group_weights: np.ndarray, families: np.ndarray
) -> dict[str, np.ndarray]:
    """Pairwise comparisons of data sets ``y`` (data sets, subjects, levels) as the report's post hoc.

    Contrast c takes each subject's value ``y @ level_weights[:, c]`` and tests
    ``group_weights[:, c]`` times the group means of it against the pooled within-group variance
    (df = subjects - groups); p is Bonferroni-corrected within each ``families`` label.
    Returns (data sets, contrasts) arrays: estimate, SE, T, p_unc, p_bonf.
    """
    y = np.asarray(y, dtype=float)
    sizes = np.asarray(sizes)
    n, g = int(sizes.sum()), len(sizes)
    member = np.repeat(np.arange(g), sizes)
    values = y @ level_weights  # (S, n, m)
    means = np.stack([values[:, member == i].mean(axis=1) for i in range(g)], axis=1)  # (S, g, m)
    variance = ((values - means[:, member]) ** 2).sum(axis=1) / (n - g)
    estimate = np.einsum("sgm,gm->sm", means, group_weights)
    se = np.sqrt(variance * (group_weights**2 / sizes[:, None]).sum(axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = estimate / se
    p_unc = 2 * stats.t.sf(np.abs(t), n - g)
    family_size = np.array([np.sum(families == f) for f in families])
    return {"estimate": estimate, "SE": se, "T": t, "p_unc": p_unc, "p_bonf": np.minimum(p_unc * family_size, 1.0)}


def _sphericity(residuals: np.ndarray, df_error: int, noise: np.ndarray) -> tuple[np.ndarray, ...]:
    """Greenhouse-Geisser epsilon, Mauchly's W and p per data set from the pooled within-group
    covariance of the orthonormal within contrasts; NaN where the report cannot estimate them
    (fewer error degrees of freedom than levels, or singular errors), and W, p NaN for two levels."""
    count, _, k = residuals.shape
    d = k - 1
    contrasts = null_space(np.ones((1, k)))
    errors = np.einsum("lc,snl,snm,md->scd", contrasts, residuals, residuals, contrasts)
    zeroed = np.where(np.abs(errors) <= noise[:, None, None], 0.0, errors)
    estimable = (np.linalg.matrix_rank(zeroed) == d) & (df_error >= k)
    trace = np.trace(errors, axis1=1, axis2=2)
    eps = np.minimum(trace**2 / (d * np.einsum("scd,sdc->s", errors, errors)), 1.0)
    nan = np.full(count, np.nan)
    if d == 1:
        return np.where(estimable, 1.0, nan), nan, nan
    sign, logdet = np.linalg.slogdet(errors)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_w = np.where(sign > 0, logdet - d * np.log(trace / d), -np.inf)
    f = 1 - (2 * d**2 + d + 2) / (6 * d * df_error)
    w2 = (d + 2) * (d - 1) * (d - 2) * (2 * d**3 + 6 * d**2 + 3 * k + 2) / (288 * (df_error * d * f) ** 2)
    chi_square = -df_error * f * log_w
    dof = d * (d + 1) / 2 - 1
    p1, p2 = stats.chi2.sf(chi_square, dof), stats.chi2.sf(chi_square, dof + 4)
    p = p1 + w2 * (p2 - p1)
    return np.where(estimable, eps, nan), np.where(estimable, np.exp(log_w), nan), np.where(estimable, p, nan)


def _stack(data: pd.DataFrame, dv: str, within: str, between: str, subject: str, dataset: str):
    """(data set keys, values (data sets, subjects, levels), group sizes, groups, levels): subjects
    sorted by group, then id; groups and levels sorted, as the report sorts them."""
    wide = data.pivot_table(index=[dataset, between, subject], columns=within, values=dv, aggfunc="mean",
                            observed=True)  # fmt: skip
    levels = sorted(wide.columns)
    if wide[levels].isna().any(axis=None):
        raise ValueError(f"a {subject} misses a level of {within!r}: the batch functions need complete data")
    wide = wide[levels].sort_index()
    per_set = wide.groupby(level=[dataset, between], observed=True).size().unstack(between)
    groups = sorted(per_set.columns)
    per_set = per_set[groups]
    if per_set.isna().any(axis=None) or (per_set.nunique() > 1).any():
        raise ValueError(f"every {dataset} needs the same number of {subject}s in each {between}")
    sizes = per_set.iloc[0].astype(int).to_numpy()
    keys = per_set.index.to_numpy()
    y = wide.to_numpy(float).reshape(len(keys), int(sizes.sum()), len(levels))
    return keys, y, sizes, groups, levels
