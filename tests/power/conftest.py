"""Shared set-up for the power tests: the paper's design, effects files, closed forms and a real
Dask cluster (a scheduler and two workers on 127.0.0.1, started as processes)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from microg.paths import protocol_file
from microg.power import design_from_protocol
from microg.study.protocol import load_protocol

HERE = Path(__file__).parent
DASK = Path(sys.executable).with_name("dask")
STARTUP_LIMIT = 120.0
"""Seconds a scheduler or worker may take to come up on a busy machine before the test gives up."""

ISSUE_EFFECTS = """\
sd = 20.0
correlation = 0.5
[means.veteran]
cube = 45.0
flat_cuboid = 55.0
long_cuboid = 55.0
[means.beginner]
cube = 55.0
flat_cuboid = 70.0
long_cuboid = 70.0
"""
"""The issue's example, verbatim."""


@pytest.fixture(scope="session")
def design():
    return design_from_protocol(load_protocol(protocol_file("paper")))


@pytest.fixture
def effects_file(tmp_path) -> Path:
    path = tmp_path / "effects.toml"
    path.write_text(ISSUE_EFFECTS)
    return path


def effects_text(means: dict, sd: float | None = None, correlation: float | None = None, extra: str = "") -> str:
    """An effects file: ``means`` {group: {level: mean}}, then sd/correlation and any extra lines."""
    lines = [f"sd = {sd!r}"] if sd is not None else []
    lines += [f"correlation = {correlation!r}"] if correlation is not None else []
    for group, row in means.items():
        lines.append(f"[means.{group}]")
        lines += [f"{level} = {value!r}" for level, value in row.items()]
    return "\n".join(lines) + "\n" + extra


def compound_symmetry_power(means: np.ndarray, sd: float, rho: float, n: int, alpha: float) -> dict:
    """Power of the group, within and interaction terms of a balanced mixed design under compound
    symmetry, from the textbook noncentralities (not from any data set):

    lambda_group = n k sum_g (m_g. - m..)^2 / (sd^2 (1 + (k - 1) rho)),
    lambda_within = n g sum_j (m_.j - m..)^2 / (sd^2 (1 - rho)),
    lambda_interaction = n sum_gj (m_gj - m_g. - m_.j + m..)^2 / (sd^2 (1 - rho)).
    """
    g, k = means.shape
    grand = means.mean()
    rows, columns = means.mean(axis=1), means.mean(axis=0)
    lambdas = {
        "between": n * k * np.sum((rows - grand) ** 2) / (sd**2 * (1 + (k - 1) * rho)),
        "within": n * g * np.sum((columns - grand) ** 2) / (sd**2 * (1 - rho)),
        "interaction": n * np.sum((means - rows[:, None] - columns[None, :] + grand) ** 2) / (sd**2 * (1 - rho)),
    }
    df2 = g * (n - 1)
    dfs = {"between": (g - 1, df2), "within": (k - 1, (k - 1) * df2), "interaction": ((g - 1) * (k - 1), (k - 1) * df2)}
    return {name: float(stats.ncf.sf(stats.f.isf(alpha, *dfs[name]), *dfs[name], lam)) for name, lam in lambdas.items()}


@dataclass
class Cluster:
    address: str
    workers: list
    logs: Path


def _spawn(arguments: list, log: Path) -> subprocess.Popen:
    return subprocess.Popen([str(DASK), *arguments], stdout=log.open("w"), stderr=subprocess.STDOUT,
                            cwd=HERE.parents[1])  # fmt: skip


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _address(scheduler_file: Path) -> str | None:
    """The address the scheduler wrote, once the file is complete."""
    try:
        return json.loads(scheduler_file.read_text())["address"]
    except (OSError, ValueError, KeyError):
        return None


@pytest.fixture
def dask_cluster(tmp_path):
    """A real Dask scheduler and two single-threaded workers (no nanny: one process each, so a test can
    kill a worker by its pid), all on 127.0.0.1 with ephemeral ports; shut down afterwards."""
    from distributed import Client

    logs = tmp_path / "dask-logs"
    logs.mkdir()
    address_file = tmp_path / "scheduler.json"
    processes = [_spawn(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--dashboard-address",
                         "127.0.0.1:0", "--scheduler-file", str(address_file)], logs / "scheduler.log")]  # fmt: skip
    try:
        deadline = time.monotonic() + STARTUP_LIMIT
        while (address := _address(address_file)) is None:
            log = (logs / "scheduler.log").read_text()
            assert processes[0].poll() is None and time.monotonic() < deadline, f"no scheduler came up: {log}"
            time.sleep(0.05)
        workers = [_spawn(["worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--nworkers", "1",
                           "--no-nanny", "--no-dashboard", "--dashboard-address", "127.0.0.1:0", "--memory-limit", "0",
                           "--name", f"w{i}"],
                          logs / f"worker{i}.log") for i in range(2)]  # fmt: skip
        processes += workers
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=STARTUP_LIMIT)
        yield Cluster(address, workers, logs)
    finally:
        for process in reversed(processes):
            _stop(process)


def worker_count(address: str) -> int:
    from distributed import Client

    with Client(address, timeout="60s") as client:
        return len(client.scheduler_info()["workers"])


def kill(process: subprocess.Popen) -> None:
    """SIGKILL one process we started (a worker), by its pid, and reap it."""
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
