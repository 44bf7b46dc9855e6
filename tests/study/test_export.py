"""Export: the tidy tables' schemas, CSV and Parquet round trips, Motion-BIDS names and contents."""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

from microg.study.assignment import Participant
from microg.study.export import export_study, read_tables, run_frames, run_list
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import create_study

from .conftest import PROTOCOLS, answers, scripted_inputs

SPEC_TRIALS = ["study", "participant", "group", "gender", "age", "handedness", "mr_experience", "phase", "interaction",
               "object", "order_position", "completed", "time_s", "attempts", "started_at", "ended_at"]
SPEC_QUESTIONNAIRE = ["participant", "group", "interaction", "item", "rating"]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """One study with one finished session, shared by the tests here (they only read it)."""
    store = create_study(tmp_path_factory.mktemp("export") / "study", load_protocol(PROTOCOLS / "tiny.toml"), 1)
    record = store.add_participant(Participant("P01", "female", 24, "right", True))
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, scripted_inputs(), clock=SimulationClock(), rater=answers("7", "6", "3", "4"))
    yield store, record
    store.close()


def test_the_trials_table_has_the_tidy_schema(study):
    store, record = study
    trials, questionnaire = read_tables(store.dir)
    assert trials.columns[:len(SPEC_TRIALS)].tolist() == SPEC_TRIALS
    assert {"simulated", "status"} <= set(trials.columns)
    phase_rows = trials[trials.phase != "training"]
    assert phase_rows[["phase", "interaction", "object"]].values.tolist() == [
        ["stage1", "impulse_penetration", "C"], ["stage2", "soft_hand", "C"]]
    assert (trials.participant == "P01").all() and (trials.group == record.group).all()
    assert trials.simulated.all() and trials.completed.all()
    assert trials.time_s.dtype == np.float64 and str(trials.attempts.dtype) == "Int64"
    assert (trials.ended_at - trials.started_at >= trials.time_s).all()
    assert set(SPEC_QUESTIONNAIRE) <= set(questionnaire.columns) and "simulated" in questionnaire.columns
    assert len(questionnaire) == 4 and questionnaire.rating.tolist() == [6, 7, 4, 3]  # sorted by interaction, item


def test_csv_and_parquet_exports_read_back_as_the_same_tables(study, tmp_path):
    store, _ = study
    out = tmp_path / "export"
    export_study(store.dir, out, progress=False)
    from_db = read_tables(store.dir)
    for table, csv, parquet in zip(from_db, ("trials.csv", "questionnaire.csv"), ("trials.parquet",
                                                                                  "questionnaire.parquet")):
        pd.testing.assert_frame_equal(pd.read_parquet(out / parquet), table)
        # a column with no value (station, in a study run in one place; flipped, in one without a stop of a
        # spin; criterion_met, in one without a phase trained to a criterion) reads back as its type only when told
        told = {"station": "string", "flipped": "boolean", "criterion_met": "boolean"} if csv == "trials.csv" \
            else {"station": "string"}
        pd.testing.assert_frame_equal(pd.read_csv(out / csv, dtype=told), table, check_dtype=False)
    pd.testing.assert_frame_equal(read_tables(out)[0], from_db[0])
    frames = pd.read_parquet(out / "frames.parquet")
    assert len(frames) == store.db.execute("SELECT SUM(count) FROM frames").fetchone()[0]
    assert {"right_index_tip_x", "rendered_right_thumb_proximal_z", "px", "qw", "touching"} <= set(frames.columns)


def test_an_export_never_overwrites_silently(study, tmp_path):
    store, _ = study
    out = tmp_path / "export"
    export_study(store.dir, out, bids=False, frames=False, progress=False)
    with pytest.raises(FileExistsError, match="export exists; export into another folder or pass --overwrite"):
        export_study(store.dir, out, bids=False, frames=False, progress=False)
    export_study(store.dir, out, bids=False, frames=False, overwrite=True, progress=False)


def test_an_export_cut_off_midway_leaves_no_folder_that_reads_as_complete(study, tmp_path, monkeypatch):
    store, _ = study
    out = tmp_path / "export"
    from microg.study import bids

    def crash(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(bids, "write_motion_bids", crash)
    with pytest.raises(KeyboardInterrupt):
        export_study(store.dir, out, progress=False)
    assert not out.exists() and (tmp_path / "export.partial" / "frames.parquet").exists()
    monkeypatch.undo()
    said = []
    export_study(store.dir, out, progress=False, say=said.append)
    assert "cut off before it finished" in said[0] and not (tmp_path / "export.partial").exists()
    assert (out / "bids" / "dataset_description.json").exists() and (out / "export.json").exists()


NAME = re.compile(r"sub-P01_task-(training|stage1|stage2)_tracksys-hand_acq-(cube|ball)_run-1_"
                  r"(motion\.tsv|motion\.json|channels\.tsv|channels\.json|events\.tsv|events\.json)")


def test_motion_bids_files_are_named_and_shaped_as_the_specification_says(study, tmp_path):
    store, _ = study
    out = tmp_path / "export"
    export_study(store.dir, out, progress=False)
    bids = out / "bids"
    description = json.loads((bids / "dataset_description.json").read_text())
    assert {"Name", "BIDSVersion"} <= set(description)
    assert "sub-P01" in (bids / "participants.tsv").read_text().splitlines()[1]
    files = sorted(p.name for p in (bids / "sub-P01" / "motion").iterdir())
    runs = run_list(store)
    assert len(files) == 6 * len(runs) and all(NAME.fullmatch(f) for f in files)

    for run in runs:
        stem = f"sub-P01_task-{run['phase']}_tracksys-hand_acq-{run['object']}_run-1"
        folder = bids / "sub-P01" / "motion"
        channels = pd.read_csv(folder / f"{stem}_channels.tsv", sep="\t")
        assert channels.columns[:5].tolist() == ["name", "component", "type", "tracked_point", "units"]
        assert set(channels.type) == {"LATENCY", "POS", "ORNT"}
        assert set(channels[channels.type == "ORNT"].component) == {"quat_x", "quat_y", "quat_z", "quat_w"}
        motion_text = (folder / f"{stem}_motion.tsv").read_text()
        first = motion_text.splitlines()[0].split("\t")
        assert all(v == "n/a" or re.fullmatch(r"-?[\d.e+-]+", v) for v in first)  # no header row
        motion = pd.read_csv(folder / f"{stem}_motion.tsv", sep="\t", header=None, na_values="n/a")
        frames = run_frames(store, run["run_id"])
        assert motion.shape == (len(frames), len(channels))
        named = dict(zip(channels.name, range(len(channels))))
        assert np.allclose(motion[named["latency"]], frames.t - frames.t.iloc[0])
        assert np.allclose(motion[named["px"]], frames.px) and np.allclose(motion[named["qw"]], frames.qw)
        sidecar = json.loads((folder / f"{stem}_motion.json").read_text())
        assert sidecar["TaskName"] == run["phase"] and sidecar["SamplingFrequency"] == 110.0
        assert sidecar["MotionChannelCount"] == len(channels)
        events = pd.read_csv(folder / f"{stem}_events.tsv", sep="\t")
        assert events.columns[:3].tolist() == ["onset", "duration", "trial_type"]
        assert {"place_lit", "place_done", "completed"} <= set(events.trial_type)
        assert (events.onset >= 0).all() and events.onset.is_monotonic_increasing
