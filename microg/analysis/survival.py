"""Time to an event with censoring (tasks to a proficiency criterion, a trainee who reaches the bound
without it censored there): Kaplan-Meier curves, median times with confidence intervals and the
log-rank test, with the numbers R's survival package gives.

The risk sets and the log-rank test come from statsmodels (``SurvfuncRight``: the event times, the
numbers at risk and the events; ``survdiff``). The estimate is the product over the event times of
1 - events / at risk, as R's ``survfit`` multiplies it (statsmodels sums logs, which puts a curve that
is exactly 0.5 a rounding error away from it and moves the median), with Greenwood's variance. Two
more things are R's rules, written here because no maintained Python package follows them: the
pointwise confidence band is R's ``survfit`` default,
``conf.type = "log"`` (S exp(+-z se(log S)), the upper bound capped at 1), and the median and its
interval are read off the curve and the band as R's ``quantile.survfit`` reads them: where a curve
sits exactly at 0.5 over an interval of time, the median is the middle of that interval (statsmodels
and lifelines take its start), and the interval's limits are where the band's bounds cross 0.5
(statsmodels' ``quantile_ci`` inverts a test instead, as SAS does).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats
from statsmodels.duration.survfunc import SurvfuncRight, survdiff

from microg.analysis.anova import CONFIDENCE
from microg.analysis.tables import AnalysisInputError

KAPLAN_MEIER_COLUMNS = ("time", "n_risk", "n_event", "surv", "se", "ci_low", "ci_high")
MEDIAN_COLUMNS = ("n", "events", "median", "ci_low", "ci_high")
LOGRANK_COLUMNS = ("chi2", "df", "p_unc", "n", "events")
TOLERANCE = np.sqrt(np.finfo(float).eps)
"""R's ``quantile.survfit`` tolerance: a curve within this of the probability sits on it."""


def kaplan_meier(data: pd.DataFrame, time: str, event: str, group: str | None = None,
                 confidence: float = CONFIDENCE) -> pd.DataFrame:
    """Kaplan-Meier estimate of surviving (not yet having the event) at each event time, with its
    pointwise confidence band, as R's ``survfit(Surv(time, event) ~ group)`` (``conf.type = "log"``).

    Parameters
    ----------
    data : pandas.DataFrame
        One row per individual.
    time : str
        Column of the time of the event, or of censoring (the last time seen without it).
    event : str
        Column of True (the event happened at ``time``) or False (censored at ``time``).
    group : str, optional
        Column of the groups: one curve each (sorted).
    confidence : float
        Level of the pointwise band.

    Returns
    -------
    pandas.DataFrame
        One row per group and event time (R's ``summary(fit)``): ``group`` (when given), time, n_risk
        (at risk just before it), n_event, surv (the estimate), se (Greenwood's standard error of
        surv), ci_low and ci_high (surv exp(-+z se / surv), the upper capped at 1; empty where surv
        is 0).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.survival import kaplan_meier
    >>> data = pd.DataFrame({"tasks": [3, 5, 5, 8, 10, 10], "met": [True, True, False, True, False, False]})
    >>> kaplan_meier(data, "tasks", "met").round(4)
       time  n_risk  n_event    surv      se  ci_low  ci_high
    0     3       6        1  0.8333  0.1521  0.5827      1.0
    1     5       5        1  0.6667  0.1925  0.3786      1.0
    2     8       3        1  0.4444  0.2222  0.1668      1.0
    """
    rows = []
    z = stats.norm.ppf((1 + confidence) / 2)
    for name, part in _groups(data, time, event, group):
        curve = _curve(part, time, event)
        at_risk, events = curve.n_risk.astype(float), curve.n_events.astype(float)
        surv = np.cumprod(1 - events / at_risk)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_se = np.sqrt(np.cumsum(events / (at_risk * (at_risk - events))))  # Greenwood's, of log S
            log_se[surv == 0] = np.nan
            low = surv * np.exp(-z * log_se)
            high = np.minimum(surv * np.exp(z * log_se), 1.0)
        table = pd.DataFrame({"time": curve.surv_times, "n_risk": curve.n_risk.astype(int),
                              "n_event": curve.n_events.astype(int), "surv": surv, "se": surv * log_se,
                              "ci_low": low, "ci_high": high})  # fmt: skip
        if pd.api.types.is_integer_dtype(part[time]):
            table["time"] = table["time"].astype(part[time].dtype)
        rows.append(table if group is None else table.assign(**{group: name})[[group, *KAPLAN_MEIER_COLUMNS]])
    columns = list(KAPLAN_MEIER_COLUMNS) if group is None else [group, *KAPLAN_MEIER_COLUMNS]
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=columns)


