"""The 11-point Likert items: distribution per item and interaction model, and the paired Wilcoxon signed-rank
test of interaction vs baseline per item with effect sizes, Bonferroni-corrected across items."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg

from microg.analysis.paired import signed_rank
from microg.analysis.tables import RATING_RANGE, stars

SCALE = tuple(range(RATING_RANGE[0], RATING_RANGE[1] + 1))
LIKERT_TEST_COLUMNS = (
    "item", "interaction", "baseline", "n", "median_interaction", "median_baseline",
    "V", "p_unc", "p_bonf", "z", "r", "rbc", "stars", "rbc_ci_low", "rbc_ci_high",
)  # fmt: skip


def likert_summary(
    answers: pd.DataFrame, item: str = "item", interaction: str = "interaction", rating: str = "rating"
) -> pd.DataFrame:
    """The distribution of the ratings per item and interaction model.

    Parameters
    ----------
    answers : pandas.DataFrame
        One row per rating.
    item, interaction, rating : str
        Columns of the item, the interaction model rated and the rating (0-10).

    Returns
    -------
    pandas.DataFrame
        Per ``item`` and ``interaction``: n, median, quartiles q1 and q3 (linear interpolation, R's
        default), iqr, mean, and the count of each rating 0-10 in ``count_0`` ... ``count_10``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import likert_summary
    >>> answers = pd.DataFrame({"item": "ease", "interaction": "s", "rating": [3, 7, 8, 8]})
    >>> likert_summary(answers)[["item", "interaction", "n", "median", "q1", "q3", "count_8"]]
       item interaction  n  median   q1   q3  count_8
    0  ease           s  4     7.5  6.0  8.0        2
    """
    rows = []
    for (item_name, interaction_name), values in answers.groupby([item, interaction], sort=True)[rating]:
        q1, median, q3 = np.percentile(values, [25, 50, 75])
        counts = values.value_counts().reindex(SCALE, fill_value=0)
        rows.append(
            {
                item: item_name,
                interaction: interaction_name,
                "n": len(values),
                "median": median,
                "q1": q1,
                "q3": q3,
                "iqr": q3 - q1,
                "mean": values.mean(),
                **{f"count_{score}": int(counts[score]) for score in SCALE},
            }
        )
    return pd.DataFrame(rows)


def likert_tests(
    answers: pd.DataFrame,
    interaction: str,
    baseline: str,
    subject: str = "participant",
    item: str = "item",
    interaction_column: str = "interaction",
    rating: str = "rating",
) -> pd.DataFrame:
    """Per item, the Wilcoxon signed-rank test of ``interaction`` vs ``baseline`` on the same raters.

    Only participants who rated the item for both interaction models count (:func:`unpaired_raters` lists the
    others). The p-value is Bonferroni-corrected across items.

    Parameters
    ----------
    answers : pandas.DataFrame
        One row per participant, interaction model and item.
    interaction, baseline : str
        The interaction models compared (values of ``interaction_column``).
    subject, item, interaction_column, rating : str
        The column names.

    Returns
    -------
    pandas.DataFrame
        Columns LIKERT_TEST_COLUMNS: n pairs, the medians, V, p_unc, p_bonf, z, r = z / sqrt(n
        non-zero differences), the rank-biserial correlation rbc with its 95 % CI, stars.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import likert_tests
    >>> answers = pd.DataFrame({"participant": [f"P{i}" for i in range(6)] * 2, "item": "ease",
    ...                         "interaction": ["s"] * 6 + ["b"] * 6, "rating": [8, 7, 9, 6, 8, 7, 4, 5, 3, 6, 2, 5]})
    >>> likert_tests(answers, "s", "b")[["item", "n", "V", "p_bonf", "rbc"]].round(3)
       item  n     V  p_bonf  rbc
    0  ease  6  15.0   0.057  1.0
    """
    rows = []
    for item_name, ratings in answers.groupby(item, sort=True):
        wide = ratings.pivot(index=subject, columns=interaction_column, values=rating)
        pairs = wide.reindex(columns=[interaction, baseline]).dropna()
        test = signed_rank(pairs[interaction].to_numpy(), pairs[baseline].to_numpy()).iloc[0]
        rows.append(
            {
                "item": item_name,
                "interaction": interaction,
                "baseline": baseline,
                "n": int(test["n"]),
                "median_interaction": pairs[interaction].median(),
                "median_baseline": pairs[baseline].median(),
                "V": test["V"],
                "p_unc": test["p"],
                "z": test["z"],
                "r": test["r"],
                "rbc": test["rbc"],
                "rbc_ci_low": test["rbc_ci_low"],
                "rbc_ci_high": test["rbc_ci_high"],
            }
        )
    table = pd.DataFrame(rows)
    table["p_bonf"] = pg.multicomp(table["p_unc"].to_numpy(), method="bonf")[1]
    table["stars"] = table["p_bonf"].map(stars)
    return table[list(LIKERT_TEST_COLUMNS)]


def unpaired_raters(
    answers: pd.DataFrame,
    interaction: str,
    baseline: str,
    subject: str = "participant",
    item: str = "item",
    interaction_column: str = "interaction",
) -> pd.DataFrame:
    """Participants left out of an item's test because they rated it for only one of the interaction models.

    Parameters
    ----------
    answers, interaction, baseline, subject, item, interaction_column
        As for :func:`likert_tests`.

    Returns
    -------
    pandas.DataFrame
        Columns ``subject`` and ``reason``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import unpaired_raters
    >>> answers = pd.DataFrame({"who": ["a", "a", "b"], "question": "ease", "tool": ["s", "b", "s"],
    ...                         "rating": [7, 5, 6]})
    >>> unpaired_raters(answers, "s", "b", subject="who", item="question", interaction_column="tool")
      who                 reason
    0   b  rated ease only for s
    """
    rated = answers[answers[interaction_column].isin([interaction, baseline])]
    per_item = rated.groupby([item, subject])[interaction_column].agg(set)
    missing = per_item[per_item.map(len) < 2]
    rows = [(who, f"rated {name} only for {next(iter(interactions))}") for (name, who), interactions in missing.items()]
    return pd.DataFrame(rows, columns=[subject, "reason"])
