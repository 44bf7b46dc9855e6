"""Pareto fronts and the error-versus-cost chart."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

METRICS = {
    "restitution_error": ("impact: restitution error", "|e_eff - e| / e"),
    "max_penetration": ("impact: deepest penetration", "m"),
    "L_drift": ("60 s tumble: |L| drift", "relative"),
    "E_drift": ("60 s tumble: energy drift", "relative"),
    "omega_error": ("60 s tumble: body rate vs solve_ivp", "relative"),
    "slip": ("2 Hz shake: slip of the pinched cube", "m"),
    "lag": ("2 Hz shake: tracking lag", "s"),
    "tracking_rms": ("2 Hz shake: tracking error (RMS)", "m"),
}
"""Every error metric: its panel title and unit."""
COLOURS = {"midpoint": "tab:blue", "semi_implicit_euler": "tab:orange", "explicit_euler": "tab:red",
           "mujoco": "tab:green", "pybullet": "tab:purple"}
MARKERS = {1: "v", 2: "<", 3: "o", 4: ">", 5: "^", 6: "s", 7: "D"}
FLOOR = 1e-16


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Mask of the points no other point beats on both cost and error (ties kept)."""
    cost, error = np.asarray(cost, dtype=float), np.asarray(error, dtype=float)
    front = np.ones(len(cost), dtype=bool)
    for i in range(len(cost)):
        better = (cost <= cost[i]) & (error <= error[i]) & ((cost < cost[i]) | (error < error[i]))
        front[i] = not better.any()
    return front


def mark_fronts(table: pd.DataFrame) -> pd.DataFrame:
    """Add ``pareto`` (bool) per metric to a tidy table with ``metric``, ``error`` and ``cost_us_per_s``."""
    table = table.copy()
    table["pareto"] = False
    for _, rows in table.groupby("metric"):
        table.loc[rows.index, "pareto"] = pareto_front(rows["cost_us_per_s"], rows["error"])
    return table


def error_cost_chart(table: pd.DataFrame, path: Path, title: str) -> Path:
    """One panel per metric: error against microseconds per simulated second, log-log, Pareto front drawn."""
    metrics = [m for m in METRICS if m in set(table["metric"])]
    columns = 4
    rows = -(-(len(metrics) + 1) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.6 * rows), squeeze=False)
    for ax, metric in zip(axes.flat, metrics):
        data = table[table["metric"] == metric]
        for (engine, window), group in data.groupby(["variant", "filter_window"]):
            ax.scatter(group["cost_us_per_s"], np.maximum(group["error"], FLOOR), s=22, alpha=0.8,
                       color=COLOURS.get(engine, "grey"), marker=MARKERS.get(int(window), "o"),
                       edgecolor="none")
        front = data[data["pareto"]].sort_values("cost_us_per_s")
        ax.step(front["cost_us_per_s"], np.maximum(front["error"], FLOOR), where="post", color="black", lw=1)
        for _, point in front.iterrows():
            ax.annotate(f"1/{1 / point['dt']:.0f}", (point["cost_us_per_s"], max(point["error"], FLOOR)),
                        fontsize=6, xytext=(3, 3), textcoords="offset points")
        name, unit = METRICS[metric]
        ax.set(xscale="log", yscale="log", title=name, ylabel=unit, xlabel="µs per simulated second")
        ax.grid(True, which="major", alpha=0.3)
    legend_ax = axes.flat[len(metrics)]
    for variant in sorted(set(table["variant"])):
        legend_ax.scatter([], [], color=COLOURS.get(variant, "grey"), label=variant)
    for window in sorted(set(table["filter_window"].dropna().astype(int))):
        legend_ax.scatter([], [], color="grey", marker=MARKERS.get(window, "o"), label=f"F = {window}")
    legend_ax.plot([], [], color="black", lw=1, label="Pareto front (labels: dt in s)")
    legend_ax.legend(loc="center", fontsize=8, frameon=False)
    for ax in axes.flat[len(metrics):]:
        ax.axis("off")
    figure.suptitle(title)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
