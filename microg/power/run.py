"""A power run: what to compute, on which Dask cluster, and the files it leaves in its folder.

``--out DIR`` receives
- ``run.json``: the request (design, effects, method, sizes, alpha, sims, seed), to resume it;
- ``simulations.csv`` (Monte Carlo and in-silico studies): one row per data set and test with the
  p the report reads, appended batch by batch as results arrive, so an interrupted run keeps
  everything it finished and ``resume=True`` computes only the data sets that are missing;
- ``power.csv``: n_per_group, term, power, ci_low, ci_high, method;
- ``power-curve.png`` and ``summary.json`` (the smallest n per group that reaches the target);
- with ``sensitivity``, instead of the power table and curve: ``sensitivity.csv``, the smallest effect
  each test detects at each n (``microg.power.exact.SENSITIVITY_COLUMNS``), summarised in
  ``summary.json``.

The work runs on Dask: a local cluster of one single-threaded worker process per core by default,
or the cluster at ``scheduler``; either way the same tasks are submitted and gathered the same way.
A task is a batch of data sets (or one simulated study); each data set's seed depends only on the
run's seed, its n and its index, so the numbers do not depend on the workers. A worker that dies
takes only its tasks in flight with it, and Dask runs them again elsewhere.
"""

from __future__ import annotations

import io
import json
import logging
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from tqdm import tqdm

from microg.power.design import CORRECTIONS, Design, PowerInputError
from microg.power.effects import Effects
from microg.power.montecarlo import SIMULATION_COLUMNS, montecarlo_batch, power_table
from microg.power.plot import plot_power
from microg.study.protocol import Protocol

if TYPE_CHECKING:
    from microg.participant import Population

METHODS = ("exact", "montecarlo")
POWER_COLUMNS = ("n_per_group", "term", "power", "ci_low", "ci_high", "method")
RECORD, SIMULATIONS, POWER, SUMMARY = "run.json", "simulations.csv", "power.csv", "summary.json"
SENSITIVITY = "sensitivity.csv"
CURVE = "power-curve.png"
P_FORMAT = "%.17g"
"""p values are written with every digit, so a resumed run reads back exactly what it computed."""
BATCH = 100
"""Data sets per Dask task (Monte Carlo): large enough that a task's overhead is small, small enough
that a lost worker costs little and the progress bar moves."""


