"""The report's figures: bars per object and group with every participant's value and significance
marks (the paper's Fig. 11), the diverging stacked rating distribution (the paper's Fig. 12), and
each instrument's scores per administration and interaction model with every participant's score."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter

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
    levels = sorted(cells[within].unique())
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
