"""Interaction model vs baseline on the same participants (the paper's Table 1): descriptives, paired t-test,
Wilcoxon signed-rank test and effect sizes with confidence intervals, all on one value per
participant and interaction."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import stats

from microg.analysis.anova import CONFIDENCE, noncentrality
from microg.analysis.tables import incomplete_cases

INTERACTIONS_COLUMNS = (
    "measure", "interaction", "baseline", "n", "mean_interaction", "sd_interaction", "mean_baseline", "sd_baseline",
    "mean_diff", "T", "dof", "p_t", "cohen_d", "V", "p_wilcoxon", "rbc", "p_shapiro",
    "diff_ci_low", "diff_ci_high", "d_z", "d_z_ci_low", "d_z_ci_high", "rbc_ci_low", "rbc_ci_high", "n_nonzero",
)  # fmt: skip
SIGNED_RANK_COLUMNS = ("n", "n_nonzero", "V", "p", "z", "r", "rbc", "rbc_ci_low", "rbc_ci_high")
EXACT_SIGNED_RANK_MAX_N = 50


def signed_rank(x, y) -> pd.DataFrame:
    """Wilcoxon signed-rank test of paired samples, with the p-value R's wilcox.test gives.

    Zero differences are dropped (R's default). p is exact below 50 non-zero differences without
    ties, else the normal approximation with continuity correction.

    Parameters
    ----------
    x, y : array_like
        Paired values.

    Returns
    -------
    pandas.DataFrame
        One row, columns SIGNED_RANK_COLUMNS: n pairs, n_nonzero differences, V (sum of the ranks of
        the positive differences, R's statistic), p, z (normal approximation without continuity
        correction, signed like V - E[V]), r = z / sqrt(n_nonzero), rbc (matched-pairs
        rank-biserial correlation (W+ - W-) / (W+ + W-)) and its 95 % CI (Fisher z with the SE of
        R's effectsize::rank_biserial).

    Examples
    --------
    >>> from microg.analysis import signed_rank
    >>> signed_rank([5, 6, 7, 9, 4], [4, 3, 6, 5, 5])[["V", "p", "rbc"]].round(3)
          V     p    rbc
    0  13.0  0.17  0.733
    """
    diff = np.asarray(x, float) - np.asarray(y, float)
    nonzero = diff[diff != 0]
    m = len(nonzero)
    if m == 0:
        return pd.DataFrame([(len(diff), 0, 0.0, *[np.nan] * 6)], columns=list(SIGNED_RANK_COLUMNS))
    ranks = stats.rankdata(np.abs(nonzero))
    v_plus = float(ranks[nonzero > 0].sum())
    v_minus = float(ranks[nonzero < 0].sum())
    ties = len(np.unique(ranks)) < m
    zeros = m < len(diff)
    if m < EXACT_SIGNED_RANK_MAX_N and not ties and not zeros:
        p = stats.wilcoxon(nonzero, method="exact").pvalue
    else:
        p = stats.wilcoxon(nonzero, method="approx", correction=True).pvalue
    z_size = abs(stats.wilcoxon(nonzero, method="approx", correction=False).zstatistic)
    z = float(np.sign(v_plus - m * (m + 1) / 4) * z_size)
    rbc = (v_plus - v_minus) / (v_plus + v_minus)
    spread = np.sqrt((2 * m**3 + 3 * m**2 + m) / 6) / ((m**2 + m) / 2)
    margin = stats.norm.ppf((1 + CONFIDENCE) / 2) * spread
    with np.errstate(divide="ignore"):
        low, high = np.tanh(np.arctanh(rbc) - margin), np.tanh(np.arctanh(rbc) + margin)
    row = (len(diff), m, v_plus, float(p), z, z / np.sqrt(m), rbc, float(low), float(high))
    return pd.DataFrame([row], columns=list(SIGNED_RANK_COLUMNS))


def paired_means(
    cells: pd.DataFrame,
    dv: str,
    interaction: str,
    baseline: str,
    within: str = "object",
    subject: str = "participant",
    interaction_column: str = "interaction",
) -> pd.DataFrame:
    """Each participant's mean of ``dv`` over the ``within`` levels with the interaction model and the baseline.

    Only participants with a value in every level for both interaction models are paired (a mean over fewer
    levels would not be comparable); :func:`unpaired_participants` says who is left out and why.

    Parameters
    ----------
    cells : pandas.DataFrame
        Participant-level cells: one row per participant, interaction and ``within`` level.
    dv, interaction, baseline, within, subject, interaction_column
        As for :func:`compare_interactions`.

    Returns
    -------
    pandas.DataFrame
        Columns ``subject, interaction_column, dv``: two rows per paired participant.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import paired_means
    >>> cells = pd.DataFrame({"participant": ["a"] * 4 + ["b"] * 3, "interaction": ["s", "s", "b", "b", "s", "s", "b"],
    ...                       "object": ["x", "y"] * 3 + ["x"], "time_s": [1.0, 3.0, 4.0, 6.0, 2.0, 2.0, 9.0]})
    >>> paired_means(cells, "time_s", "s", "b")
      participant interaction  time_s
    0           a           s     2.0
    1           a           b     5.0
    """
    left_out = unpaired_participants(cells, dv, interaction, baseline, within, subject, interaction_column)[subject]
    kept = cells[cells[interaction_column].isin([interaction, baseline]) & ~cells[subject].isin(left_out)]
    means = kept.groupby([subject, interaction_column], observed=True)[dv].mean().reset_index()
    order = means[interaction_column].map({interaction: 0, baseline: 1})
    return means.assign(_order=order).sort_values([subject, "_order"]).drop(columns="_order").reset_index(drop=True)


def unpaired_participants(
    cells: pd.DataFrame,
    dv: str,
    interaction: str,
    baseline: str,
    within: str = "object",
    subject: str = "participant",
    interaction_column: str = "interaction",
) -> pd.DataFrame:
    """The participants :func:`paired_means` leaves out: a ``within`` level missing with an interaction.

    Parameters
    ----------
    cells, dv, interaction, baseline, within, subject, interaction_column
        As for :func:`compare_interactions`.

    Returns
    -------
    pandas.DataFrame
        Columns ``subject`` and ``reason``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import unpaired_participants
    >>> cells = pd.DataFrame({"participant": ["a", "a", "a"], "interaction": ["s", "s", "b"],
    ...                       "object": ["x", "y", "x"], "time_s": [1.0, 3.0, 4.0]})
    >>> unpaired_participants(cells, "time_s", "s", "b")
      participant                         reason
    0           a  no time_s for object y with b
    """
    levels = sorted(cells[within].unique())
    reasons: dict[str, list[str]] = {}
    for name in (interaction, baseline):
        rows = cells[cells[interaction_column] == name]
        for who, why in incomplete_cases(rows, dv, within, subject, levels).itertuples(index=False):
            reasons.setdefault(who, []).append(f"{why} with {name}")
        for who in sorted(set(cells[subject]) - set(rows[subject])):
            reasons.setdefault(who, []).append(f"no {dv} with {name}")
    return pd.DataFrame({subject: list(reasons), "reason": ["; ".join(why) for why in reasons.values()]})


def compare_interactions(
    cells: pd.DataFrame,
    dv: str,
    interaction: str,
    baseline: str,
    within: str = "object",
    subject: str = "participant",
    interaction_column: str = "interaction",
) -> pd.DataFrame:
    """Compare ``interaction`` with ``baseline`` on ``dv``, paired by participant (the paper's Table 1).

    Per participant, ``dv`` is averaged over the ``within`` levels (participants without every
    level with both interaction models are dropped, with a warning naming them); mean and sample SD are over
    participants.

    Parameters
    ----------
    cells : pandas.DataFrame
        Participant-level cells: one row per participant, interaction and ``within`` level.
    dv : str
        The measure.
    interaction, baseline : str
        The two interaction models (values of ``interaction_column``); differences are interaction - baseline.
    within, subject, interaction_column : str
        Columns of the within factor, the participant and the interaction model.

    Returns
    -------
    pandas.DataFrame
        One row, columns INTERACTIONS_COLUMNS: n pairs; means and SDs; mean_diff (interaction - baseline) with
        its 95 % CI (diff_ci_low, diff_ci_high); the paired t-test (T, dof, p_t); Cohen's d on the
        average SD (cohen_d, pingouin's paired d) and d_z = mean_diff / SD of the differences with
        its 95 % CI from the noncentral t (as R's effectsize::cohens_d(paired = TRUE)); the Wilcoxon
        signed-rank test (V, p_wilcoxon, n_nonzero) with the rank-biserial correlation and its 95 %
        CI; p_shapiro, the Shapiro-Wilk test of the paired differences.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import compare_interactions
    >>> data = pg.read_dataset("mixed_anova").query("Time != 'June'").assign(object="all")
    >>> row = compare_interactions(data, "Scores", "August", "January", subject="Subject", interaction_column="Time")
    >>> row[["n", "mean_diff", "diff_ci_low", "diff_ci_high", "p_t", "d_z"]].round(3)
        n  mean_diff  diff_ci_low  diff_ci_high    p_t    d_z
    0  60     -0.317       -0.681         0.047  0.087 -0.225
    """
    dropped = unpaired_participants(cells, dv, interaction, baseline, within, subject, interaction_column)
    if len(dropped):
        listed = "; ".join(f"{p}: {r}" for p, r in dropped.itertuples(index=False))
        warnings.warn(f"dropped {len(dropped)} {subject}(s) from the {dv} pairs: {listed}", stacklevel=2)
    wide = paired_means(cells, dv, interaction, baseline, within, subject, interaction_column).pivot(
        index=subject, columns=interaction_column, values=dv
    )
    x, y = wide[interaction].to_numpy(), wide[baseline].to_numpy()
    n = len(x)
    ttest = pg.ttest(x, y, paired=True).iloc[0]
    rank = signed_rank(x, y).iloc[0]
    diff = x - y
    sd_diff = diff.std(ddof=1)
    low, high = stats.t.interval(CONFIDENCE, n - 1, loc=diff.mean(), scale=sd_diff / np.sqrt(n))
    p_shapiro = stats.shapiro(diff).pvalue if n >= 3 and np.ptp(diff) > 0 else np.nan
    row = {
        "measure": dv,
        "interaction": interaction,
        "baseline": baseline,
        "n": n,
        "mean_interaction": x.mean(),
        "sd_interaction": x.std(ddof=1),
        "mean_baseline": y.mean(),
        "sd_baseline": y.std(ddof=1),
        "mean_diff": diff.mean(),
        "T": ttest["T"],
        "dof": ttest["dof"],
        "p_t": ttest["p_val"],
        "cohen_d": pg.compute_effsize(x, y, paired=True, eftype="cohen"),
        "V": rank["V"],
        "p_wilcoxon": rank["p"],
        "rbc": rank["rbc"],
        "p_shapiro": float(p_shapiro),
        "diff_ci_low": low,
        "diff_ci_high": high,
        "d_z": ttest["T"] / np.sqrt(n),
        **dict(zip(("d_z_ci_low", "d_z_ci_high"), _standardised_mean_ci(ttest["T"], n))),
        "rbc_ci_low": rank["rbc_ci_low"],
        "rbc_ci_high": rank["rbc_ci_high"],
        "n_nonzero": rank["n_nonzero"],
    }
    return pd.DataFrame([row], columns=list(INTERACTIONS_COLUMNS))


def _standardised_mean_ci(t: float, n: int) -> tuple[float, float]:
    """95 % CI of d_z = t / sqrt(n): the noncentralities that put t at the 97.5 and 2.5 % points."""
    if not np.isfinite(t):
        return np.nan, np.nan
    tail = (1 - CONFIDENCE) / 2
    low, high = (noncentrality(lambda ncp: stats.nct.cdf(t, n - 1, ncp), p, floor=None) for p in (1 - tail, tail))
    return low / np.sqrt(n), high / np.sqrt(n)
