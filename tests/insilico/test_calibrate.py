"""``microg.insilico.calibrate``'s machinery on Dask: the same seed gives the same posterior with one
worker and with two (a real cluster), and a run killed mid-generation continues (``resume``) to the
posterior of an uninterrupted run. The studies are the closed form of tests/insilico/closed_form.py, so
that each run takes seconds; test_recovery.py calibrates against the real in-silico study."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import cloudpickle
import pytest

from microg.insilico.calibrate import CalibrationError, calibrate
from microg.participant import read_population
from microg.power.run import dask_client

from . import closed_form
from .closed_form import closed_form_request, closed_form_trials

cloudpickle.register_pickle_by_value(closed_form)  # the workers of the external cluster cannot import tests/
ROOT = Path(__file__).parents[2]
FILES = ("posterior.csv", "calibration.csv")
WAIT = 300.0
"""Seconds the killed run may take to reach its second generation on a busy machine."""


def run(folder: Path, client, resume: bool = False, **changes):
    request = closed_form_request()
    if changes:
        from dataclasses import replace

        request = replace(request, **changes)
    return calibrate(request, folder / "profile.toml", client, resume=resume, progress=False,
                     simulate=closed_form_trials)  # fmt: skip


def assert_same_run(one: Path, other: Path) -> None:
    for name in FILES:
        assert (one / name).read_text() == (other / name).read_text(), name
    assert read_population(one / "profile.toml").parameters == read_population(other / "profile.toml").parameters


@pytest.mark.slow
def test_one_and_two_workers_give_the_same_posterior(dask_cluster, tmp_path):
    with dask_client(None, 1) as client:
        one = run(tmp_path / "one", client)
    with dask_client(dask_cluster.address) as client:
        two = run(tmp_path / "two", client)
        with pytest.raises(CalibrationError, match="holds a calibration already"):
            run(tmp_path / "two", client)
        with pytest.raises(CalibrationError, match="particles = 8, but this run asks for 12"):
            run(tmp_path / "two", client, resume=True, particles=12)
    assert (one.summary["workers"], two.summary["workers"]) == (1, 2)
    assert_same_run(tmp_path / "one", tmp_path / "two")

    # what the run wrote: the profile with its fitted means, spreads and intervals, and the check
    profile = read_population(tmp_path / "one" / "profile.toml")
    posterior = one.posterior.set_index("value")
    for name in ("hold_margin_s", "hesitation_s"):
        spread = profile.parameters[name]
        assert spread.ci_low <= spread.mean <= spread.ci_high
        assert spread.mean == pytest.approx(posterior.loc[name, "mean"])
    hesitation = profile.parameters["hesitation_s"]
    assert 0 < hesitation.sd <= hesitation.mean * 1.0  # the spread fitted as sd / mean in [0, 1]
    assert profile.parameters["aim_sd"] == read_population_default("aim_sd")
    calibration = profile.calibration
    assert calibration["fitted_to"] == "closed-form pilot" and calibration["seed"] == 11
    assert len(calibration["measures_fitted"]) == len(one.check) and calibration["measures_held_out"] == []
    check = one.check
    assert list(check.columns[:6]) == ["measure", "data", "se", "simulated_mean", "simulated_low", "simulated_high"]
    assert set(check["use"]) == {"fitted"} and (check["studies"] <= 3).all()
    assert (tmp_path / "one" / "calibration.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def read_population_default(name: str):
    from microg.participant import default_population

    return default_population().parameters[name]


def evaluations(folder: Path, stage: str) -> int:
    path = folder / "calibration-evaluations.db"
    if not path.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5) as db:
            return db.execute("SELECT COUNT(*) FROM evaluations WHERE stage = ?", (stage,)).fetchone()[0]
    except sqlite3.OperationalError:  # the table is not there yet
        return 0


@pytest.mark.slow
def test_a_killed_run_resumes_to_the_posterior_of_an_uninterrupted_one(dask_cluster, tmp_path):
    cut = tmp_path / "cut"
    log = (tmp_path / "child.log").open("w")
    child = subprocess.Popen([sys.executable, "-m", "tests.insilico.closed_form", dask_cluster.address,
                              str(cut / "profile.toml")], cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)  # fmt: skip
    try:
        deadline = time.monotonic() + WAIT
        while evaluations(cut, "generation 1") < 3:
            assert child.poll() is None, (tmp_path / "child.log").read_text()
            assert time.monotonic() < deadline, f"the run did not reach its second generation: {evaluations(cut, 'prior')} " \
                                                 "prior studies written"
            time.sleep(0.05)
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        log.close()
    assert not (cut / "profile.toml").exists() and (cut / "calibration.db").exists()
    with dask_client(dask_cluster.address) as client:
        resumed = run(cut, client, resume=True)
        whole = run(tmp_path / "whole", client)
    assert_same_run(cut, tmp_path / "whole")
    assert resumed.summary["studies_run"] < whole.summary["studies_run"]  # the finished studies were kept
