"""The 11-point Likert items: distribution per item and system, and the paired Wilcoxon signed-rank
test of system vs baseline per item with effect size r, Bonferroni-corrected across items."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pingouin as pg

from microg.analysis.paired import signed_rank
from microg.analysis.tables import RATING_RANGE, stars

SCALE = tuple(range(RATING_RANGE[0], RATING_RANGE[1] + 1))
LIKERT_TEST_COLUMNS = (
    "item", "system", "baseline", "n", "median_system", "median_baseline",
    "V", "p_unc", "p_bonf", "z", "r", "rbc", "stars",
)  # fmt: skip


def likert_summary(
    answers: pd.DataFrame, item: str = "item", system: str = "system", rating: str = "rating"
) -> pd.DataFrame:
    """Per item and system: n, median, quartiles (linear interpolation, R's default), IQR, mean, and
    the count of each rating 0-10 in columns ``count_0`` ... ``count_10``."""
    rows = []
    for (item_name, system_name), values in answers.groupby([item, system], sort=True)[rating]:
        q1, median, q3 = np.percentile(values, [25, 50, 75])
        counts = values.value_counts().reindex(SCALE, fill_value=0)
        rows.append(
            {
                "item": item_name,
                "system": system_name,
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
    system: str,
    baseline: str,
    subject: str = "participant",
    item: str = "item",
    system_column: str = "system",
    rating: str = "rating",
) -> pd.DataFrame:
    """Per item: Wilcoxon signed-rank test of ``system`` vs ``baseline`` ratings of the same
    participants (those who rated both), r = z / sqrt(n non-zero differences), and the p-value
    Bonferroni-corrected across items; columns LIKERT_TEST_COLUMNS."""
    rows = []
    for item_name, ratings in answers.groupby(item, sort=True):
        wide = ratings.pivot(index=subject, columns=system_column, values=rating)
        pairs = wide.reindex(columns=[system, baseline]).dropna()
        test = signed_rank(pairs[system].to_numpy(), pairs[baseline].to_numpy())
        rows.append(
            {
                "item": item_name,
                "system": system,
                "baseline": baseline,
                "n": test.n,
                "median_system": pairs[system].median(),
                "median_baseline": pairs[baseline].median(),
                "V": test.V,
                "p_unc": test.p,
                "z": test.z,
                "r": test.r,
                "rbc": test.rbc,
            }
        )
    table = pd.DataFrame(rows)
    table["p_bonf"] = pg.multicomp(table["p_unc"].to_numpy(), method="bonf")[1]
    table["stars"] = table["p_bonf"].map(stars)
    return table[list(LIKERT_TEST_COLUMNS)]


def unpaired_raters(
    answers: pd.DataFrame, system: str, baseline: str, subject: str = "participant", item: str = "item"
) -> pd.DataFrame:
    """Participants left out of an item's test because they rated it for only one of the systems."""
    rated = answers[answers["system"].isin([system, baseline])]
    per_item = rated.groupby([item, subject])["system"].agg(set)
    missing = per_item[per_item.map(len) < 2]
    rows = [(who, f"rated {item_name} only for {next(iter(systems))}") for (item_name, who), systems in missing.items()]
    return pd.DataFrame(rows, columns=["participant", "reason"])
