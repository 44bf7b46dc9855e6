"""Bonferroni-corrected post hoc comparisons for the mixed design, as R's emmeans computes them on
afex's multivariate model.

Each comparison is a linear contrast of the group-by-level cell means, tested against the pooled
within-group (co)variance with N - (number of groups) degrees of freedom. Both kinds reduce to an
ordinary least-squares fit on the groups (cell-means coding) of one column derived from the wide data:
- levels of the within factor, averaged over groups with equal weights: the per-subject difference
  between the two levels, contrast = the mean of its group means (emmeans' ``pairs(emmeans(fit, ~ object))``);
- groups at one level of the within factor: that level's values, contrast = the difference of the two
  group means (emmeans' ``pairs(emmeans(fit, ~ group | object))``).
A paired t-test that ignores the groups (pingouin's pairwise_tests) uses a different variance and df
and can reach a different conclusion. The Bonferroni family is all comparisons of one kind: all level
pairs, or all group pairs across all levels (emmeans with ``by = NULL``).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd
import pingouin as pg
import statsmodels.api as sm

from microg.analysis.anova import wide_complete
from microg.analysis.tables import stars

POSTHOC_COLUMNS = ("factor", "at", "A", "B", "estimate", "SE", "df", "T", "p_unc", "p_bonf", "stars")


def posthoc(data: pd.DataFrame, dv: str, within: str, between: str, subject: str) -> pd.DataFrame:
    """Pairwise comparisons of the ``within`` levels (averaged over groups) and of the groups at each
    ``within`` level; estimate is A - B; columns POSTHOC_COLUMNS. Subjects missing a cell are dropped
    (with a warning), as in :func:`microg.analysis.anova.mixed_anova`."""
    wide, groups = wide_complete(data, dv, within, between, subject)
    group_levels = sorted(set(groups))
    design = np.column_stack([(groups == g).astype(float) for g in group_levels])
    equal_weights = np.full(len(group_levels), 1 / len(group_levels))

    level_rows = [
        (within, np.nan, a, b, _contrast(wide[a] - wide[b], design, equal_weights))
        for a, b in combinations(wide.columns, 2)
    ]
    group_rows = [
        (between, level, a, b, _contrast(wide[level], design, _difference(group_levels, a, b)))
        for level in wide.columns
        for a, b in combinations(group_levels, 2)
    ]
    frames = [_family(rows) for rows in (level_rows, group_rows)]
    return pd.concat(frames, ignore_index=True)[list(POSTHOC_COLUMNS)]


def _contrast(values: pd.Series, design: np.ndarray, weights: np.ndarray) -> tuple[float, float, float, float, float]:
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


POSTHOC_COLUMNS = ("factor", "at", "A", "B", "estimate", "SE", "df", "T", "p_unc", "p_bonf", "stars")


def _family(rows: list) -> pd.DataFrame:
    table = pd.DataFrame(
        [(factor, at, a, b, *result) for factor, at, a, b, result in rows],
        columns=list(POSTHOC_COLUMNS[:-2]),
    )
    table["at"] = table["at"].astype(object)
    table["p_bonf"] = pg.multicomp(table["p_unc"].to_numpy(), method="bonf")[1]
    table["stars"] = table["p_bonf"].map(stars)
    return table
