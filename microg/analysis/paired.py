"""System vs baseline on the same participants (the paper's Table 1): descriptives, paired t-test,
Wilcoxon signed-rank test and effect sizes, all on one value per participant and system."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import stats

from microg.analysis.tables import complete_cases

SYSTEMS_COLUMNS = (
    "measure", "system", "baseline", "n", "mean_system", "sd_system", "mean_baseline", "sd_baseline",
    "mean_diff", "T", "dof", "p_t", "cohen_d", "V", "p_wilcoxon", "rbc", "p_shapiro",
)  # fmt: skip
EXACT_SIGNED_RANK_MAX_N = 50


@dataclass(frozen=True)
class SignedRank:
    """Wilcoxon signed-rank test of x - y with zero differences dropped (R's wilcox.test default).

    V: sum of the ranks of the positive differences (R's statistic); p: exact when fewer than 50
    non-zero differences without ties, else the normal approximation with continuity correction;
    z: the normal approximation without continuity correction, signed like V - E[V];
    r = z / sqrt(n_nonzero); rbc: matched-pairs rank-biserial correlation (W+ - W-) / (W+ + W-).
    """

    n: int
    n_nonzero: int
    V: float
    p: float
    z: float
    r: float
    rbc: float


def signed_rank(x: np.ndarray, y: np.ndarray) -> SignedRank:
    """Wilcoxon signed-rank test of paired samples, with the p-value R's wilcox.test gives."""
    diff = np.asarray(x, float) - np.asarray(y, float)
    nonzero = diff[diff != 0]
    m = len(nonzero)
    if m == 0:
        return SignedRank(len(diff), 0, 0.0, np.nan, np.nan, np.nan, np.nan)
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
    return SignedRank(len(diff), m, v_plus, float(p), z, z / np.sqrt(m), (v_plus - v_minus) / (v_plus + v_minus))


def paired_means(
    cells: pd.DataFrame,
    dv: str,
    system: str,
    baseline: str,
    within: str = "object",
    subject: str = "participant",
    system_column: str = "system",
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Each participant's mean over the ``within`` levels for the system and the baseline.

    Only participants with a value in every level for both systems are paired (a mean over fewer
    objects would not be comparable). Returns (subjects x [system, baseline], dropped with reasons).
    """
    levels = sorted(cells[within].unique())
    means, reasons = {}, {}
    for name in (system, baseline):
        rows = cells[cells[system_column] == name]
        complete, missing = complete_cases(rows, dv, within, subject, levels)
        means[name] = complete.groupby(subject, observed=True)[dv].mean()
        for who, why in missing.itertuples(index=False):
            reasons.setdefault(who, []).append(f"{why} with {name}")
        for who in sorted(set(cells[subject]) - set(rows[subject])):
            reasons.setdefault(who, []).append(f"no {dv} with {name}")
    dropped = pd.DataFrame({"participant": list(reasons), "reason": ["; ".join(why) for why in reasons.values()]})
    return pd.DataFrame(means).dropna(), dropped


def compare_systems(
    cells: pd.DataFrame,
    dv: str,
    system: str,
    baseline: str,
    within: str = "object",
    subject: str = "participant",
    system_column: str = "system",
) -> pd.DataFrame:
    """One row (columns SYSTEMS_COLUMNS) comparing ``system`` with ``baseline`` on ``dv``.

    Per participant, ``dv`` is averaged over the ``within`` levels; mean and sample SD are over
    participants; the paired t-test comes with Cohen's d on the average SD (pingouin's paired d,
    signed like the difference),
    the Wilcoxon signed-rank test with the rank-biserial correlation; p_shapiro tests the
    normality of the paired differences (Shapiro-Wilk).
    """
    wide, dropped = paired_means(cells, dv, system, baseline, within, subject, system_column)
    if len(dropped):
        listed = "; ".join(f"{p}: {r}" for p, r in dropped.itertuples(index=False))
        warnings.warn(f"dropped {len(dropped)} {subject}(s) from the {dv} pairs: {listed}", stacklevel=2)
    x, y = wide[system].to_numpy(), wide[baseline].to_numpy()
    ttest = pg.ttest(x, y, paired=True).iloc[0]
    rank = signed_rank(x, y)
    diff = x - y
    p_shapiro = stats.shapiro(diff).pvalue if len(diff) >= 3 and np.ptp(diff) > 0 else np.nan
    row = {
        "measure": dv,
        "system": system,
        "baseline": baseline,
        "n": len(wide),
        "mean_system": x.mean(),
        "sd_system": x.std(ddof=1),
        "mean_baseline": y.mean(),
        "sd_baseline": y.std(ddof=1),
        "mean_diff": diff.mean(),
        "T": ttest["T"],
        "dof": ttest["dof"],
        "p_t": ttest["p_val"],
        "cohen_d": pg.compute_effsize(x, y, paired=True, eftype="cohen"),
        "V": rank.V,
        "p_wilcoxon": rank.p,
        "rbc": rank.rbc,
        "p_shapiro": float(p_shapiro),
    }
    return pd.DataFrame([row], columns=list(SYSTEMS_COLUMNS))
