"""The power curve: power against participants per group, one line per test, the target marked."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure

FAMILY_STYLES = ("-", "--", ":")
"""Line style of each post hoc family, in the order the design lists them."""


def plot_power(table: pd.DataFrame, terms, target: float, path: str | Path, title: str = "",
               families: dict | None = None, xlabel: str = "participants per group") -> Path:
    """Draw ``table`` (n_per_group, term, power, ci_low, ci_high) into ``path`` (PNG): the ANOVA
    ``terms`` on the left, the post hoc contrasts on the right (one line style per family of
    ``families``, test -> family), the interval as a band where the power was simulated, and a dashed
    line at the ``target`` power; ``n_per_group`` on the x axis, named ``xlabel``."""
    path = Path(path)
    families = families or {}
    family_order = list(dict.fromkeys(families.values()))
    panels = [("ANOVA terms", table[table["term"].isin(terms)]),
              ("post hoc contrasts (Bonferroni within each family)", table[~table["term"].isin(terms)])]  # fmt: skip
    panels = [(name, rows) for name, rows in panels if len(rows)]
    figure = Figure(figsize=(5.2 * len(panels) + 2.6, 4.6))
    axes = figure.subplots(1, len(panels), sharey=True, squeeze=False)[0]
    for axis, (name, rows) in zip(axes, panels):
        seen: dict = {}
        for term, line in rows.groupby("term", sort=False):
            line = line.sort_values("n_per_group")
            family = families.get(term)
            style = FAMILY_STYLES[family_order.index(family) % len(FAMILY_STYLES)] if family else "-"
            colour = f"C{seen.setdefault(family, 0) % 10}"
            seen[family] += 1
            axis.plot(line["n_per_group"], line["power"], marker="o", markersize=4, label=term, color=colour,
                      linestyle=style, linewidth=2.0 if term in terms else 1.3)  # fmt: skip
            if (line["ci_high"] > line["ci_low"]).any():
                axis.fill_between(line["n_per_group"], line["ci_low"], line["ci_high"], alpha=0.15, color=colour,
                                  linewidth=0)  # fmt: skip
        axis.axhline(target, color="black", linestyle="--", linewidth=1)
        axis.text(rows["n_per_group"].min(), target + 0.01, f"target {target:g}", fontsize=8, va="bottom")
        axis.set_title(name, fontsize=10)
        axis.set_xlabel(xlabel)
        axis.set_ylim(0, 1.02)
        axis.set_xticks(sorted(rows["n_per_group"].unique()))
        axis.grid(alpha=0.3)
    axes[0].set_ylabel("power")
    axes[0].legend(fontsize=8, loc="center right")
    if len(panels) > 1:
        axes[-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0)
    if title:
        figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=120)
    return path