@dataclass(frozen=True)
class PowerRequest:
    """What a run computes.

    ``n_per_group`` holds the samples: a group size (every group that size) or a tuple of one size
    per group (the design's order). ``effects`` are the expected effects (from a file or a pilot);
    ``effect_sizes`` instead names tests with their effect size ((test, "f" or "np2", value): exact
    power by Superpower's convention); neither asks for in-silico studies of ``protocol``
    (``measure`` of ``interaction``), which are Monte Carlo by nature. ``sensitivity`` asks for the
    smallest effect each test detects with power ``target`` (exact; the pattern of ``effects`` when
    given). ``correction`` is the sphericity correction (design.CORRECTIONS; None: the report's
    Mauchly rule for simulated data sets, none for exact power).
    """

    design: Design
    method: str
    n_per_group: tuple
    effects: Effects | None = None
    protocol: Protocol | None = field(default=None, compare=False)
    alpha: float = 0.05
    target: float = 0.8
    sims: int = 1000
    seed: int = 1
    measure: str = "time_s"
    interaction: str | None = None
    correction: str | None = None
    sensitivity: bool = False
    effect_sizes: tuple = ()
    population: Population | None = field(default=None, compare=False)
    """In-silico studies: the population every group's participants are drawn from (None: each
    group's ``simulated_profile``)."""

    def __post_init__(self):
        if self.method not in METHODS:
            raise PowerInputError(f"--method = {self.method!r}: must be one of {list(METHODS)}")
        if self.correction is not None and self.correction not in CORRECTIONS:
            raise PowerInputError(f"--correction {self.correction}: must be one of {', '.join(CORRECTIONS)}")
        if self.method == "exact" and self.correction == "mauchly":
            raise PowerInputError("--correction mauchly with --method exact: the report's rule reads Mauchly's test "
                                  "of each data set, which needs simulated data sets (--method montecarlo)")
        if (self.sensitivity or self.effect_sizes) and self.method != "exact":
            what = "--sensitivity" if self.sensitivity else "--effect-size"
            raise PowerInputError(f"{what} is computed exactly (noncentral F and t): use it with --method exact")
        if self.effect_sizes and (self.effects is not None or self.sensitivity):
            raise PowerInputError("--effect-size gives the effects itself: not with --effects, --pilot or --sensitivity")
        if self.simulated and not all(isinstance(self.design.sample_key(n), int) for n in self.n_per_group):
            raise PowerInputError("--simulated with groups of unequal size: in-silico studies run every group at one "
                                  "size (microg.insilico); give --n as sizes, e.g. --n 4,8")
        if self.population is not None and not self.simulated:
            raise PowerInputError("--profile draws the participants of --simulated studies: not with --effects, "
                                  "--pilot, --effect-size or --sensitivity")
        if self.effects is None and not self.effect_sizes and not self.sensitivity and self.method == "exact":
            raise PowerInputError("--method exact with --simulated: in-silico studies can only be counted "
                                  "(--method montecarlo)")
        if self.effects is None and self.correction not in (None, "none", "mauchly") and self.method == "exact":
            raise PowerInputError(f"--correction {self.correction}: a sphericity correction needs the covariance of "
                                  "--effects or --pilot")
        if not self.n_per_group:
            raise PowerInputError("--n: give at least one group size, e.g. --n 8,10,15,20")
        for n in self.n_per_group:
            self.design.check_sample(n)
        if not 0 < self.alpha < 1:
            raise PowerInputError(f"--alpha = {self.alpha!r}: must lie in (0, 1)")
        if not 0 < self.target <= 1:
            raise PowerInputError(f"--target = {self.target!r}: must lie in (0, 1]")
        if self.method == "montecarlo" and self.sims < 1:
            raise PowerInputError(f"--sims = {self.sims!r}: must be at least 1")

    @property
    def simulated(self) -> bool:
        """In-silico studies: no effects given in any form."""
        return self.effects is None and not self.effect_sizes and not self.sensitivity

    @property
    def source(self) -> str:
        if self.effect_sizes:
            return "effect sizes (Superpower's convention: lambda = f^2 df2)"
        if self.effects is None:
            if self.sensitivity:
                return "the design's degrees of freedom"
            return "simulated studies" + (f" of {self.population.where}" if self.population is not None else "")
        return self.effects.source

    @property
    def read(self) -> str:
        """The sphericity correction applied."""
        return self.correction or ("mauchly" if self.method == "montecarlo" else "none")

    @property
    def samples(self) -> list:
        return [self.design.sample_key(n) for n in self.n_per_group]

    def record(self) -> dict:
        """Everything the numbers depend on (``run.json``; a resumed run must match it)."""
        counted = self.method == "montecarlo"
        return {
            "method": self.method,
            "source": self.source,
            "design": self.design.as_dict(),
            "effects": None if self.effects is None else self.effects.as_dict(),
            "effect_sizes": [list(entry) for entry in self.effect_sizes] or None,
            "protocol_sha256": self.protocol.sha256 if self.simulated else None,
            "population_sha256": self.population.sha256 if self.population is not None else None,
            "measure": self.measure if self.simulated else None,
            "interaction": (self.interaction or self.design.interactions[0]) if self.simulated else None,
            "n_per_group": self.samples,
            "alpha": self.alpha,
            "correction": self.read,
            "sensitivity": self.target if self.sensitivity else None,
            "sims": self.sims if counted else None,
            "seed": self.seed if counted else None,
        }


@dataclass(frozen=True)
class PowerResult:
    """The power table (POWER_COLUMNS), the summary and where the files are."""

    table: pd.DataFrame
    summary: dict
    out: Path


