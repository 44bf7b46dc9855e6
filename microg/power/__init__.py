"""Planning a study: how many participants the protocol's design needs (``microg power``).

    from microg.paths import protocol_file
    from microg.study.protocol import load_protocol
    from microg.power import design_from_protocol, read_effects, exact_power

    design = design_from_protocol(load_protocol(protocol_file("paper")))
    effects = read_effects("effects.toml", design)
    exact_power(effects, [8, 10, 15, 20])        # one tidy row per n and test

Exact power (``exact``) analyses one data set with exactly the expected means and covariances
(and answers sensitivity: the smallest effect each test detects, ``sensitivity``);
Monte Carlo power (``montecarlo``, ``run_power``) counts how often simulated data sets, analysed
as the report does (``batch``: the report's tests vectorised over data sets), reach significance,
on a Dask cluster. See docs/power.md.

Names are imported on first use, so that a Dask worker that runs a Monte Carlo batch loads numpy
and scipy only, not the report's statistics stack.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "Contrast": "design", "Design": "design", "PowerInputError": "design", "design_from_protocol": "design",
    "Effects": "effects", "compound_symmetry": "effects", "effects_from_means": "effects", "read_effects": "effects",
    "exact_dataset": "exact", "exact_power": "exact", "sensitivity": "exact", "effect_size_power": "exact",
    "mixed_anova_many": "batch", "posthoc_many": "batch",
    "montecarlo_batch": "montecarlo", "power_table": "montecarlo", "simulate": "montecarlo",
    "PilotEstimate": "pilot", "design_cells": "pilot", "pilot_effects": "pilot",
    "simulated_batch": "simulated",
    "PowerRequest": "run", "PowerResult": "run", "dask_client": "run", "run_power": "run", "smallest_n": "run",
    "plot_power": "plot",
}  # fmt: skip

__all__ = [
    "Contrast",
    "Design",
    "Effects",
    "PilotEstimate",
    "PowerInputError",
    "PowerRequest",
    "PowerResult",
    "compound_symmetry",
    "dask_client",
    "design_cells",
    "design_from_protocol",
    "effect_size_power",
    "effects_from_means",
    "exact_dataset",
    "exact_power",
    "mixed_anova_many",
    "montecarlo_batch",
    "pilot_effects",
    "plot_power",
    "posthoc_many",
    "power_table",
    "read_effects",
    "run_power",
    "sensitivity",
    "simulate",
    "simulated_batch",
    "smallest_n",
]


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
