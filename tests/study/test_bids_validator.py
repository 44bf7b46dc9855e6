"""The Motion-BIDS export as another tool reads it: the BIDS validator (the schema-based one,
``bids-validator-deno`` from the dev extra) finds no error and no warning that the export could avoid."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from microg.study.assignment import Participant
from microg.study.export import export_study
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import create_study

from .conftest import PROTOCOLS, answers, scripted_inputs

pytest.importorskip("bids_validator_deno", reason="needs the dev extra's bids-validator-deno")

UNAVOIDABLE = {
    ("JSON_KEY_RECOMMENDED", "HEDVersion"): "the events are not annotated with HED tags",
    ("JSON_KEY_RECOMMENDED", "SourceDatasets"): "the data are raw: no dataset they were derived from",
}
"""Warnings the export cannot honestly avoid, and why."""


def validator() -> str:
    return shutil.which("bids-validator-deno", path=str(Path(sys.executable).parent)) or \
        shutil.which("bids-validator-deno")


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    """Two participants (one trains: the training's ball is exported too), exported whole."""
    folder = tmp_path_factory.mktemp("bids")
    with create_study(folder / "study", load_protocol(PROTOCOLS / "tiny.toml"), 1) as store:
        for pid in ("P01", "P02"):
            store.add_participant(Participant(pid, "female", 24, "right", True))
            session = store.create_session(pid, input_spec="scripted", simulated=True, clock="simulation")
            run_session(store, session.id, scripted_inputs(), clock=SimulationClock(),
                        rater=answers("7", "6", "3", "4"))
        assert {p.group for p in store.participants()} == {"V", "B"}
    export_study(folder / "study", folder / "export")
    return folder / "export" / "bids"


def test_the_bids_validator_finds_no_error_and_no_avoidable_warning(exported):
    result = subprocess.run([validator(), "--format", "json", str(exported)], capture_output=True, text=True)
    report = json.loads(result.stdout)
    issues = report["issues"]["issues"]
    errors = [i for i in issues if i["severity"] == "error"]
    assert errors == [] and result.returncode == 0, errors
    warnings = {(i["code"], i.get("subCode")) for i in issues if i["severity"] == "warning"}
    assert warnings <= set(UNAVOIDABLE), warnings - set(UNAVOIDABLE)
    summary = report["summary"]
    assert sorted(summary["subjects"]) == ["P01", "P02"] and set(summary["tasks"]) == {"training", "stage1", "stage2"}
    assert "motion" in summary["modalities"]
