"""``microg power --scheduler`` on a real Dask cluster (a scheduler and two workers started as processes
on 127.0.0.1): the same numbers as the local run and as the same data sets analysed without Dask,
also when a worker is killed mid-run."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from microg.cli import main
from microg.power import montecarlo_batch, power_table, read_effects

from .conftest import kill, worker_count

MICROG = Path(sys.executable).with_name("microg")


def without_dask(effects_file, design, sizes, sims, seed) -> pd.DataFrame:
    effects = read_effects(effects_file, design)
    rows = pd.concat([montecarlo_batch(effects, n, range(sims), seed=seed, alpha=0.05) for n in sizes])
    return power_table(rows, 0.05, "montecarlo")


def assert_same(table: pd.DataFrame, expected: pd.DataFrame) -> None:
    merged = table.merge(expected, on=["n_per_group", "term"], suffixes=("", "_expected"), validate="one_to_one")
    assert len(merged) == len(expected) == len(table)
    for column in ("power", "ci_low", "ci_high"):
        assert (merged[column] == merged[f"{column}_expected"]).all(), column


def test_the_scheduler_gives_the_numbers_of_the_local_run(dask_cluster, effects_file, design, tmp_path):
    common = ["power", "--effects", str(effects_file), "--method", "montecarlo", "--sims", "250", "--n", "5,9",
              "--seed", "21", "--batch", "25"]  # fmt: skip
    remote = CliRunner().invoke(main, [*common, "--scheduler", dask_cluster.address, "--out", str(tmp_path / "remote")])
    assert remote.exit_code == 0, remote.output
    local = CliRunner().invoke(main, [*common, "--workers", "1", "--out", str(tmp_path / "local")])
    assert local.exit_code == 0, local.output
    remote_table, local_table = (pd.read_csv(tmp_path / name / "power.csv") for name in ("remote", "local"))
    assert remote_table.equals(local_table)
    assert_same(remote_table, without_dask(effects_file, design, (5, 9), 250, 21))
    assert '"workers": 2' in (tmp_path / "remote" / "summary.json").read_text()


def test_a_killed_worker_loses_only_its_tasks_in_flight(dask_cluster, effects_file, design, tmp_path):
    sizes, sims, seed = (6, 8, 10, 12), 2000, 5
    out = tmp_path / "run"
    results = out / "simulations.csv"
    tests = len(design.tests)
    log = (tmp_path / "run.log").open("w")
    run = subprocess.Popen([str(MICROG), "power", "--effects", str(effects_file), "--method", "montecarlo",
                            "--sims", str(sims), "--n", ",".join(map(str, sizes)), "--seed", str(seed),
                            "--batch", "10", "--scheduler", dask_cluster.address, "--out", str(out)],
                           stdout=log, stderr=subprocess.STDOUT)  # fmt: skip
    try:
        # wait until results are being written (a generous limit for a busy machine, not a timing assumption)
        deadline = time.monotonic() + 300
        while not results.exists() or results.read_text().count("\n") < 1 + 20 * tests:
            assert run.poll() is None, (tmp_path / "run.log").read_text()
            assert time.monotonic() < deadline, "no results were written"
            time.sleep(0.02)
        written = results.read_text().count("\n") - 1
        kill(dask_cluster.workers[0])
        assert run.poll() is None and written < len(sizes) * sims * tests, "the run ended before the kill"
        assert run.wait(timeout=900) == 0, (tmp_path / "run.log").read_text()
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
        log.close()
    assert worker_count(dask_cluster.address) == 1
    rows = pd.read_csv(results)
    assert len(rows) == len(sizes) * sims * tests and not rows.duplicated(["n_per_group", "sim", "term"]).any()
    assert_same(pd.read_csv(out / "power.csv"), without_dask(effects_file, design, sizes, sims, seed))
