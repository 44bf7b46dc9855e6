"""The mixed ANOVA's assumptions, each checked and followed by what it means for the tests:
equal variances between groups at each level (Levene), equal covariance matrices (Box's M) and
normal residuals (Shapiro-Wilk)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import stats

from microg.analysis.anova import group_residuals, wide_complete

ASSUMPTION_COLUMNS = ("check", "at", "statistic", "df1", "df2", "p", "alpha", "violated", "consequence")
BOX_M_ALPHA = 0.001
"""Box's M flags trivial differences in samples of moderate size; it is read at .001 by convention."""


def assumption_checks(
    data: pd.DataFrame, dv: str, within: str, between: str, subject: str, alpha: float = 0.05
) -> pd.DataFrame:
    """Check the mixed ANOVA's assumptions on the complete cases and say what follows from each.

    - Levene's test of equal variances between the groups at each ``within`` level, centred on the
      median (Brown-Forsythe; R's ``car::leveneTest`` default).
    - Box's M test of equal covariance matrices across groups (chi-square approximation, as R's
      ``rstatix::box_m``), judged at .001.
    - Shapiro-Wilk test of the ANOVA's residuals (each value minus its group's mean at that level,
      R's ``shapiro.test(residuals(afex_fit))``).

    Parameters
    ----------
    data : pandas.DataFrame
        Long table, one row per subject and ``within`` level.
    dv, within, between, subject : str
        Columns of the measure, the within factor, the between factor and the subject id.
    alpha : float
        Level of Levene's and Shapiro-Wilk's tests.

    Returns
    -------
    pandas.DataFrame
        One row per test, columns ASSUMPTION_COLUMNS: check, at (the level, for Levene), statistic
        (F, chi-square or W), df1, df2, p, the alpha it is read at, violated, and consequence (what
        it means for the ANOVA, in words). A test the data cannot support has empty statistics and
        says why.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import assumption_checks
    >>> checks = assumption_checks(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject")
    >>> checks[["check", "at", "statistic", "p"]].round(4)
                           check       at  statistic       p
    0                     Levene   August     1.4996  0.2257
    1                     Levene  January     1.6725  0.2010
    2                     Levene     June     0.1724  0.6796
    3                    Box's M             5.4614  0.4861
    4  Shapiro-Wilk of residuals             0.9854  0.0585
    """
    wide, groups = wide_complete(data, dv, within, between, subject)
    rows = [_levene(wide[level], groups, level, alpha) for level in wide.columns]
    rows.append(_box_m(wide, groups))
    rows.append(_normal_residuals(group_residuals(wide, groups).to_numpy().ravel(), alpha))
    return pd.DataFrame(rows, columns=list(ASSUMPTION_COLUMNS))


def _levene(values: pd.Series, groups: np.ndarray, level, alpha: float) -> tuple:
    samples = [values[groups == g].to_numpy() for g in sorted(set(groups))]
    # the test is an ANOVA of the distances from each group's median: with none varying within any
    # group (no variation, or two participants a group) its F has a zero denominator
    if min(len(s) for s in samples) < 2 or all(np.ptp(np.abs(s - np.median(s))) == 0 for s in samples):
        return ("Levene", level, np.nan, np.nan, np.nan, np.nan, alpha, False,
                f"cannot be computed at {level}: too few participants, or their distances from their group's "
                "median do not vary")  # fmt: skip
    test = stats.levene(*samples, center="median")
    df1, df2 = len(samples) - 1, sum(len(s) for s in samples) - len(samples)
    violated = bool(test.pvalue < alpha)
    consequence = (
        f"the groups' variances differ at {level}: the group comparisons at {level} pool them, so read "
        "those with caution, the more so if the groups are unequal in size"
        if violated
        else f"equal variances of the groups at {level} are plausible"
    )
    return ("Levene", level, float(test.statistic), df1, df2, float(test.pvalue), alpha, violated, consequence)


def _box_m(wide: pd.DataFrame, groups: np.ndarray) -> tuple:
    k = wide.shape[1]
    samples = [wide[groups == g].to_numpy(float) for g in set(groups)]
    if min(len(s) for s in samples) <= k or min(np.linalg.matrix_rank(np.cov(s, rowvar=False)) for s in samples) < k:
        why = (
            "cannot be computed: in some group the covariance matrix is singular (no more participants than levels, "
            "or values that do not vary)"
        )
        return ("Box's M", "", np.nan, np.nan, np.nan, np.nan, BOX_M_ALPHA, False, why)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        test = pg.box_m(wide.assign(_group=groups), dvs=list(wide.columns), group="_group", alpha=BOX_M_ALPHA).iloc[0]
    violated = bool(test["pval"] < BOX_M_ALPHA)
    consequence = (
        "the groups' covariance matrices differ: the pooled covariance behind the within effects, the post hoc "
        "tests and the simple effects misrepresents some group; trust unequal-sized groups least"
        if violated
        else "equal covariance matrices across groups are plausible, so pooling them is justified"
    )
    return ("Box's M", "", float(test["Chi2"]), float(test["df"]), np.nan, float(test["pval"]), BOX_M_ALPHA,
            violated, consequence)  # fmt: skip


def _normal_residuals(residuals: np.ndarray, alpha: float) -> tuple:
    if len(residuals) < 3 or np.ptp(residuals) == 0:
        return ("Shapiro-Wilk of residuals", "", np.nan, np.nan, np.nan, np.nan, alpha, False,
                "cannot be computed: the residuals do not vary")  # fmt: skip
    test = stats.shapiro(residuals)
    violated = bool(test.pvalue < alpha)
    consequence = (
        "the residuals depart from normality: the F tests tolerate moderate departures with similar group "
        "sizes, but check the conclusions against the paired Wilcoxon tests (and for counts, the count model)"
        if violated
        else "the residuals are consistent with normality"
    )
    return ("Shapiro-Wilk of residuals", "", float(test.statistic), np.nan, np.nan, float(test.pvalue), alpha,
            violated, consequence)  # fmt: skip
