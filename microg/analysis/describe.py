"""Descriptive statistics of the participant-level cells: what a reader needs beside every test."""

from __future__ import annotations

import pandas as pd

CELL_MEANS_COLUMNS = ("n", "mean", "sd", "se", "share_zero")


def cell_means(data: pd.DataFrame, dv: str, within: str, between: str) -> pd.DataFrame:
    """Mean, SD, SE and n of ``dv`` per ``between`` x ``within`` cell, and the share of zeros.

    Parameters
    ----------
    data : pandas.DataFrame
        Long table, one row per participant and ``within`` level (the cells the ANOVA used).
    dv, within, between : str
        Columns of the measure, the within factor and the between factor.

    Returns
    -------
    pandas.DataFrame
        Columns ``between, within`` and CELL_MEANS_COLUMNS: n participants, mean, sample SD, SE of
        the mean, and share_zero, the share of participants whose value is 0 (how sparse a count
        such as drops is).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import cell_means
    >>> cells = pd.DataFrame({"group": ["V", "V", "B", "B"], "object": "cube", "attempts": [0.0, 2.0, 0.0, 0.0]})
    >>> cell_means(cells, "attempts", "object", "group").round(3)
      group object  n  mean     sd   se  share_zero
    0     B   cube  2   0.0  0.000  0.0         1.0
    1     V   cube  2   1.0  1.414  1.0         0.5
    """
    grouped = data.groupby([between, within], observed=True, sort=True)[dv]
    table = grouped.agg(n="count", mean="mean", sd="std", se="sem").reset_index()
    table["share_zero"] = grouped.apply(lambda values: float((values == 0).mean())).to_numpy()
    return table
