"""The aligned rank transform (ART) for ordinal measures such as Likert ratings, with the numbers R's
ARTool reports.

A rating scale is ordinal: its steps need not be equal, so an ANOVA of the ratings themselves is
suspect, and the signed-rank test compares only two conditions at a time. The ART (Wobbrock,
Findlater, Gergle and Higgins, CHI 2011) keeps the factorial design: for each effect, every value
is *aligned* (its residual from its cell mean plus the effect's estimate, the alternating sum of
the marginal means of the effect's factors) so that only that effect remains, the aligned values
are ranked, and the full-factorial ANOVA of the ranks is read for that effect alone. Ties are
averaged; values are rounded to 8 decimals before ranking, as ARTool does, so that rounding noise
does not split ties. The ANOVA of the ranks is the report's mixed ANOVA (:func:`mixed_anova`).

Post hoc contrasts use ART-C (Elkin, Kay, Higgins and Wobbrock, UIST 2021): the aligned ranks of
one effect cannot be compared cell by cell, so for contrasts between the cells of a crossed term
the term's factors are joined into one factor and the data aligned and ranked for it (ARTool's
``art.con``; in a two-factor design these are the ranks of the values themselves); contrasts of a
main effect use that effect's aligned ranks. The contrasts are then tested as the report's post hoc
tests are (emmeans on afex's multivariate model of the wide data: the pooled within-group
covariance, N - groups df), Bonferroni over the term's pairs. ARTool's own ``art.con`` tests them
in a mixed model (``lmer``) or a stratified ANOVA (``aov``): on unbalanced groups the mixed model of
aligned ranks is singular (the subjects' variance estimated at 0), emmeans' Satterthwaite df for it
can fall below 1, and the stratified model misestimates comparisons between groups; the
multivariate model has none of these troubles and is the one the report's ANOVA rests on.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import stats

from microg.analysis.anova import mixed_anova, wide_complete
from microg.analysis.tables import stars

ART_COLUMNS = ("source", "F", "df1", "df2", "p_unc")
ART_CONTRAST_COLUMNS = ("term", "A", "B", "estimate", "SE", "df", "T", "p_unc", "p_bonf", "stars")
RANK_DIGITS = 8
"""Aligned values are rounded to this many decimals before ranking (ARTool's default, the digits of
the square root of the machine epsilon)."""
CELL_SEPARATOR = ","
"""How ART-C names a cell of a crossed term: its levels joined, as ARTool does ("V,impulse_penetration")."""


def art_anova(
    data: pd.DataFrame, dv: str, within: str, between: str, subject: str, ss_type: int = 3
) -> pd.DataFrame:
    """Aligned rank transform ANOVA of ``dv`` with one between and one within factor.

    Parameters
    ----------
    data : pandas.DataFrame
        Long table: one row per subject and ``within`` level (several rows are averaged); subjects
        missing a level are dropped with a warning that names them (complete cases, as
        :func:`microg.analysis.mixed_anova`).
    dv, within, between, subject : str
        Columns of the measure (ordinal or not), the within factor, the between factor and the subject.
    ss_type : {3, 2}
        Sums of squares of the ANOVA of the ranks. Type 2 equals ARTool's repeated-measures ANOVA
        (``art(y ~ between * within + Error(subject))``: sequential sums of squares per stratum);
        type 3 (the report's default) its mixed model (``(1 | subject)``), which differs from type 2
        only for the within effect when the groups are unequal.

    Returns
    -------
    pandas.DataFrame
        One row per source, named as :func:`microg.analysis.mixed_anova` names them (``between``,
        ``within``, ``between:within``); columns ART_COLUMNS (F, its df and p, uncorrected: the ranks
        of aligned values are not tested for sphericity).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import art_anova
    >>> ratings = pd.DataFrame({"p": [f"P{i}" for i in range(8) for _ in range(2)],
    ...                         "g": ["V"] * 8 + ["B"] * 8, "tool": ["ours", "base"] * 8,
    ...                         "rating": [8, 5, 7, 5, 9, 4, 6, 6, 7, 3, 6, 2, 8, 3, 5, 4]})
    >>> art_anova(ratings, "rating", "tool", "g", "p").round(3)
       source       F  df1  df2  p_unc
    0       g  16.794    1    6  0.006
    1    tool  24.774    1    6  0.003
    2  g:tool   0.483    1    6  0.513
    """
    long = _complete(data, dv, within, between, subject)
    factors = [between, within]
    ranks = aligned_ranks(long, dv, factors)
    rows = []
    for source in (between, within, f"{between}:{within}"):
        anova = mixed_anova(long.assign(**{dv: ranks[source]}), dv, within, between, subject, ss_type)
        rows.append(anova.set_index("source").loc[source, ["F", "df1", "df2", "p_unc"]])
    table = pd.DataFrame(rows).rename_axis("source").reset_index()
    return table.astype({"df1": int, "df2": int})[list(ART_COLUMNS)]


def art_contrasts(data: pd.DataFrame, dv: str, within: str, between: str, subject: str, term: str) -> pd.DataFrame:
    """ART-C contrasts: every pair of levels of ``term`` (a factor, or the crossed ``between:within``).

    Parameters
    ----------
    data, dv, within, between, subject
        As for :func:`art_anova`.
    term : str
        ``between`` (pairs of groups, averaged over the within levels), ``within`` (pairs of levels,
        averaged over the groups with equal weights) or ``f"{between}:{within}"`` (pairs of cells,
        each named ``"<between level>,<within level>"``).

    Returns
    -------
    pandas.DataFrame
        Columns ART_CONTRAST_COLUMNS: the pair A, B (estimate = A - B, in ranks), its SE, df, T, the
        uncorrected and the Bonferroni p (over the term's pairs) and stars.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import art_contrasts
    >>> ratings = pd.DataFrame({"p": [f"P{i}" for i in range(8) for _ in range(2)],
    ...                         "g": ["V"] * 8 + ["B"] * 8, "tool": ["ours", "base"] * 8,
    ...                         "rating": [8, 5, 7, 5, 9, 4, 6, 6, 7, 3, 6, 2, 8, 3, 5, 4]})
    >>> art_contrasts(ratings, "rating", "tool", "g", "p", "g:tool")[["A", "B", "estimate", "p_bonf"]].round(3)
            A       B  estimate  p_bonf
    0  B,base  B,ours    -8.375   0.057
    1  B,base  V,base    -4.500   0.090
    2  B,base  V,ours   -10.625   0.005
    3  B,ours  V,base     3.875   0.409
    4  B,ours  V,ours    -2.250   1.000
    5  V,base  V,ours    -6.125   0.201
    """
    long = _complete(data, dv, within, between, subject)
    crossed = f"{between}:{within}"
    if term not in (between, within, crossed):
        raise ValueError(f"term must be {between!r}, {within!r} or {crossed!r}, not {term!r}")
    if term == crossed:  # ART-C: the crossed term's factors joined into one, aligned and ranked for it
        joined = long[between].astype(str) + CELL_SEPARATOR + long[within].astype(str)
        ranks = aligned_ranks(long.assign(**{crossed: joined}), dv, [crossed])[crossed]
    else:
        ranks = aligned_ranks(long, dv, [between, within])[term]
    wide, groups = wide_complete(long.assign(**{dv: ranks}), dv, within, between, subject)
    group_levels, levels = sorted(set(groups)), list(wide.columns)
    weights = {}  # each level of the term as weights on the group x level cell means
    if term == between:
        for g in group_levels:
            weights[g] = np.outer(np.array(group_levels) == g, np.full(len(levels), 1 / len(levels)))
    elif term == within:
        for level in levels:
            weights[level] = np.outer(np.full(len(group_levels), 1 / len(group_levels)), np.array(levels) == level)
    else:
        for g in group_levels:
            for level in levels:
                weights[f"{g}{CELL_SEPARATOR}{level}"] = np.outer(np.array(group_levels) == g, np.array(levels) == level) * 1.0
    values = wide.to_numpy(float)
    sizes = np.array([np.sum(groups == g) for g in group_levels])
    means = np.array([values[groups == g].mean(axis=0) for g in group_levels])
    residuals = values - means[np.searchsorted(group_levels, groups)]
    df = len(values) - len(group_levels)
    covariance = residuals.T @ residuals / df
    rows = []
    for a, b in combinations(sorted(weights), 2):
        contrast = weights[a] - weights[b]
        variance = sum(c @ covariance @ c / n for c, n in zip(contrast, sizes))
        rows.append((term, a, b, float(np.sum(contrast * means)), float(np.sqrt(variance)), float(df)))
    table = pd.DataFrame(rows, columns=["term", "A", "B", "estimate", "SE", "df"])
    table["T"] = table["estimate"] / table["SE"]
    table["p_unc"] = 2 * stats.t.sf(table["T"].abs(), table["df"])
    table["p_bonf"] = pg.multicomp(table["p_unc"].to_numpy(), method="bonf")[1]
    table["stars"] = table["p_bonf"].map(stars)
    return table[list(ART_CONTRAST_COLUMNS)]


def aligned_ranks(data: pd.DataFrame, dv: str, factors: list[str]) -> pd.DataFrame:
    """For each effect of the full factorial of ``factors`` (named as ``a``, ``b``, ``a:b``), the
    ranks of the values aligned for it: value - cell mean + the effect's estimate, the estimate being
    the alternating sum of the marginal means (over the data's rows) of every subset of the effect's
    factors, as ARTool's ``art``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.art import aligned_ranks
    >>> data = pd.DataFrame({"a": ["x", "x", "y", "y"], "b": ["u", "v", "u", "v"], "y": [1.0, 4.0, 2.0, 9.0]})
    >>> aligned_ranks(data, "y", ["a", "b"])["a:b"].tolist()
    [3.5, 1.5, 1.5, 3.5]
    """
    values = data[dv].to_numpy(float)
    keys = {name: data[name].astype(str).to_numpy() for name in factors}

    def mean_over(names) -> np.ndarray:
        if not names:
            return np.full(len(values), values.mean())
        frame = pd.DataFrame({name: keys[name] for name in names}).assign(value=values)
        return frame.groupby(list(names), sort=False)["value"].transform("mean").to_numpy()

    residuals = values - mean_over(factors)
    ranks = {}
    for size in range(1, len(factors) + 1):
        for effect in combinations(factors, size):
            estimate = sum((-1) ** (len(effect) - len(part)) * mean_over(list(part))
                           for order in range(len(effect) + 1) for part in combinations(effect, order))  # fmt: skip
            aligned = np.round(residuals + estimate, RANK_DIGITS)
            ranks[":".join(effect)] = stats.rankdata(aligned, method="average")
    return pd.DataFrame(ranks, index=data.index)


def _complete(data: pd.DataFrame, dv: str, within: str, between: str, subject: str) -> pd.DataFrame:
    """The complete cases in long form, one row per subject and level (as mixed_anova reads them)."""
    wide, groups = wide_complete(data, dv, within, between, subject)
    long = wide.assign(**{between: groups}).reset_index()
    long = long.melt(id_vars=[subject, between], var_name=within, value_name=dv)
    return long.sort_values([subject, within], kind="stable").reset_index(drop=True)
