"""Accuracy versus time: every error metric against the cost, over dt, integrators and filter windows.

The sweep (not a full product: each scenario varies what it depends on):

- impact and tumble: every dt x every angular integrator (F = 3; the tumble has no hand);
- shake: every dt x F = 1..7 with the midpoint rule, and every dt x the Euler integrators at F = 3.

dt = 1 / (tracking rate x substeps): 60 Hz tracking with one step a frame (dt = 1/60 s), then the
Leap's 110 Hz with 1 to 36 substeps (dt down to 1/3960 s).
"""

from __future__ import annotations

from dataclasses import asdict, replace
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from . import ours
from .charts import error_cost_chart, mark_fronts
from .scenarios import IMPACT, SHAKE, TUMBLE

TIMESTEPS = ((60.0, 1), (110.0, 1), (110.0, 2), (110.0, 4), (110.0, 8), (110.0, 16), (110.0, 36))
INTEGRATORS = ("midpoint", "semi_implicit_euler", "explicit_euler")
WINDOWS = tuple(range(1, 8))
QUICK_TIMESTEPS = ((110.0, 1), (110.0, 4))
QUICK_WINDOWS = (1, 3)


def plan(quick: bool = False) -> list[tuple[str, ours.Config]]:
    """(scenario, config) pairs of the sweep."""
    timesteps, windows = (QUICK_TIMESTEPS, QUICK_WINDOWS) if quick else (TIMESTEPS, WINDOWS)
    runs = []
    for rate, substeps in timesteps:
        for integrator in INTEGRATORS:
            config = ours.Config(rate, substeps, integrator)
            runs += [("impact", config), ("tumble", config)]
            if integrator != "midpoint":
                runs.append(("shake", config))
        runs += [("shake", ours.Config(rate, substeps, "midpoint", window)) for window in windows]
    return runs


def run(out: Path, figures: Path, quick: bool = False) -> pd.DataFrame:
    """Run the sweep; write ``accuracy.csv`` (tidy: one row per run and metric) and the chart."""
    scenarios = {
        "impact": lambda c: ours.impact(c, IMPACT),
        "tumble": lambda c: ours.tumble(c, replace(TUMBLE, duration=5.0) if quick else TUMBLE),
        "shake": lambda c: ours.shake(c, replace(SHAKE, cycles=4, hold=0.6) if quick else SHAKE),
    }
    ours.warm_up()
    rows = []
    for scenario, config in tqdm(plan(quick), desc="accuracy sweep", unit="run"):
        result = scenarios[scenario](config)
        cost = result.pop("cost_us_per_s")
        extra = {k: result.pop(k) for k in ("hits",) if k in result}
        for metric, error in result.items():
            rows.append({"engine": "microg", "variant": config.angular_integrator, "scenario": scenario,
                         **asdict(config), "dt": config.dt, "metric": metric, "error": float(error),
                         "cost_us_per_s": cost, **extra})
    table = mark_fronts(pd.DataFrame(rows))
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "accuracy.csv", index=False)
    error_cost_chart(table, figures / "bench-accuracy.png",
                     "microg: error against cost (dt, angular integrator, filter window F)")
    return table


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Wide table for the README: the midpoint rule at F = 3, one row per dt, one column per metric."""
    chosen = table[(table["variant"] == "midpoint") & (table["filter_window"] == 3)]
    wide = chosen.pivot_table(index=["dt", "tracking_rate", "substeps"], columns="metric", values="error")
    cost = chosen.groupby(["dt", "tracking_rate", "substeps"])["cost_us_per_s"].mean().rename("cost_us_per_s")
    return wide.join(cost).sort_index(ascending=False).reset_index()