def median_survival(data: pd.DataFrame, time: str, event: str, group: str | None = None,
                    confidence: float = CONFIDENCE) -> pd.DataFrame:
    """Median time to the event with its confidence interval, per group, as R's
    ``quantile(survfit(...), 0.5)`` (``conf.type = "log"``).

    The median is the first time the Kaplan-Meier curve falls below 0.5, or the middle of the
    interval over which it sits at 0.5; the interval's limits are the same reading of the band's
    upper and lower bound (:func:`kaplan_meier`). A curve, or a bound, that never reaches 0.5 has no
    median, or no limit, there (empty: "not reached").

    Parameters
    ----------
    data, time, event, group, confidence
        As for :func:`kaplan_meier`.

    Returns
    -------
    pandas.DataFrame
        One row per group: ``group`` (when given), n, events, median, ci_low, ci_high.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.survival import median_survival
    >>> data = pd.DataFrame({"tasks": [2, 3, 3, 4, 6, 6, 7, 9], "met": [True] * 6 + [False, True]})
    >>> median_survival(data, "tasks", "met")
       n  events  median  ci_low  ci_high
    0  8       7     5.0     3.0      NaN
    """
    rows = []
    for name, part in _groups(data, time, event, group):
        band = kaplan_meier(part, time, event, confidence=confidence)
        last = float(part[time].max())
        quantiles = [_r_quantile(band["time"].to_numpy(float), band[column].to_numpy(float), last)
                     for column in ("surv", "ci_low", "ci_high")]
        row = {"n": len(part), "events": int(part[event].sum()), "median": quantiles[0], "ci_low": quantiles[1],
               "ci_high": quantiles[2]}  # fmt: skip
        rows.append(row if group is None else {group: name, **row})
    columns = list(MEDIAN_COLUMNS) if group is None else [group, *MEDIAN_COLUMNS]
    return pd.DataFrame(rows, columns=columns)


def logrank(data: pd.DataFrame, time: str, event: str, group: str) -> pd.DataFrame:
    """Log-rank test of equal survival in the groups, as R's ``survdiff(Surv(time, event) ~ group)``.

    Parameters
    ----------
    data, time, event
        As for :func:`kaplan_meier`.
    group : str
        Column of the groups compared (two or more).

    Returns
    -------
    pandas.DataFrame
        One row: chi2, df (groups - 1), p_unc, n and events.

    Raises
    ------
    AnalysisInputError
        With fewer than two groups, or no event at all (nothing to compare).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.survival import logrank
    >>> data = pd.DataFrame({"tasks": [2, 3, 4, 4, 5, 7, 8, 9, 10, 10], "met": [True] * 8 + [False] * 2,
    ...                      "group": ["P"] * 5 + ["B"] * 5})
    >>> logrank(data, "tasks", "met", "group").round(4)
         chi2  df   p_unc   n  events
    0  9.4957   1  0.0021  10       8
    """
    groups = sorted(data[group].unique())
    events = int(data[event].sum())
    if len(groups) < 2 or events == 0:
        raise AnalysisInputError(f"log-rank test: {len(groups)} group(s) in column {group!r} and {events} event(s) "
                                 f"in column {event!r}: it needs two groups and an event")
    chi2, p = survdiff(data[time].to_numpy(float), data[event].to_numpy(float), data[group].astype(str).to_numpy())
    return pd.DataFrame([(float(chi2), len(groups) - 1, float(p), len(data), events)], columns=list(LOGRANK_COLUMNS))


def _groups(data: pd.DataFrame, time: str, event: str, group: str | None):
    missing = [column for column in (time, event, *([group] if group else [])) if column not in data.columns]
    if missing:
        raise AnalysisInputError(f"survival: missing column {missing[0]!r} (columns: {', '.join(data.columns)})")
    if group is None:
        return [(None, data)]
    return list(data.groupby(group, sort=True, observed=True))


def _curve(part: pd.DataFrame, time: str, event: str) -> SurvfuncRight:
    return SurvfuncRight(part[time].to_numpy(float), part[event].to_numpy(float))


def _r_quantile(times: np.ndarray, surv: np.ndarray, last: float, p: float = 0.5) -> float:
    """Where a survival curve (or a bound of its band), given at ``times``, reaches 1 - ``p``: R
    survival's ``findq`` on (0, times) and (0, 1 - surv); ``last`` is the last time observed."""
    x = np.concatenate([[0.0], np.asarray(times, float)])
    y = np.concatenate([[0.0], 1 - np.asarray(surv, float)])
    first = ~pd.Series(y).duplicated().to_numpy()  # R's duplicated(): a repeated NA is a duplicate too
    x, y = x[first], y[first]
    if np.all(np.isnan(y)) or np.nanmax(y) < p:
        return np.nan
    known = np.flatnonzero(~np.isnan(y))

    def first_reaching(shift: float) -> float:
        """R's approx(y + shift, 1:n, p, method = "constant", f = 1): the first point at or past p."""
        abscissa = y[known] + shift
        if p < abscissa[0] or p > abscissa[-1]:
            return np.nan
        return float(x[known[np.searchsorted(abscissa, p, side="left")]])

    quantile = (first_reaching(TOLERANCE) + first_reaching(-TOLERANCE)) / 2
    if not np.isnan(y[-1]) and abs(p - y[-1]) < TOLERANCE:
        quantile = (first_reaching(TOLERANCE) + last) / 2
    return quantile
