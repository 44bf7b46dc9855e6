"""The report's figures: bars per object and group with every participant's value and significance
marks (the paper's Fig. 11), the diverging stacked rating distribution (the paper's Fig. 12),
each instrument's scores per administration and interaction model with every participant's score,
and a training program's learning curves and curves of reaching the criterion."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MaxNLocator

from microg.analysis.likert import SCALE

NEUTRAL = 5
GROUP_COLOURS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3")


def plot_bars(
    cells: pd.DataFrame,
    dv: str,
    posthoc: pd.DataFrame,
    within: str = "object",
    between: str = "group",
    ylabel: str | None = None,
    title: str | None = None,
    order: Sequence[str] | None = None,
) -> Figure:
    """Bars of the mean +- SE of ``dv`` per ``within`` level and group, every participant's value a dot.

    Brackets with stars mark the Bonferroni-significant post hoc comparisons (groups at a level,
    and levels); the legend gives n per group.

    Parameters
    ----------
    cells : pandas.DataFrame
        One row per participant and ``within`` level (the cells the ANOVA used).
    dv, within, between : str
        Columns of the measure, the within factor and the between factor.
    posthoc : pandas.DataFrame
        :func:`microg.analysis.posthoc` of the same cells.
    ylabel, title : str, optional
        Axis label (default ``dv``) and title.
    order : sequence of str, optional
        The ``within`` levels from left to right (default: sorted), e.g. sessions in their order.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import plot_bars, posthoc
    >>> data = pg.read_dataset("mixed_anova")
    >>> fig = plot_bars(data, "Scores", posthoc(data, "Scores", "Time", "Group", "Subject"), "Time", "Group")
    >>> [text.get_text() for text in fig.axes[0].get_legend().get_texts()]
    ['Control (n = 30)', 'Meditation (n = 30)']
    """
    summary = cells.groupby([within, between], observed=True)[dv].agg(["mean", "sem", "count", "max"])
    levels = list(order) if order is not None else sorted(cells[within].unique())
    groups = sorted(cells[between].unique())
    width = 0.8 / len(groups)
    fig = Figure(figsize=(2.6 + 1.5 * len(levels), 3.6), layout="constrained")
    ax = fig.subplots()
    tops, centres = {}, {}
    for g_index, group in enumerate(groups):
        colour = GROUP_COLOURS[g_index % len(GROUP_COLOURS)]
        for l_index, level in enumerate(levels):
            x = l_index + (g_index - (len(groups) - 1) / 2) * width
            mean, sem, count, highest = summary.loc[(level, group), ["mean", "sem", "count", "max"]]
            sem = 0.0 if np.isnan(sem) else sem
            label = f"{group} (n = {int(count)})" if l_index == 0 else None
            ax.bar(x, mean, width * 0.95, yerr=sem, capsize=3, color=colour, alpha=0.55, label=label, zorder=1)
            values = np.sort(cells.loc[(cells[within] == level) & (cells[between] == group), dv].to_numpy(float))
            ax.scatter(x + _spread(len(values), width * 0.6), values, s=9, color=colour, edgecolor="black",
                       linewidth=0.4, zorder=2)  # fmt: skip
            centres[(level, group)] = x
            tops[(level, group)] = max(mean + sem, highest)
    span = max(max(tops.values()), 1e-9)
    step = 0.07 * span
    level_tops = {level: max(tops[(level, g)] for g in groups) for level in levels}
    marks = posthoc[posthoc["stars"] != ""]
    for row in marks[marks["factor"] == between].itertuples(index=False):
        height = level_tops[row.at] + step
        _bracket(ax, centres[(row.at, row.A)], centres[(row.at, row.B)], height, step, row.stars)
        level_tops[row.at] = height + 2 * step
    ceiling = max(level_tops.values())
    for row in marks[(marks["factor"] == within) & marks["at"].isna()].itertuples(index=False):
        a, b = levels.index(row.A), levels.index(row.B)
        height = max(level_tops[lv] for lv in levels[min(a, b) : max(a, b) + 1]) + step
        height = max(height, ceiling)
        _bracket(ax, a, b, height, step, row.stars)
        ceiling = height + 2 * step
    ax.set_xticks(range(len(levels)), levels)
    ax.set_xlabel(within)
    ax.set_ylabel(ylabel or dv)
    ax.set_ylim(0, max(ceiling, span) * 1.08)
    ax.legend(title=between, frameon=False, fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.spines[["top", "right"]].set_visible(False)
    if title:
        ax.set_title(title, fontsize="medium")
    return fig


def plot_ratings(summary: pd.DataFrame, title: str | None = None, item: str = "item",
                 interaction: str = "interaction") -> Figure:
    """Diverging stacked bars of the ratings per item and interaction model: shares below the neutral 5 to the
    left, above it to the right, the neutral share split across zero.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`microg.analysis.likert_summary`: columns ``item``, ``interaction``, ``count_0`` ... ``count_10``.
    title : str, optional
    item, interaction : str
        The columns that name each bar.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import likert_summary, plot_ratings
    >>> answers = pd.DataFrame({"item": "ease", "interaction": ["s"] * 3 + ["b"] * 3, "rating": [8, 7, 9, 3, 5, 4]})
    >>> fig = plot_ratings(likert_summary(answers))
    >>> [label.get_text() for label in fig.axes[0].get_yticklabels()]
    ['ease\\nb', 'ease\\ns']
    """
    counts = summary[[f"count_{score}" for score in SCALE]].to_numpy(float)
    shares = 100 * counts / counts.sum(axis=1, keepdims=True)
    labels = [f"{name}\n{code}" for name, code in zip(summary[item], summary[interaction])]
    colours = matplotlib.colormaps["RdYlBu"](np.linspace(0.05, 0.95, len(SCALE)))
    fig = Figure(figsize=(8, 0.7 * len(labels) + 1.6), layout="constrained")
    ax = fig.subplots()
    neutral = SCALE.index(NEUTRAL)
    y = np.arange(len(labels))[::-1]
    left = -shares[:, :neutral].sum(axis=1) - shares[:, neutral] / 2
    for index, score in enumerate(SCALE):
        ax.barh(
            y, shares[:, index], left=left, color=colours[index], edgecolor="white", linewidth=0.5, label=str(score)
        )
        left = left + shares[:, index]
    ax.axvline(0, color="black", linewidth=0.8)
    ax.set_yticks(y, labels)
    ax.set_xlabel("share of ratings (%), left: below 5, right: above 5")
    limit = np.ceil(np.max(np.abs(ax.get_xlim())) / 10) * 10
    ax.set_xlim(-limit, limit)
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{abs(v):.0f}"))
    ax.legend(title="rating", ncol=len(SCALE), loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False,
              fontsize="small", columnspacing=0.8, handlelength=1.2)  # fmt: skip
    ax.spines[["top", "right"]].set_visible(False)
    if title:
        ax.set_title(title, fontsize="medium")
    return fig


def plot_scores(scores: pd.DataFrame, title: str | None = None, labels: dict[str, str] | None = None,
                columns: int = 4) -> Figure:
    """One panel per scale: each administration and interaction model a box (median and quartiles, whiskers
    to 1.5 IQR) with every participant's score a dot.

    Parameters
    ----------
    scores : pandas.DataFrame
        :func:`microg.analysis.score_answers` of one instrument.
    title : str, optional
    labels : dict, optional
        How each interaction model is named (its label); absent ones by their code.
    columns : int
        Panels per row.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.figures import plot_scores
    >>> scores = pd.DataFrame({"participant": ["a", "b"] * 2, "instrument": "ssq", "interaction": "",
    ...                        "administration": ["pre", "pre", "post", "post"], "scale": "total",
    ...                        "score": [0.0, 3.74, 11.22, 7.48]})
    >>> fig = plot_scores(scores)
    >>> fig.axes[0].get_title(), [t.get_text() for t in fig.axes[0].get_xticklabels()]
    ('total', ['pre', 'post'])
    """
    labels = labels or {}
    scales = list(dict.fromkeys(scores["scale"]))
    conditions = list(dict.fromkeys(zip(scores["administration"], scores["interaction"])))
    rows = -(-len(scales) // columns)
    fig = Figure(figsize=(min(columns, len(scales)) * (1.2 + 0.7 * len(conditions)), 2.8 * rows + 0.4),
                 layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, min(columns, len(scales)), squeeze=False).ravel())
    names = ["\n".join(part for part in (administration, labels.get(about, about)) if part)
             for administration, about in conditions]
    for ax, scale in zip(axes, scales):
        rows_of = scores[(scores["scale"] == scale) & scores["score"].notna()]
        for index, (administration, about) in enumerate(conditions):
            values = np.sort(rows_of.loc[(rows_of["administration"] == administration)
                                         & (rows_of["interaction"] == about), "score"].to_numpy(float))
            colour = GROUP_COLOURS[index % len(GROUP_COLOURS)]
            if len(values):
                ax.boxplot(values, positions=[index], widths=0.5, showfliers=False, medianprops={"color": "black"},
                           boxprops={"color": colour}, whiskerprops={"color": colour}, capprops={"color": colour})
                ax.scatter(index + _spread(len(values), 0.35), values, s=9, color=colour, edgecolor="black",
                           linewidth=0.4, zorder=2)  # fmt: skip
        ax.set_xticks(range(len(conditions)), names, fontsize="small")
        ax.set_title(scale, fontsize="medium")
        ax.spines[["top", "right"]].set_visible(False)
    for ax in axes[len(scales):]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title, fontsize="medium")
    return fig


def plot_learning_curves(tasks: pd.DataFrame, fits: pd.DataFrame, curves: pd.DataFrame, dv: str = "time_s",
                         practice: str = "practice", subject: str = "participant", group: str = "group",
                         ylabel: str | None = None) -> Figure:
    """One panel per group: every task's ``dv`` against practice (dots), each participant's power law
    a + b practice^-c over the practice of their own finished tasks (thin lines) and the group's curve exp(intercept) practice^slope from the mixed
    model (thick).

    Parameters
    ----------
    tasks : pandas.DataFrame
        One row per task with ``dv`` (empty for an unfinished task) and ``practice``.
    fits : pandas.DataFrame
        :func:`microg.analysis.power_law_fits` (columns ``subject, group, a, b, c``).
    curves : pandas.DataFrame
        :func:`microg.analysis.practice_model`'s per group ``intercept`` and ``slope`` (may be empty).
    dv, practice, subject, group : str
        The columns.
    ylabel : str, optional
        Axis label (default ``dv``).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.figures import plot_learning_curves
    >>> tasks = pd.DataFrame({"participant": "T1", "group": "P", "practice": [1, 2, 3, 4],
    ...                       "time_s": [60.0, 41.0, 35.0, 30.0]})
    >>> fits = pd.DataFrame({"participant": ["T1"], "group": ["P"], "a": [20.0], "b": [40.0], "c": [0.8]})
    >>> curves = pd.DataFrame({"group": ["P", "P"], "parameter": ["intercept", "slope"], "estimate": [4.1, -0.5]})
    >>> fig = plot_learning_curves(tasks, fits, curves)
    >>> fig.axes[0].get_title(), len(fig.axes[0].get_lines())
    ('P (n = 1)', 2)
    """
    groups = sorted(tasks[group].unique())
    fig = Figure(figsize=(3.4 * len(groups) + 0.6, 3.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(groups), sharey=True, squeeze=False).ravel())
    span = np.linspace(1, max(float(tasks[practice].max()), 2.0), 200)
    for index, (ax, name) in enumerate(zip(axes, groups)):
        colour = GROUP_COLOURS[index % len(GROUP_COLOURS)]
        rows = tasks[(tasks[group] == name) & tasks[dv].notna()]
        ax.scatter(rows[practice].astype(float), rows[dv].astype(float), s=5, color=colour, alpha=0.35, linewidth=0)
        for fit in fits[(fits[group] == name) & fits["a"].notna()].itertuples(index=False):
            seen = rows.loc[rows[subject] == getattr(fit, subject), practice].astype(float)
            own_span = span[(span >= seen.min()) & (span <= seen.max())] if len(seen) else span  # no extrapolation
            ax.plot(own_span, fit.a + fit.b * own_span**-fit.c, color=colour, linewidth=0.8, alpha=0.8)
        own = curves[curves[group] == name].set_index("parameter")["estimate"] if len(curves) else pd.Series()
        if {"intercept", "slope"} <= set(own.index):
            ax.plot(span, np.exp(own["intercept"]) * span ** own["slope"], color="black", linewidth=2.2,
                    label="group (mixed model)")  # fmt: skip
            ax.legend(frameon=False, fontsize="small", loc="upper right")
        ax.set_title(f"{name} (n = {rows[subject].nunique()})", fontsize="medium")
        ax.set_xlabel(f"{practice} (tasks done)")
        ax.spines[["top", "right"]].set_visible(False)
    axes[0].set_ylabel(ylabel or dv)
    axes[0].set_ylim(bottom=0)
    return fig


def plot_trainee(tasks: pd.DataFrame, band: pd.DataFrame, dv: str = "time_s", practice: str = "practice",
                 session: str = "session", criterion: float | None = None, ylabel: str | None = None) -> Figure:
    """One trainee's ``dv`` against practice (dots joined, a shade per session) over the band of their
    group (:func:`microg.analysis.training.cohort_band`), with the criterion's limit as a line.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.figures import plot_trainee
    >>> tasks = pd.DataFrame({"practice": [1, 2, 3], "time_s": [60.0, 45.0, 30.0], "session": ["a", "a", "b"]})
    >>> band = pd.DataFrame({"practice": [1, 2, 3], "low": [40.0, 35.0, 30.0], "median": [50.0, 42.0, 36.0],
    ...                      "high": [70.0, 60.0, 50.0]})
    >>> len(plot_trainee(tasks, band, criterion=45.0).axes[0].get_lines())  # median, two sessions, criterion
    4
    """
    fig = Figure(figsize=(6.4, 3.4), layout="constrained")
    ax = fig.subplots()
    if len(band):
        ax.fill_between(band[practice].astype(float), band["low"], band["high"], color="0.85", linewidth=0,
                        label="group, 10-90 %")
        ax.plot(band[practice].astype(float), band["median"], color="0.55", linewidth=1.0, label="group median")
    done = tasks[tasks[dv].notna()]
    colours = matplotlib.colormaps["tab10"].colors
    for index, (name, part) in enumerate(done.groupby(session, sort=False)):
        ax.plot(part[practice].astype(float), part[dv].astype(float), marker="o", markersize=3.5, linewidth=1.2,
                color=colours[index % len(colours)], label=str(name))
    ax.set_xlim(0, float(tasks[practice].max()) + 1)
    if criterion is not None:
        ax.axhline(criterion, color="black", linestyle="--", linewidth=0.9, label=f"criterion ({criterion:g})")
    ax.set_xlabel(f"{practice} (tasks done)")
    ax.set_ylabel(ylabel or dv)
    ax.set_ylim(bottom=0)
    ax.spines[["top", "right"]].set_visible(False)
    ax.legend(frameon=False, fontsize="x-small", loc="upper right", ncols=2)
    return fig


def plot_practice_means(curve: pd.DataFrame, measure: str, group: str = "group", practice: str = "practice",
                        ylabel: str | None = None) -> Figure:
    """Each group's mean of ``measure`` at each amount of practice, with a band of +- SE.

    Parameters
    ----------
    curve : pandas.DataFrame
        A learning curve table (columns ``group, practice, measure, n, mean, se``).
    measure : str
        The measure shown (a value of the ``measure`` column).
    group, practice : str
        The columns.
    ylabel : str, optional
        Axis label (default ``measure``).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.figures import plot_practice_means
    >>> curve = pd.DataFrame({"group": "P", "practice": [1, 2], "measure": "attempts", "n": 2, "mean": [1.0, 0.5],
    ...                       "se": [0.5, 0.5]})
    >>> [text.get_text() for text in plot_practice_means(curve, "attempts").axes[0].get_legend().get_texts()]
    ['P']
    """
    rows = curve[curve["measure"] == measure]
    fig = Figure(figsize=(6.0, 3.2), layout="constrained")
    ax = fig.subplots()
    for index, (name, part) in enumerate(rows.groupby(group, sort=True)):
        colour = GROUP_COLOURS[index % len(GROUP_COLOURS)]
        part = part.sort_values(practice)
        x, mean, se = (part[column].to_numpy(float) for column in (practice, "mean", "se"))
        ax.plot(x, mean, color=colour, linewidth=1.2, label=str(name))
        ax.fill_between(x, mean - np.nan_to_num(se), mean + np.nan_to_num(se), color=colour, alpha=0.2, linewidth=0)
    ax.set_xlabel(f"{practice} (tasks done)")
    ax.set_ylabel(ylabel or measure)
    ax.set_ylim(bottom=0)
    ax.legend(title=group, frameon=False, fontsize="small")
    ax.spines[["top", "right"]].set_visible(False)
    return fig


CRITERION_COLUMNS = 4
"""Panels per row of :func:`plot_criterion` (one per session and phase with a criterion)."""


def plot_criterion(km: pd.DataFrame, reached: pd.DataFrame, keys: Sequence[str] = ("session", "phase"),
                   group: str = "group", time: str = "at_tasks", event: str = "criterion_met") -> Figure:
    """One panel per session and phase: the share of each group that has met the criterion against the
    tasks done (1 - the Kaplan-Meier curve), its 95 % band shaded, censored participants as ticks.

    Parameters
    ----------
    km : pandas.DataFrame
        :func:`microg.analysis.kaplan_meier` per group, keyed by ``keys``.
    reached : pandas.DataFrame
        One row per participant and key: ``time`` and ``event`` (:func:`microg.analysis.criterion_tasks`).
    keys, group, time, event : str
        The columns.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import criterion_tasks, kaplan_meier
    >>> from microg.analysis.figures import plot_criterion
    >>> reached = pd.DataFrame({"session": "train1", "phase": "training", "group": ["P", "P", "B"],
    ...                         "at_tasks": [3, 6, 8], "criterion_met": [True, True, False]})
    >>> km = kaplan_meier(reached, "at_tasks", "criterion_met", "group").assign(session="train1", phase="training")
    >>> plot_criterion(km, reached).axes[0].get_title()
    'train1, training'
    """
    panels = list(dict.fromkeys(reached[list(keys)].itertuples(index=False, name=None)))
    groups = sorted(reached[group].unique())
    columns = min(len(panels), CRITERION_COLUMNS)
    rows = -(-len(panels) // columns)
    fig = Figure(figsize=(3.2 * columns + 0.6, 3.0 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, columns, sharey=True, squeeze=False).ravel())
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    for ax, panel in zip(axes, panels):
        here = np.logical_and.reduce([km[k] == v for k, v in zip(keys, panel)]) if len(km) else []
        people = reached[np.logical_and.reduce([reached[k] == v for k, v in zip(keys, panel)])]
        end = float(people[time].max())
        for index, name in enumerate(groups):
            colour = GROUP_COLOURS[index % len(GROUP_COLOURS)]
            steps = km[here & (km[group] == name)] if len(km) else km
            x = np.concatenate([[0.0], steps["time"].to_numpy(float), [end]])
            share = 1 - np.concatenate([[1.0], steps["surv"].to_numpy(float), steps["surv"].to_numpy(float)[-1:]
                                        if len(steps) else [1.0]])  # fmt: skip
            low = 1 - np.concatenate([[1.0], steps["ci_high"].to_numpy(float), steps["ci_high"].to_numpy(float)[-1:]
                                      if len(steps) else [1.0]])  # fmt: skip
            high = 1 - np.concatenate([[1.0], steps["ci_low"].to_numpy(float), steps["ci_low"].to_numpy(float)[-1:]
                                       if len(steps) else [1.0]])  # fmt: skip
            mine = people[people[group] == name]
            if mine.empty:  # the group does not run this phase
                continue
            ax.step(x, share, where="post", color=colour, linewidth=1.5, label=f"{name} (n = {len(mine)})")
            ax.fill_between(x, np.nan_to_num(low), np.nan_to_num(high, nan=1.0), step="post", color=colour,
                            alpha=0.15, linewidth=0)  # fmt: skip
            censored = mine[~mine[event].astype(bool)][time].to_numpy(float)
            heights = [share[np.searchsorted(x, value, side="right") - 1] for value in censored]
            ax.scatter(censored, heights, marker="|", s=60, color=colour, zorder=3)
        ax.set_title(", ".join(map(str, panel)), fontsize="medium")
        ax.set_xlabel("tasks in the phase")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylim(0, 1.02)
        ax.spines[["top", "right"]].set_visible(False)
    for ax in axes[::columns]:
        ax.set_ylabel("share that met the criterion")
    for ax in axes[:len(panels)]:
        ax.legend(title=group, frameon=False, fontsize="small", loc="lower right")
    return fig


def save_figure(fig: Figure, stem: Path) -> tuple[Path, Path]:
    """Write ``stem``.png and ``stem``.svg."""
    png, svg = stem.with_suffix(".png"), stem.with_suffix(".svg")
    fig.savefig(png, dpi=150)
    fig.savefig(svg)
    return png, svg


def _spread(n: int, width: float) -> np.ndarray:
    """Horizontal offsets that set n dots (sorted by value) side by side, so that equal values do not hide
    one another; deterministic, unlike random jitter."""
    return np.linspace(-width / 2, width / 2, n) if n > 1 else np.zeros(n)


def _bracket(ax, x0: float, x1: float, height: float, step: float, text: str) -> None:
    ax.plot([x0, x0, x1, x1], [height, height + step / 2, height + step / 2, height], color="black", linewidth=0.8)
    ax.text((x0 + x1) / 2, height + step / 2, text, ha="center", va="bottom")