def run_power(request: PowerRequest, out: str | Path, scheduler: str | None = None, workers: int | None = None,
              resume: bool = False, progress: bool = True, batch: int = BATCH) -> PowerResult:
    """Compute the power of every test for every n, write the run's files into ``out`` (see the
    module docstring) and return them.

    Parameters
    ----------
    request : PowerRequest
        What to compute.
    out : str or Path
        The run's folder.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``); default a local cluster.
    workers : int, optional
        Worker processes of the local cluster (default: the machine's cores).
    resume : bool
        Continue the run already in ``out`` (it must be the same request); without it a folder
        that holds a run is refused.
    progress : bool
        Show a progress bar (data sets done, rate, tasks, workers).
    batch : int
        Data sets per Dask task (Monte Carlo; a simulated study is always one task).
    """
    started = time.monotonic()
    out = Path(out)
    record = request.record()
    claim_run(out, record, resume)
    d = request.design
    if request.sensitivity:
        from microg.power.exact import sensitivity

        table = sensitivity(d, request.n_per_group, request.alpha, request.target, request.effects, request.read)
        table.to_csv(out / SENSITIVITY, index=False)
        summary = _summary(request, table, time.monotonic() - started, None, 0)
        (out / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")
        return PowerResult(table, summary, out)
    workers_seen = 0
    if request.effect_sizes:
        from microg.power.exact import effect_size_power

        sizes = {test: (kind, value) for test, kind, value in request.effect_sizes}
        table = effect_size_power(d, sizes, request.n_per_group, request.alpha)
    elif request.method == "exact":
        from microg.power.exact import exact_power

        table = exact_power(request.effects, request.n_per_group, request.alpha, request.read)
    else:
        results = out / SIMULATIONS
        done = _finished(results, len(d.tests)) if resume else set()
        if not done:
            results.write_text(",".join(SIMULATION_COLUMNS) + "\n")
        size = 1 if request.simulated else batch
        missing = {n: [i for i in range(request.sims) if (str(d.sample_key(n)), i) not in done]
                   for n in request.n_per_group}  # fmt: skip
        tasks = [(n, indices[start:start + size]) for n, indices in missing.items()
                 for start in range(0, len(indices), size)]  # fmt: skip
        if tasks:
            workers_seen = _compute(request, tasks, results, len(done), scheduler, workers, progress)
        simulations = pd.read_csv(results, dtype={"n_per_group": str})
        table = power_table(simulations, request.alpha, request.method)
    table = _ordered(table, request)[list(POWER_COLUMNS)]
    table.to_csv(out / POWER, index=False)
    summary = _summary(request, table, time.monotonic() - started, scheduler, workers_seen)
    (out / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")
    counted = "studies" if request.simulated else "data sets"
    title = f"{d.protocol}: {d.between} x {d.within}, {request.method}" + (
        f" ({request.sims} {counted} per n)" if request.method == "montecarlo" else "") + f", alpha {request.alpha:g}"
    equal = all(isinstance(key, int) for key in request.samples)
    curve = table if equal else table.assign(n_per_group=table["n_per_group"].map(_totals(request)))
    plot_power(curve, d.terms, request.target, out / CURVE, title, {c.name: c.family for c in d.contrasts},
               xlabel="participants per group" if equal else "participants (all groups)")  # fmt: skip
    return PowerResult(table, summary, out)


def smallest_n(table: pd.DataFrame, target: float, totals: dict | None = None) -> dict:
    """For each test, the smallest sample whose power reaches ``target`` (None: none does): the
    smallest n per group, or with ``totals`` (sample key -> participants in all) the sample with the
    fewest participants."""
    found = {}
    for term, rows in table.groupby("term", sort=False):
        reached = rows.loc[rows["power"] >= target, "n_per_group"]
        if not len(reached):
            found[term] = None
        elif totals is None:
            found[term] = int(reached.min())
        else:
            found[term] = min(reached, key=lambda key: totals[key])
    return found


def _ordered(table: pd.DataFrame, request: PowerRequest) -> pd.DataFrame:
    """Rows by sample (as asked) and test (``Design.tests`` order), samples keyed as the design names them."""
    keys = {str(key): key for key in request.samples}
    table = table.assign(n_per_group=table["n_per_group"].map(lambda key: keys[str(key)]))
    samples = {key: i for i, key in enumerate(request.samples)}
    tests = {term: i for i, term in enumerate(request.design.tests)}
    order = table["n_per_group"].map(samples) * len(tests) + table["term"].map(tests)
    return table.iloc[np.argsort(order.to_numpy(), kind="stable")].reset_index(drop=True)


def _totals(request: PowerRequest) -> dict:
    return {request.design.sample_key(n): sum(request.design.group_sizes(n)) for n in request.n_per_group}


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None) -> Iterator:
    """A Dask client: connected to ``scheduler``, or to a local cluster of ``workers`` single-threaded
    worker processes (default: one per core) that is shut down on exit."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as error:  # ValueError: not an address
            raise PowerInputError(f"--scheduler {scheduler}: cannot connect: {error}") from None
        with client:
            yield client
        return
    count = workers or os.cpu_count() or 1
    with LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address="127.0.0.1:0",
                      host="127.0.0.1", silence_logs=logging.ERROR) as cluster, Client(cluster) as client:  # fmt: skip
        yield client


def _compute(request: PowerRequest, tasks: list, results: Path, done: int, scheduler: str | None,
             workers: int | None, progress: bool) -> int:
    """Run ``tasks`` on Dask, appending each batch's rows to ``results`` as it arrives; returns the
    most workers seen."""
    from distributed import as_completed

    total = request.sims * len(request.n_per_group)
    unit = "studies" if request.simulated else "data sets"
    most = 0
    with dask_client(scheduler, workers) as client, results.open("a") as sink, \
            tqdm(total=total, initial=done, unit=f" {unit}", disable=not progress, dynamic_ncols=True,
                 desc=f"{request.method} power",
                 bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt}{unit} "
                            "[{elapsed}<{remaining}, {rate_fmt}] {postfix}") as bar:  # fmt: skip
        futures = [_submit(client, request, n, indices) for n, indices in tasks]
        for finished, future in enumerate(as_completed(futures), start=1):
            rows = future.result()
            sink.write(rows.to_csv(header=False, index=False, float_format=P_FORMAT))
            sink.flush()
            os.fsync(sink.fileno())
            future.release()
            most = max(most, len(client.scheduler_info()["workers"]))
            bar.set_postfix_str(f"tasks {finished}/{len(tasks)}, workers {most}")
            bar.update(rows["sim"].nunique())
    return most


def _submit(client, request: PowerRequest, n: int, indices: list[int]):
    """One task; ``pure=False`` gives it a key of its own, so runs sharing a cluster never share results."""
    if not request.simulated:
        return client.submit(montecarlo_batch, request.effects, n, indices, request.seed, request.alpha, request.read,
                             pure=False)  # fmt: skip
    from microg.power.simulated import simulated_batch

    interaction = request.interaction or request.design.interactions[0]
    return client.submit(simulated_batch, request.protocol, request.design, n, indices, request.seed, request.alpha,
                         request.measure, interaction, request.read, request.population, pure=False)  # fmt: skip


def claim_run(out: Path, record: dict, resume: bool, what: str = "a power run",
              outputs: tuple[str, ...] = (SIMULATIONS, POWER, SUMMARY, CURVE, SENSITIVITY)) -> None:
    """Make ``out`` this run's folder (``what`` it holds, e.g. a power run): new, or the same run
    when resuming (``record``, kept in ``run.json``, must match); a folder holding one of another
    run's ``outputs`` is refused."""
    path = out / RECORD
    if path.exists():
        if not resume:
            raise PowerInputError(f"--out {out}: holds {what} already ({RECORD}); continue it with --resume "
                                  "or choose another --out")
        before = json.loads(path.read_text())
        for key, value in record.items():
            if before.get(key) != value:
                raise PowerInputError(f"--resume: {path}: {key} = {json.dumps(before.get(key))[:200]}, but this run "
                                      f"asks for {json.dumps(value)[:200]}; a run resumes only with the same settings")
        return
    out.mkdir(parents=True, exist_ok=True)
    for name in outputs:
        if (out / name).exists():
            raise PowerInputError(f"--out {out}: holds {name} from another run; choose another --out")
    path.write_text(json.dumps(record, indent=2) + "\n")


def _finished(results: Path, tests: int) -> set[tuple[str, int]]:
    """The (sample key as text, data set) pairs ``results`` holds completely; the file is rewritten
    without the rest (a line or batch cut off when the run was interrupted)."""
    if not results.exists():
        return set()
    lines = results.read_text().splitlines(keepends=True)
    whole = "".join(line for line in lines if line.endswith("\n"))  # a line cut off has no end
    if not whole:
        return set()
    table = pd.read_csv(io.StringIO(whole), dtype={"term": str, "n_per_group": str})
    counts = table.groupby(["n_per_group", "sim"]).size()
    complete = counts[counts == tests].index
    kept = table[table.set_index(["n_per_group", "sim"]).index.isin(complete)]
    partial = results.with_suffix(".partial")
    kept.to_csv(partial, index=False, float_format=P_FORMAT)
    os.replace(partial, results)
    return {(str(n), int(i)) for n, i in complete}


def _summary(request: PowerRequest, table: pd.DataFrame, seconds: float, scheduler: str | None,
             workers: int) -> dict:
    d = request.design
    counted = request.method == "montecarlo"
    corrected = {"none": "sphericity assumed", "GG": "Greenhouse-Geisser corrected (df and lambda times epsilon)",
                 "HF": "Huynh-Feldt corrected (df and lambda times epsilon)"}  # fmt: skip
    if request.sensitivity:
        how = ("sensitivity: the smallest noncentrality at which each test reaches the target, from the noncentral "
               f"F (terms) and t (contrasts); {corrected[request.read]}; as partial eta squared and Cohen's f by "
               "Superpower's convention (lambda = f^2 df2, np2 = f^2 / (1 + f^2)) and, with effects, as the factor "
               "scaling every mean's deviation from the grand mean")
    elif request.effect_sizes:
        how = ("exact from effect sizes: lambda = f^2 df2 at each n (Superpower's convention, f^2 = np2 / (1 - np2)), "
               "the noncentral F (terms) and t (contrasts); sphericity assumed")
    elif not counted:
        how = ("exact: one data set with exactly the expected means and covariances, the report's mixed ANOVA and "
               f"post hoc on it, power from the noncentral F (terms) and t (contrasts); {corrected[request.read]}")
    else:
        reads = {"mauchly": "Greenhouse-Geisser when Mauchly's p < alpha", "none": "no sphericity correction",
                 "GG": "Greenhouse-Geisser always", "HF": "Huynh-Feldt always (epsilon capped at 1)"}  # fmt: skip
        how = (f"Monte Carlo: each data set analysed as the report does (type 3 mixed ANOVA, {reads[request.read]}, "
               "Bonferroni post hoc); 95 % Clopper-Pearson interval")
    summary = {
        "target": request.target,
        "n_per_group": request.samples,
        "method": request.method,
        "how": how,
        "source": request.source,
        "design": d.as_dict(),
        "alpha": request.alpha,
        "correction": request.read,
        "sims": request.sims if counted else None,
        "seed": request.seed if counted else None,
        "seconds": round(seconds, 2),
        "cluster": (scheduler or "local") if counted else None,
        "workers": workers if counted else None,
    }
    if request.sensitivity:
        summary["smallest_effect"] = {
            str(key): {row.term: {"scale": _number(row.scale), "np2": row.np2, "cohen_f": row.cohen_f}
                       for row in rows.itertuples(index=False)}
            for key, rows in table.groupby("n_per_group", sort=False)
        }  # fmt: skip
    else:
        totals = None if all(isinstance(key, int) for key in request.samples) else _totals(request)
        summary["smallest_n_per_group"] = smallest_n(table, request.target, totals)
    return summary


def _number(value: float) -> float | None:
    """A float for JSON: None for a missing or infinite one."""
    return float(value) if np.isfinite(value) else None
