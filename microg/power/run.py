"""A power run: what to compute, on which Dask cluster, and the files it leaves in its folder.

``--out DIR`` receives
- ``run.json``: the request (design, effects, method, sizes, alpha, sims, seed), to resume it;
- ``simulations.csv`` (Monte Carlo and in-silico studies): one row per data set and test with the
  p the report reads, appended batch by batch as results arrive, so an interrupted run keeps
  everything it finished and ``resume=True`` computes only the data sets that are missing;
- ``power.csv``: n_per_group, term, power, ci_low, ci_high, method;
- ``power-curve.png`` and ``summary.json`` (the smallest n per group that reaches the target).

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

import pandas as pd
from tqdm import tqdm

from microg.power.design import Design, PowerInputError
from microg.power.effects import Effects
from microg.power.montecarlo import SIMULATION_COLUMNS, montecarlo_batch, power_table
from microg.power.plot import plot_power
from microg.study.protocol import Protocol

METHODS = ("exact", "montecarlo")
POWER_COLUMNS = ("n_per_group", "term", "power", "ci_low", "ci_high", "method")
RECORD, SIMULATIONS, POWER, SUMMARY = "run.json", "simulations.csv", "power.csv", "summary.json"
CURVE = "power-curve.png"
P_FORMAT = "%.17g"
"""p values are written with every digit, so a resumed run reads back exactly what it computed."""
BATCH = 100
"""Data sets per Dask task (Monte Carlo): large enough that a task's overhead is small, small enough
that a lost worker costs little and the progress bar moves."""


@dataclass(frozen=True)
class PowerRequest:
    """What a run computes.

    ``effects`` are the expected effects (from a file or a pilot); None asks for in-silico studies
    of ``protocol`` (``measure`` of ``interaction``), which are Monte Carlo by nature.
    """

    design: Design
    method: str
    n_per_group: tuple[int, ...]
    effects: Effects | None = None
    protocol: Protocol | None = field(default=None, compare=False)
    alpha: float = 0.05
    target: float = 0.8
    sims: int = 1000
    seed: int = 1
    measure: str = "time_s"
    interaction: str | None = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise PowerInputError(f"--method = {self.method!r}: must be one of {list(METHODS)}")
        if self.effects is None and self.method == "exact":
            raise PowerInputError("--method exact with --simulated: in-silico studies can only be counted "
                                  "(--method montecarlo)")
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
    def source(self) -> str:
        return "simulated studies" if self.effects is None else self.effects.source

    def record(self) -> dict:
        """Everything the numbers depend on (``run.json``; a resumed run must match it)."""
        counted = self.method == "montecarlo"
        return {
            "method": self.method,
            "source": self.source,
            "design": self.design.as_dict(),
            "effects": None if self.effects is None else self.effects.as_dict(),
            "protocol_sha256": None if self.effects is not None else self.protocol.sha256,
            "measure": self.measure if self.effects is None else None,
            "interaction": (self.interaction or self.design.interactions[0]) if self.effects is None else None,
            "n_per_group": list(self.n_per_group),
            "alpha": self.alpha,
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
    _claim(out, record, resume)
    d = request.design
    workers_seen = 0
    if request.method == "exact":
        from microg.power.exact import exact_power

        table = exact_power(request.effects, request.n_per_group, request.alpha)
    else:
        results = out / SIMULATIONS
        done = _finished(results, len(d.tests)) if resume else set()
        if not done:
            results.write_text(",".join(SIMULATION_COLUMNS) + "\n")
        size = 1 if request.effects is None else batch
        missing = {n: [i for i in range(request.sims) if (n, i) not in done] for n in request.n_per_group}
        tasks = [(n, indices[start:start + size]) for n, indices in missing.items()
                 for start in range(0, len(indices), size)]  # fmt: skip
        if tasks:
            workers_seen = _compute(request, tasks, results, len(done), scheduler, workers, progress)
        simulations = pd.read_csv(results)
        table = power_table(simulations, request.alpha, request.method)
    order = {term: i for i, term in enumerate(d.tests)}
    table = table.sort_values(["n_per_group", "term"], key=lambda c: c.map(order) if c.name == "term" else c)
    table = table[list(POWER_COLUMNS)].reset_index(drop=True)
    table.to_csv(out / POWER, index=False)
    summary = _summary(request, table, time.monotonic() - started, scheduler, workers_seen)
    (out / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")
    counted = "studies" if request.effects is None else "data sets"
    title = f"{d.protocol}: {d.between} x {d.within}, {request.method}" + (
        f" ({request.sims} {counted} per n)" if request.method == "montecarlo" else "") + f", alpha {request.alpha:g}"
    plot_power(table, d.terms, request.target, out / CURVE, title, {c.name: c.family for c in d.contrasts})
    return PowerResult(table, summary, out)


def smallest_n(table: pd.DataFrame, target: float) -> dict:
    """For each test, the smallest n per group whose power reaches ``target`` (None: none does)."""
    found = {}
    for term, rows in table.groupby("term", sort=False):
        reached = rows.loc[rows["power"] >= target, "n_per_group"]
        found[term] = int(reached.min()) if len(reached) else None
    return found


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None) -> Iterator:
    """A Dask client: connected to ``scheduler``, or to a local cluster of ``workers`` single-threaded
    worker processes (default: one per core) that is shut down on exit."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as error:
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
    unit = "studies" if request.effects is None else "data sets"
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
    if request.effects is not None:
        return client.submit(montecarlo_batch, request.effects, n, indices, request.seed, request.alpha, pure=False)
    from microg.power.simulated import simulated_batch

    interaction = request.interaction or request.design.interactions[0]
    return client.submit(simulated_batch, request.protocol, request.design, n, indices, request.seed, request.alpha,
                         request.measure, interaction, pure=False)  # fmt: skip


