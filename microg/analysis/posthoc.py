"""Post hoc comparisons and simple effects for the mixed design, as R's emmeans computes them on
afex's multivariate model.

Each comparison is a linear contrast of the group-by-level cell means, tested against the pooled
within-group (co)variance with N - (number of groups) degrees of freedom. Every pairwise kind
reduces to an ordinary least-squares fit on the groups (cell-means coding) of one column derived
from the wide data:
- levels of the within factor, averaged over groups with equal weights: the per-subject difference
  between the two levels, contrast = the mean of its group means (emmeans' ``pairs(emmeans(fit, ~ object))``);
- groups at one level of the within factor: that level's values, contrast = the difference of the two
  group means (emmeans' ``pairs(emmeans(fit, ~ group | object))``);
- levels of the within factor in one group: the per-subject difference, contrast = that group's mean
  (emmeans' ``pairs(emmeans(fit, ~ object | group))``).
A paired t-test that ignores the groups (pingouin's pairwise_tests) uses a different variance and df
and can reach a different conclusion. The Bonferroni family is all comparisons of one kind (emmeans
with ``by = NULL``).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd
import pingouin as pg
import statsmodels.api as sm
from scipy import stats

from microg.analysis.anova import CONFIDENCE, wide_complete
from microg.analysis.tables import stars

POSTHOC_COLUMNS = (
    "factor", "at", "A", "B", "estimate", "SE", "df", "T", "p_unc", "p_bonf", "stars",
    "ci_low", "ci_high", "ci_low_bonf", "ci_high_bonf",
)  # fmt: skip
SIMPLE_EFFECT_COLUMNS = ("effect", "at", "df1", "df2", "F", "p_unc", "p_bonf", "stars")


def posthoc(
    data: pd.DataFrame, dv: str, within: str, between: str, subject: str, within_by_group: bool = False
) -> pd.DataFrame:
    """Bonferroni-corrected pairwise comparisons of a mixed design, as emmeans on afex's model.

    Parameters
    ----------
    data : pandas.DataFrame
        Long table, one row per subject and ``within`` level. Subjects missing a level are dropped
        (with a warning), as in :func:`microg.analysis.mixed_anova`.
    dv, within, between, subject : str
        Columns of the measure, the within factor, the between factor and the subject id.
    within_by_group : bool
        Also compare the ``within`` levels inside each group (the simple effects' pairs; a third
        family, rows with ``factor`` = ``within`` and ``at`` = the group).

    Returns
    -------
    pandas.DataFrame
        Columns POSTHOC_COLUMNS: the family (``factor``; ``at`` the level it is compared at), the
        pair A, B, estimate = A - B, its SE, df, T, the uncorrected and the Bonferroni p (within the
        family), stars on the Bonferroni p, the 95 % CI (ci_low, ci_high) and the
        Bonferroni-adjusted 95 % CI (ci_low_bonf, ci_high_bonf; excludes 0 exactly when
        p_bonf < .05).

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import posthoc
    >>> table = posthoc(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject")
    >>> table.loc[:2, ["A", "B", "estimate", "ci_low_bonf", "ci_high_bonf", "p_bonf"]].round(3)
             A        B  estimate  ci_low_bonf  ci_high_bonf  p_bonf
    0   August  January    -0.317       -0.764         0.130   0.257
    1   August     June    -0.498       -0.929        -0.067   0.018
    2  January     June    -0.181       -0.617         0.255   0.928
    """
    wide, groups = wide_complete(data, dv, within, between, subject)
    group_levels = sorted(set(groups))
    design = np.column_stack([(groups == g).astype(float) for g in group_levels])
    equal_weights = np.full(len(group_levels), 1 / len(group_levels))
    pairs = list(combinations(wide.columns, 2))

    families = [
        [(within, np.nan, a, b, _contrast(wide[a] - wide[b], design, equal_weights)) for a, b in pairs],
        [
            (between, level, a, b, _contrast(wide[level], design, _difference(group_levels, a, b)))
            for level in wide.columns
            for a, b in combinations(group_levels, 2)
        ],
    ]
    if within_by_group:
        only = {g: (np.array(group_levels) == g).astype(float) for g in group_levels}
        families.append(
            [(within, g, a, b, _contrast(wide[a] - wide[b], design, only[g])) for g in group_levels for a, b in pairs]
        )
    return pd.concat([_family(rows) for rows in families], ignore_index=True)[list(POSTHOC_COLUMNS)]


def simple_effects(data: pd.DataFrame, dv: str, within: str, between: str, subject: str) -> pd.DataFrame:
    """The effect of ``within`` inside each group: emmeans' ``joint_tests(fit, by = between)``.

    A Wald F test that the group's ``within`` means are equal, with the pooled within-group
    covariance of afex's multivariate model: F = n_g (C m)' (C S C')^-1 (C m) / (k - 1) with
    df (k - 1, N - number of groups). Read it after a significant interaction. The family is the
    tests of all groups: p_bonf is Bonferroni over them.

    Parameters
    ----------
    data, dv, within, between, subject
        As for :func:`posthoc`.

    Returns
    -------
    pandas.DataFrame
        Columns SIMPLE_EFFECT_COLUMNS: effect (the ``within`` name), at (the group), df1, df2, F,
        p_unc, p_bonf, stars.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import simple_effects
    >>> table = simple_effects(pg.read_dataset("mixed_anova"), "Scores", "Time", "Group", "Subject")
    >>> table[["at", "df1", "df2", "F", "p_bonf"]].round(4)
               at  df1  df2       F  p_bonf
    0     Control    2   58  0.0842  1.0000
    1  Meditation    2   58  6.8465  0.0043
    """
    wide, groups = wide_complete(data, dv, within, between, subject)
    n, k = wide.shape
    group_levels = sorted(set(groups))
    values = wide.to_numpy(float)
    means = np.array([values[groups == g].mean(axis=0) for g in group_levels])
    residuals = values - means[np.searchsorted(group_levels, groups)]
    df_error = n - len(group_levels)
    covariance = residuals.T @ residuals / df_error
    contrasts = np.eye(k)[:-1] - np.eye(k)[1:]  # successive differences; F does not depend on the choice
    rows = []
    for g, mean in zip(group_levels, means):
        difference = contrasts @ mean
        spread = contrasts @ covariance @ contrasts.T / np.sum(groups == g)
        F = float(difference @ np.linalg.pinv(spread) @ difference) / (k - 1)
        rows.append((within, g, k - 1, df_error, F, float(stats.f.sf(F, k - 1, df_error))))
    table = pd.DataFrame(rows, columns=list(SIMPLE_EFFECT_COLUMNS[:-2]))
    table["at"] = table["at"].astype(object)
    table["p_bonf"] = pg.multicomp(table["p_unc"].to_numpy(), method="bonf")[1]
    table["stars"] = table["p_bonf"].map(stars)
    return table


def _contrast(values: pd.Series, design: np.ndarray, weights: np.ndarray) -> tuple[float, ...]:
    test = sm.OLS(values.to_numpy(), design).fit().t_test(weights[None, :])
    return (
        float(test.effect[0]),
        float(test.sd[0, 0]),
        float(test.df_denom),
        float(test.tvalue[0, 0]),
        float(test.pvalue),
    )


def _difference(levels: list, a, b) -> np.ndarray:
    return np.array([1.0 if g == a else -1.0 if g == b else 0.0 for g in levels])


def _family(rows: list) -> pd.DataFrame:
    table = pd.DataFrame(
        [(factor, at, a, b, *result) for factor, at, a, b, result in rows],
        columns=["factor", "at", "A", "B", "estimate", "SE", "df", "T", "p_unc"],
    )
    table["at"] = table["at"].astype(object)
    table["p_bonf"] = pg.multicomp(table["p_unc"].to_numpy(), method="bonf")[1]
    table["stars"] = table["p_bonf"].map(stars)
    for suffix, level in (("", CONFIDENCE), ("_bonf", 1 - (1 - CONFIDENCE) / len(table))):
        margin = stats.t.ppf((1 + level) / 2, table["df"]) * table["SE"]
        table[f"ci_low{suffix}"] = table["estimate"] - margin
        table[f"ci_high{suffix}"] = table["estimate"] + margin
    return table
