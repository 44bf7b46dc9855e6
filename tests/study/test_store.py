"""The study database under faults and misuse: files that are not studies, another program holding
the database or a session, a full disk, forged or damaged logs, colliding ids. Each ends in a clear
error (never a traceback), nothing committed is lost and nothing is written that should not be."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study import framelog, store as store_module
from microg.study.assignment import Participant, ParticipantError
from microg.study.export import export_study
from microg.study.store import DamagedStudyError, StoreError, open_study
from tests.waiting import ended, line_reader, next_item

ROOT = Path(__file__).resolve().parents[2]


def cli(*args: str):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in result.output
    return result


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def holder(tmp_path):
    """``holder(what, study_dir)``: ``tests.study.holder`` in its own process, once it holds what it
    holds; closing its standard input (``release``) lets go."""
    children = []

    def start(what: str, study_dir: Path) -> subprocess.Popen:
        child = subprocess.Popen([sys.executable, "-m", "tests.study.holder", what, str(study_dir)], cwd=ROOT,
                                 stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        children.append(child)
        assert next_item(line_reader(child.stdout), f"the holder of {what} to say it holds it") == "held\n"
        return child

    yield start
    for child in children:
        release(child)


def release(child: subprocess.Popen) -> None:
    if child.poll() is None:
        child.stdin.close()
        ended(child, "the process holding the study")


@pytest.mark.parametrize("content, message", [
    (b"", "the file is empty, not a study database"),
    (b"participant,group\nP01,V\n", "not a SQLite database (it starts with b'participant,gro"),
])
def test_a_study_db_that_is_no_database_is_named_and_never_written(tmp_path, content, message):
    (tmp_path / "study.db").write_bytes(content)
    for verb in (["study", "status"], ["study", "check"], ["participant", "list"], ["export"]):
        result = cli(*verb, tmp_path)
        assert result.exit_code == 1 and message in result.output, (verb, result.output)
    assert (tmp_path / "study.db").read_bytes() == content
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.db"]


def test_another_sqlite_database_is_not_taken_for_a_study(tmp_path):
    sqlite3.connect(tmp_path / "study.db").execute("CREATE TABLE notes (text TEXT)")
    result = cli("study", "status", tmp_path)
    assert result.exit_code == 1 and "a SQLite database but not a microg study" in result.output


def test_a_study_of_an_older_schema_is_refused_naming_both_versions(make_study):
    """Issue 12 renamed the store's columns (``tasks.system`` and ``answers.system`` became
    ``interaction``): a study written before is refused with the versions, and is left as it was."""
    store, _ = make_study("tiny")
    store.close()
    database = store.dir / "study.db"
    with sqlite3.connect(database) as db:
        db.execute("DROP TRIGGER study_no_update")
        db.execute("UPDATE study SET schema_version = 3")
    db.close()
    before = digest(database)
    for verb in (["study", "status"], ["export"], ["report"]):
        result = cli(*verb, store.dir, *(["--out", store.dir.parent / "report"] if verb == ["report"] else []))
        assert result.exit_code == 1, (verb, result.output)
        assert "schema version 3, this microg" in result.output and f"reads {store_module.SCHEMA_VERSION}" in \
            result.output, (verb, result.output)
    assert digest(database) == before
    with pytest.raises(StoreError, match="schema version 3"):
        open_study(store.dir)


def test_study_status_and_check_never_write_into_the_study(make_study):
    store, _ = make_study("tiny")
    store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.close()
    database, wal = store.dir / "study.db", store.dir / "study.db-wal"
    before = digest(database)
    assert cli("study", "status", store.dir).exit_code == 0
    assert cli("study", "check", store.dir).exit_code == 0
    assert digest(database) == before
    assert not wal.exists() or wal.stat().st_size == 0  # SQLite's reader files beside it hold nothing


def test_a_database_another_program_holds_gives_a_clear_error_and_loses_nothing(make_study, holder, monkeypatch):
    store, _ = make_study("tiny")
    store.close()
    monkeypatch.setattr(store_module, "BUSY_TIMEOUT_S", 0.2)  # the product waits 30 s; the wait is not what is tested
    child = holder("db", store.dir)
    add = ["participant", "add", store.dir, "--id", "P02", "--gender", "male", "--age", "30", "--handedness", "left",
           "--mr-experience", "no"]
    result = cli(*add)
    assert result.exit_code == 1
    assert "another program has held the study database for more than 0.2 s" in result.output
    assert "Close the program that holds it" in result.output
    release(child)
    assert cli(*add).exit_code == 0
    with open_study(store.dir) as again:
        assert [p.id for p in again.participants()] == ["P01", "P02"]


def test_a_full_disk_stops_the_write_whole_and_says_what_to_do(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    pages = store.db.execute("PRAGMA page_count").fetchone()[0]
    store.db.execute(f"PRAGMA max_page_count = {pages}")  # SQLite's own "disk full" at the current size
    logged = store.events(session.id)
    big = store_module.Event(1.0, "note", {"text": "x" * 100_000})
    with pytest.raises(StoreError, match="the disk is full .*this step was not written.*Free space on that disk"):
        store.log(session.id, [store_module.Event(0.5, "small", {}), big])
    assert store.events(session.id) == logged  # the two events went in together or not at all
    store.db.execute("PRAGMA max_page_count = 1073741823")
    store.log(session.id, [big])
    assert store.events(session.id)[-1] == big
    with open_study(store.dir, readonly=True) as again:
        assert again.problems == []


def test_a_full_disk_during_an_export_leaves_no_partial_export(make_study, tmp_path, monkeypatch):
    store, _ = make_study("tiny")
    import pandas as pd

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    with pytest.raises(StoreError, match="the disk is full .*the export stopped and was removed"):
        export_study(store.dir, tmp_path / "out", frames=False, bids=False, progress=False)
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()


def forge(study_dir: Path, *statements: str) -> None:
    """What another program might do to the database behind microg's back."""
    with sqlite3.connect(study_dir / "study.db", isolation_level=None) as db:
        for statement in statements:
            db.execute(statement)