def _claim(out: Path, record: dict, resume: bool) -> None:
    """Make ``out`` this run's folder: new, or the same run when resuming."""
    path = out / RECORD
    if path.exists():
        if not resume:
            raise PowerInputError(f"--out {out}: holds a power run already ({RECORD}); continue it with --resume "
                                  "or choose another --out")
        before = json.loads(path.read_text())
        for key, value in record.items():
            if before.get(key) != value:
                raise PowerInputError(f"--resume: {path}: {key} = {json.dumps(before.get(key))[:200]}, but this run "
                                      f"asks for {json.dumps(value)[:200]}; a run resumes only with the same settings")
        return
    out.mkdir(parents=True, exist_ok=True)
    for name in (SIMULATIONS, POWER, SUMMARY, CURVE):
        if (out / name).exists():
            raise PowerInputError(f"--out {out}: holds {name} from another run; choose another --out")
    path.write_text(json.dumps(record, indent=2) + "\n")


def _finished(results: Path, tests: int) -> set[tuple[int, int]]:
    """The (n, data set) pairs ``results`` holds completely; the file is rewritten without the rest (a
    line or batch cut off when the run was interrupted)."""
    if not results.exists():
        return set()
    lines = results.read_text().splitlines(keepends=True)
    whole = "".join(line for line in lines if line.endswith("\n"))  # a line cut off has no end
    if not whole:
        return set()
    table = pd.read_csv(io.StringIO(whole), dtype={"term": str})
    counts = table.groupby(["n_per_group", "sim"]).size()
    complete = counts[counts == tests].index
    kept = table[table.set_index(["n_per_group", "sim"]).index.isin(complete)]
    partial = results.with_suffix(".partial")
    kept.to_csv(partial, index=False, float_format=P_FORMAT)
    os.replace(partial, results)
    return {(int(n), int(i)) for n, i in complete}


def _summary(request: PowerRequest, table: pd.DataFrame, seconds: float, scheduler: str | None,
             workers: int) -> dict:
    d = request.design
    counted = request.method == "montecarlo"
    how = ("exact: one data set with exactly the expected means and covariances, the report's mixed ANOVA and "
           "post hoc on it, power from the noncentral F (terms) and t (contrasts); sphericity assumed"
           if not counted else
           "Monte Carlo: each data set analysed as the report does (type 3 mixed ANOVA, Greenhouse-Geisser when "
           "Mauchly's p < alpha, Bonferroni post hoc); 95 % Clopper-Pearson interval")  # fmt: skip
    return {
        "target": request.target,
        "smallest_n_per_group": smallest_n(table, request.target),
        "n_per_group": list(request.n_per_group),
        "method": request.method,
        "how": how,
        "source": request.source,
        "design": d.as_dict(),
        "alpha": request.alpha,
        "sims": request.sims if counted else None,
        "seed": request.seed if counted else None,
        "seconds": round(seconds, 2),
        "cluster": (scheduler or "local") if counted else None,
        "workers": workers if counted else None,
    }
