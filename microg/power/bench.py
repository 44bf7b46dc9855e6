"""``microg bench power``: how long Monte Carlo power takes, against the report's one-by-one path.

The issue's target configuration: 1000 data sets x 4 sample sizes (8, 10, 15, 20 per group) x the
paper's 2 x 3 design, on a local Dask cluster of 2 worker processes. Measured:
- the whole run as ``microg power --method montecarlo`` does it (cluster start included);
- the vectorised analysis alone, in this process;
- the report's functions (``mixed_anova``, ``sphericity_correction``, ``posthoc``) one data set at
  a time on a sample, extrapolated to all data sets, and the largest difference in p between the
  two paths on that sample.
It lives in the power room because ``microg.bench`` may not import the statistics.
"""

from __future__ import annotations

import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

SIZES = (8, 10, 15, 20)
MEANS = {"veteran": (45.0, 55.0, 55.0), "beginner": (55.0, 70.0, 70.0)}
SD, CORRELATION = 20.0, 0.5


def run(out: Path, quick: bool = False, workers: int = 2) -> pd.DataFrame:
    """Measure (module docstring), write ``out/power.csv`` and return the table."""
    from microg.analysis import mixed_anova, posthoc, sphericity_correction
    from microg.paths import protocol_file
    from microg.power import (
        PowerRequest,
        design_from_protocol,
        effects_from_means,
        run_power,
        simulate,
    )
    from microg.power.montecarlo import analyse_batch
    from microg.study.protocol import load_protocol

    sims = 100 if quick else 1000
    sample = 5 if quick else 20
    design = design_from_protocol(load_protocol(protocol_file("paper")))
    means = pd.DataFrame([(g, level, m) for g, row in MEANS.items() for level, m in zip(design.levels, row)],
                         columns=["group", "object", "mean"])  # fmt: skip
    effects = effects_from_means(means, design, sd=SD, correlation=CORRELATION, source="bench effects")
    request = PowerRequest(design, "montecarlo", SIZES, effects, sims=sims, seed=1)

    with tempfile.TemporaryDirectory(prefix="microg-bench-power-") as folder:
        started = time.perf_counter()
        run_power(request, Path(folder) / "run", workers=workers, progress=False)
        whole = time.perf_counter() - started

    started = time.perf_counter()
    for n in SIZES:
        analyse_batch(effects, simulate(effects, n, range(sims), 1), n, range(sims), request.alpha)
    vectorised = time.perf_counter() - started

    n = SIZES[-1]
    y = simulate(effects, n, range(sample), 1)
    batch = analyse_batch(effects, y, n, range(sample), request.alpha)
    started = time.perf_counter()
    differences = []
    for s in range(sample):
        data = pd.DataFrame([(f"p{i}", design.groups[i // n], level, y[s, i, j])
                             for i in range(2 * n) for j, level in enumerate(design.levels)],
                            columns=["participant", "group", "object", "value"])  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            anova = sphericity_correction(mixed_anova(data, "value", "object", "group", "participant"))
            post = posthoc(data, "value", "object", "group", "participant", within_by_group=True)
        report = design.report_p(anova, post).to_numpy()
        differences.append(np.max(np.abs(report - batch.loc[batch["sim"] == s, "p"].to_numpy())))
    one_by_one = (time.perf_counter() - started) / sample
    total = sims * len(SIZES)
    table = pd.DataFrame([
        ("data sets", total, "count"),
        ("whole run on a local cluster (cluster start included)", whole, "s"),
        ("local cluster workers", workers, "count"),
        ("vectorised analysis and simulation, one process", vectorised, "s"),
        ("report's path, one data set at a time (per data set)", one_by_one, "s"),
        ("report's path for all data sets (extrapolated)", one_by_one * total, "s"),
        ("speed-up of the vectorised analysis", one_by_one * total / vectorised, "x"),
        (f"largest |p difference| vectorised vs report ({sample} data sets)", max(differences), "p"),
    ], columns=["measure", "value", "unit"])  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "power.csv", index=False)
    return table