def test_a_forged_completed_run_is_found_and_not_exported_unless_accepted(make_study, tmp_path):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.close()
    forge(store.dir, "INSERT INTO task_runs (session_id, task_index, run, status, source, seed, started_at, "
                     f"ended_at, time_s, attempts, frames, started_wall) VALUES ({session.id}, 0, 1, 'completed', "
                     "'forged', 0, 0, 9, 9.0, 0, 0, 'now')")
    with pytest.raises(DamagedStudyError) as error:
        open_study(store.dir)
    problems = error.value.problems
    run = f"participant P01's session {session.id}, task 0 (stage1, cube), run 1 (task run 1)"
    assert problems == [f"the start of {run}: not in the ledger (written behind microg's back)",
                        f"the result of {run}: not in the ledger (written behind microg's back)",
                        f"task_runs row 1 (session {session.id}, task 0, run 1, completed): has 0 task_start and 0 "
                        "task_end events, not one of each: it was not written by a session",
                        f"task_runs row 1 (session {session.id}, task 0, run 1, completed): completed with 0 frames "
                        "and time_s = 9.0: a completed task has frames and a time"]
    result = cli("export", store.dir, "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 1 and "the study is damaged" in result.output and "--accept-damaged" in result.output
    assert not (tmp_path / "out").exists()
    result = cli("export", store.dir, "--out", tmp_path / "out", "--quiet", "--accept-damaged")
    assert result.exit_code == 0 and "warning: exporting a damaged study" in result.output
    assert json.loads((tmp_path / "out" / "export.json").read_text())["damaged"] == problems
    result = cli("study", "check", store.dir)
    assert result.exit_code == 1 and all(f"damaged: {p}" in result.output for p in problems)
    result = cli("study", "status", store.dir)
    assert result.exit_code == 0 and "the study is damaged (4 problem(s) above)" in result.output
    for verb in (["participant", "add", store.dir, "--id", "P02", "--gender", "male", "--age", "20", "--handedness",
                  "left", "--mr-experience", "no"], ["session", "resume", store.dir, "--participant", "P01"]):
        assert cli(*verb).exit_code == 1  # nothing more is written into a damaged log


TRIGGER = "CREATE TRIGGER protocols_no_update BEFORE UPDATE ON protocols\n" \
          "BEGIN SELECT RAISE(ABORT, 'protocols rows are never changed: the log is append-only'); END"


@pytest.mark.parametrize("statements, problem", [
    (["DROP TRIGGER frames_no_delete"], "trigger frames_no_delete is missing"),
    (["DROP TRIGGER events_while_running", "CREATE TRIGGER events_while_running BEFORE INSERT ON events "
      "BEGIN SELECT 1; END"], "trigger events_while_running differs from the one microg wrote"),
    (["DROP TRIGGER protocols_no_update",
      "UPDATE protocols SET resolved = replace(resolved, '\"hold_s\":0.5', '\"hold_s\":0.4')", TRIGGER],
     "protocols row 1: the stored protocol was changed after the study was made: its recorded sha256 is "),
])
def test_dropped_triggers_and_a_changed_protocol_are_found_on_open(make_study, statements, problem):
    store, _ = make_study("tiny")
    store.close()
    forge(store.dir, *statements)
    with pytest.raises(DamagedStudyError, match=problem):
        open_study(store.dir)
    result = cli("study", "check", store.dir)
    assert result.exit_code == 1 and problem in result.output


def test_study_check_reports_a_sound_study_and_a_forged_frame_batch(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    run_id = store.begin_run(session.id, task=store.tasks(session.id)[0], source="test", seed=0, t=0.0)
    store.close()
    result = cli("study", "check", store.dir)
    assert result.exit_code == 0 and "sound (1 task runs, 0 frames" in result.output
    forged = framelog.checksum(run_id, first=0, count=3, t_first=0.0, t_last=0.1, blob=b"\x00\xff\x00")  # sound by its checksum, not by the ledger
    forge(store.dir, f"INSERT INTO frames VALUES ({run_id}, 0, 3, 0.0, 0.1, x'{forged.hex()}', x'00ff00')")
    result = cli("study", "check", store.dir)
    batch = f"frames of participant P01's session {session.id}, task 0 (stage1, cube), run 1 (task run {run_id}), " \
            "the batch from frame 0"
    assert result.exit_code == 1, result.output
    assert f"damaged: {batch}: not in the ledger (written behind microg's back)" in result.output
    assert f"damaged: {batch} (3 frames): matches its checksum but does not decode" in result.output


def test_withdraw_refuses_while_another_process_runs_the_session(make_study, holder):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.close()
    child = holder("session", store.dir)
    result = cli("participant", "withdraw", store.dir, "--participant", "P01", "--reason", "felt unwell")
    assert result.exit_code == 1
    assert f"participant P01: session {session.id} is running right now (another process holds it)" in result.output
    with open_study(store.dir) as again:
        assert again.participant("P01").status == "active" and again.session(session.id).status == "running"
    release(child)  # the session's process ends with its task run open
    assert cli("participant", "withdraw", store.dir, "--participant", "P01", "--reason", "felt unwell").exit_code == 0
    with open_study(store.dir) as again:
        assert again.participant("P01").status == "withdrawn" and again.session(session.id).status == "aborted"
        run = again.runs(session.id)[0]
        reason = again.db.execute("SELECT reason FROM task_runs WHERE id = ?", (run.id,)).fetchone()[0]
        assert run.status == "interrupted" and "found when the participant was withdrawn" in reason
        assert again.events(session.id)[-1].kind == "session_end"
        with pytest.raises(StoreError, match="nothing is logged after its end"):
            again.log(session.id, [store_module.Event(1.0, "late", {})])
        with pytest.raises(StoreError, match="no task runs after its end"):
            again.begin_run(session.id, task=again.tasks(session.id)[1], source="late", seed=0, t=1.0)
        with pytest.raises(StoreError, match="no frames are logged after its end"):
            again.add_frames(run.id, 0, np.zeros(1, dtype=framelog.FRAME))


def test_participant_ids_map_one_to_one_onto_bids_labels(make_study):
    store, _ = make_study("tiny")
    for bad in ("Pé01", "P-01", "P 01", "", "P" * 65, "P٣"):
        with pytest.raises(ParticipantError, match="ASCII letters and digits"):
            store.add_participant(Participant(bad, "male", 25, "right", False))
    with pytest.raises(ParticipantError, match="participant id = 'p01': collides with participant 'P01'"):
        store.add_participant(Participant("p01", "male", 25, "right", False))
    result = cli("participant", "add", store.dir, "--id", "p01", "--gender", "male", "--age", "30", "--handedness",
                 "left", "--mr-experience", "no")
    assert result.exit_code == 1 and "ids that differ only in case" in result.output
    assert [p.id for p in store.participants()] == ["P01"]
