"""Content integrity of the study's log: bytes damaged on disk, edits behind microg's back (with the
store's triggers dropped and re-created, with the ledger's digests recomputed, with the chain
rewritten), read-only archives, symbolic links as export targets. Each ends in a clear message
naming what is wrong, or in a correct result; nothing logged is lost or overwritten."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import sqlite3
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study import integrity, ledger, store as store_module
from microg.study.assignment import Participant
from microg.study.export import export_study, read_tables, run_frames
from microg.study.framelog import DamagedFramesError
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import DATABASE, DamagedStudyError, create_study, open_study

from .conftest import PROTOCOLS, answers, scripted_inputs

ADD_P02 = ("participant", "add", "--id", "P02", "--gender", "male", "--age", "30", "--handedness", "left",
           "--mr-experience", "no")


def cli(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in result.output, result.output
    return result


def add_p02(study: Path):
    return cli(*ADD_P02[:2], study, *ADD_P02[2:])


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A study whose one participant ran every task (scripted) and answered; closed, so its log is
    all in study.db. Tests damage copies of it (``copy``)."""
    folder = tmp_path_factory.mktemp("integrity") / "study"
    with create_study(folder, load_protocol(PROTOCOLS / "tiny.toml"), 1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
        session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
        run_session(store, session.id, scripted_inputs(), clock=SimulationClock(),
                    rater=answers("7", "6", "3", "4"))
    return folder


@pytest.fixture(scope="module")
def finished_long(tmp_path_factory) -> Path:
    """The finished study with long frame batches, whose blobs lie mostly on SQLite's overflow pages."""
    folder = tmp_path_factory.mktemp("integrity-long") / "study"
    with create_study(folder, load_protocol(PROTOCOLS / "tiny-long-batches.toml"), 1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
        session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
        run_session(store, session.id, scripted_inputs(), clock=SimulationClock(),
                    rater=answers("7", "6", "3", "4"))
    return folder


def copier(study: Path, tmp_path: Path):
    def make(name: str = "study") -> Path:
        target = tmp_path / name
        target.mkdir()
        for file in (DATABASE, ledger.HEAD_FILE):
            shutil.copy2(study / file, target / file)
        return target
    return make


@pytest.fixture
def copy(finished, tmp_path):
    """``copy(name)``: a fresh copy of the finished study (its database and ledger head)."""
    return copier(finished, tmp_path)


@pytest.fixture
def copy_long(finished_long, tmp_path):
    """``copy_long(name)``: a fresh copy of the finished study with long frame batches."""
    return copier(finished_long, tmp_path)


def query(study: Path, sql: str, *args):
    with sqlite3.connect(f"file:{study / DATABASE}?mode=ro", uri=True) as db:
        return db.execute(sql, args).fetchall()


def forge(study: Path, *statements) -> None:
    """What another program might do to the database behind microg's back."""
    db = sqlite3.connect(study / DATABASE, isolation_level=None)
    for statement in statements:
        db.execute(*statement) if isinstance(statement, tuple) else db.execute(statement)
    db.close()


def damage(path: Path, needle: bytes, replacement: bytes) -> None:
    """Overwrite bytes in the file itself (what a failing disk or a bad copy does), where ``needle``
    occurs exactly once."""
    data = path.read_bytes()
    assert data.count(needle) == 1 and len(replacement) == len(needle)
    path.write_bytes(data.replace(needle, replacement))


def completed_run(study: Path) -> tuple[int, int, str, str, float]:
    """(run id, task index, phase, object, time_s) of the first completed run."""
    return query(study, "SELECT r.id, r.task_index, t.phase, t.object, r.time_s FROM task_runs r JOIN tasks t "
                        "ON t.session_id = r.session_id AND t.task_index = r.task_index "
                        "WHERE r.status = 'completed' ORDER BY r.id LIMIT 1")[0]


def run_named(study: Path, run_id: int) -> str:
    task, phase, obj, run = query(study, "SELECT r.task_index, t.phase, t.object, r.run FROM task_runs r JOIN tasks t "
                                         "ON t.session_id = r.session_id AND t.task_index = r.task_index "
                                         "WHERE r.id = ?", run_id)[0]
    return f"participant P01's session 1, task {task} ({phase}, {obj}), run {run} (task run {run_id})"


def test_every_column_of_the_store_is_covered_by_one_fact(finished):
    """The ledger covers the whole log: a column no fact covers could be changed unseen (a frame
    batch's blob is covered by its checksum, a fact's key names its row)."""
    tables = [name for (name,) in query(finished, "SELECT name FROM sqlite_master WHERE type = 'table'")]
    assert set(tables) == {fact.table for fact in ledger.FACTS} | {"ledger"}
    for table in set(tables) - {"ledger"}:
        columns = [row[1] for row in query(finished, f"PRAGMA table_info({table})")]
        facts = [fact for fact in ledger.FACTS if fact.table == table]
        covered = [c for fact in facts for c in fact.columns]
        keys = {c for fact in facts for c in fact.key}
        assert sorted(covered) == sorted(set(covered)), table
        assert set(columns) - keys - set(covered) == ({"data"} if table == "frames" else set()), table


def test_a_sound_study_checks_sound_and_names_its_head(finished):
    result = cli("study", "check", finished)
    assert result.exit_code == 0, result.output
    head = json.loads((finished / ledger.HEAD_FILE).read_text())
    assert f"ledger head: {head['entry']}:{head['link']}" in result.output
    assert head["entry"] == query(finished, "SELECT COUNT(*) FROM ledger")[0][0]
    assert cli("study", "check", finished, "--head", f"{head['entry']}:{head['link']}").exit_code == 0


def test_bytes_damaged_inside_a_frame_batch_are_found_and_never_exported(copy, tmp_path):
    study = copy()
    run_id, task, *_ = completed_run(study)
    batches = query(study, "SELECT first, data FROM frames WHERE run_id = ? ORDER BY first", run_id)
    first, blob = batches[len(batches) // 2]
    data = (study / DATABASE).read_bytes()
    needle = next(blob[i:i + 24] for i in range(len(blob) // 2, len(blob) - 24, 7) if data.count(blob[i:i + 24]) == 1)
    damage(study / DATABASE, needle, needle[:12] + bytes([needle[12] ^ 0x10]) + needle[13:])
    batch = f"frames of {run_named(study, run_id)}, the batch from frame {first}"

    result = cli("study", "check", study)
    assert result.exit_code == 1 and f"damaged: {batch} (" in result.output and "does not match its checksum" \
        in result.output, result.output
    result = cli("export", study, "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 1 and batch in result.output and "Nothing was exported" in result.output
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()
    result = cli("view", study, "--session", "P01", "--task", task, "--out", tmp_path / "strip.png")
    assert result.exit_code == 1 and batch in result.output and not (tmp_path / "strip.png").exists()
    with open_study(study, readonly=True) as store, pytest.raises(DamagedFramesError, match=re.escape(batch)):
        run_frames(store, run_id)

    result = cli("export", study, "--out", tmp_path / "out", "--quiet", "--accept-damaged", "--no-bids")
    assert result.exit_code == 0 and f"warning: left out of the frames and Motion-BIDS: {batch}" in result.output
    manifest = json.loads((tmp_path / "out" / "export.json").read_text())
    assert manifest["frames_left_out"] == [run_id] and any(batch in p for p in manifest["damaged"])
    frames = pd.read_parquet(tmp_path / "out" / "frames.parquet", columns=["run_id"])
    assert run_id not in set(frames.run_id) and len(frames) == query(
        study, "SELECT SUM(count) FROM frames WHERE run_id != ?", run_id)[0][0]  # every other frame is there
    assert len(pd.read_csv(tmp_path / "out" / "trials.csv")) == query(study, "SELECT COUNT(*) FROM tasks")[0][0]


def test_a_damaged_task_plan_stops_every_verb_that_writes(copy):
    """Bytes of a planned task changed on disk (stage2 -> stage1): SQLite's own check cannot see it;
    the ledger can, so nothing is written into the study."""
    study = copy()
    task, = [t for (t,) in query(study, "SELECT task_index FROM tasks WHERE phase = 'stage2'")]
    damage(study / DATABASE, b"stage2soft_hand", b"stage1soft_hand")
    before = sha256(study / DATABASE)
    problem = f"the plan of session 1, task {task}: changed after it was written"
    for result in (add_p02(study), cli("session", "resume", study, "--participant", "P01")):
        assert result.exit_code == 1 and "the study is damaged" in result.output and problem in result.output
        assert "microg study check" in result.output  # how to inspect it
    result = cli("study", "check", study)
    assert result.exit_code == 1 and f"damaged: {problem}" in result.output
    assert "SQLite integrity check" not in result.output
    assert sha256(study / DATABASE) == before


def trigger(name: str) -> str:
    """The trigger as schema.sql writes it, to re-create after dropping it."""
    return store_module._schema_triggers()[name]


def forge_time(study: Path) -> tuple[int, float]:
    """A finished run's time changed, with the store's trigger dropped and re-created as it was."""
    run_id, *_, time_s = completed_run(study)
    forge(study, "DROP TRIGGER task_runs_once",
          ("UPDATE task_runs SET time_s = ? WHERE id = ?", (time_s - 1.0, run_id)), trigger("task_runs_once"))
    return run_id, time_s


def test_a_finished_runs_forged_time_is_found_and_neither_exported_nor_reported(copy, tmp_path):
    study = copy()
    run_id, true_time = forge_time(study)
    with pytest.raises(DamagedStudyError) as error:
        open_study(study, readonly=True)
    entry = query(study, "SELECT seq FROM ledger WHERE fact = 'result' AND key = ?", f"[{run_id}]")[0][0]
    assert error.value.problems == [
        f"the result of {run_named(study, run_id)}: changed after it was written (it no longer matches ledger entry "
        f"{entry})",
        f"task_runs row {run_id} (session 1, task {completed_run(study)[1]}, run 1, completed): time_s = "
        f"{true_time - 1.0!r}, but its task_end event says {true_time!r}"]
    result = cli("study", "check", study)
    assert result.exit_code == 1 and all(f"damaged: {p}" in result.output for p in error.value.problems)
    result = cli("export", study, "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 1 and "the study is damaged" in result.output and not (tmp_path / "out").exists()
    result = cli("report", study, "--out", tmp_path / "report")
    assert result.exit_code == 1 and "the study is damaged" in result.output
    assert not (tmp_path / "report").exists()


def reseal(study: Path, facts: list[tuple[str, tuple]], relink: bool) -> None:
    """What a forger who knows the method does: recompute the changed facts' digests in the ledger
    and, with ``relink``, every link of the chain after them."""
    db = sqlite3.connect(study / DATABASE, isolation_level=None)
    db.execute("DROP TRIGGER ledger_no_update")
    for name, key in facts:
        fact = ledger.FACT[name]
        row = db.execute(fact.select_one(), key).fetchone()
        db.execute("UPDATE ledger SET digest = ? WHERE fact = ? AND key = ?",
                   (ledger.digest(fact, row), name, ledger.key_text(key)))
    if relink:
        previous = ledger.GENESIS
        for seq, digest in db.execute("SELECT seq, digest FROM ledger ORDER BY seq").fetchall():
            previous = ledger.link(previous, digest)
            db.execute("UPDATE ledger SET link = ? WHERE seq = ?", (previous, seq))
    db.execute(trigger("ledger_no_update"))
    db.close()


def test_recomputed_digests_break_the_chain_and_a_rewritten_chain_misses_its_head(copy, tmp_path):
    """The forger of the test above, knowing more at each step: with the run's end event forged too
    and both digests recomputed, the chain's links no longer follow; with the chain rewritten, the
    head beside the database no longer matches; with that rewritten too the check is sound, and
    only a head noted earlier (an export's) shows the rewrite: the limit the docs state."""
    study = copy()
    assert cli("export", study, "--out", tmp_path / "before", "--quiet", "--no-frames", "--no-bids").exit_code == 0
    noted = json.loads((tmp_path / "before" / "export.json").read_text())["ledger_head"]
    run_id, true_time = forge_time(study)
    (event_id, data), = query(study, "SELECT id, data FROM events WHERE run_id = ? AND kind = 'task_end'", run_id)
    forged = json.dumps(json.loads(data) | {"time_s": true_time - 1.0}, sort_keys=True, separators=(",", ":"))
    forge(study, "DROP TRIGGER events_no_update", ("UPDATE events SET data = ? WHERE id = ?", (forged, event_id)),
          trigger("events_no_update"))

    reseal(study, [("result", (run_id,)), ("event", (event_id,))], relink=False)
    with pytest.raises(DamagedStudyError) as error:
        open_study(study, readonly=True)
    first, = [seq for (seq,) in query(study, "SELECT MIN(seq) FROM ledger WHERE (fact = 'result' AND key = ?) OR "
                                             "(fact = 'event' AND key = ?)", f"[{run_id}]", f"[{event_id}]")]
    assert len(error.value.problems) == 1 and error.value.problems[0].startswith(f"ledger entry {first} (")
    assert "its link does not follow from the entries before it" in error.value.problems[0]

    reseal(study, [], relink=True)
    result = cli("study", "check", study)
    assert result.exit_code == 1 and "ledger-head.json names ledger entry" in result.output
    assert "the ledger was rewritten after that entry was committed" in result.output

    with sqlite3.connect(study / DATABASE) as db:
        seq, link = db.execute("SELECT seq, link FROM ledger ORDER BY seq DESC LIMIT 1").fetchone()
    db.close()
    (study / ledger.HEAD_FILE).write_text(json.dumps({"entry": seq, "link": link.hex()}))
    assert cli("study", "check", study).exit_code == 0  # what the chain alone cannot see
    result = cli("study", "check", study, "--head", noted)
    assert result.exit_code == 1 and f"--head {noted} names ledger entry" in result.output


def test_a_cut_log_is_found_by_its_head(copy):
    """The session's end removed, rows and ledger entries alone (the chain before them intact): the
    head beside the database still names the entries that are gone."""
    study = copy()
    last = query(study, "SELECT MAX(seq) FROM ledger")[0][0]
    forge(study, "DROP TRIGGER ledger_no_delete", "DROP TRIGGER events_no_delete", "DROP TRIGGER sessions_once",
          "DELETE FROM events WHERE kind = 'session_end'", "UPDATE sessions SET status = 'running', ended_at = NULL",
          f"DELETE FROM ledger WHERE seq > {last - 2}", trigger("ledger_no_delete"), trigger("events_no_delete"),
          trigger("sessions_once"))
    with pytest.raises(DamagedStudyError) as error:
        open_study(study)
    assert error.value.problems == [f"{study / ledger.HEAD_FILE} names ledger entry {last}, but the ledger ends at "
                                    f"entry {last - 2}: entries were removed after it was written, or study.db was "
                                    "put back from an older copy (a power cut during a simulated session can lose "
                                    "its last commits too)"]


@pytest.mark.parametrize("statements, problem", [
    (["DROP TRIGGER answers_no_update", "UPDATE answers SET value = 10 WHERE item = 'naturalness' AND value = 7",
      "answers_no_update"], "the answer of session 1 to paper item naturalness (questionnaire, about "
                            "impulse_penetration): changed after it was written"),
    (["DROP TRIGGER events_no_delete", "DELETE FROM events WHERE kind = 'phase_end'", "events_no_delete"],
     "is gone from the database (deleted, or set back to an earlier state)"),
    (["INSERT INTO ledger (fact, key, digest, link) VALUES ('event', '[9999]', zeroblob(32), zeroblob(32))"],
     "its link does not follow from the entries before it"),
])
def test_edits_behind_microgs_back_are_named(copy, statements, problem):
    study = copy()
    forge(study, *[trigger(s) if s in store_module._schema_triggers() else s for s in statements])
    with pytest.raises(DamagedStudyError) as error:
        open_study(study)
    assert any(problem in p for p in error.value.problems), error.value.problems


def test_a_withdrawal_undone_behind_microgs_back_is_found(make_study):
    store, _ = make_study("tiny")
    store.withdraw("P01", "felt unwell")
    store.close()
    forge(store.dir, "DROP TRIGGER participants_withdraw_only",
          "UPDATE participants SET status = 'active', withdrawn_at = NULL, withdraw_reason = NULL",
          trigger("participants_withdraw_only"))
    with pytest.raises(DamagedStudyError, match="the withdrawal of participant P01 is gone from the database"):
        open_study(store.dir)


def read_only(folder: Path) -> None:
    for path in folder.iterdir():
        path.chmod(0o444)
    folder.chmod(0o555)


def writable_again(folder: Path) -> None:
    folder.chmod(0o755)
    for path in folder.iterdir():
        path.chmod(0o644)


def test_an_archived_study_is_read_where_it_lies_and_refuses_to_be_written(copy, tmp_path):
    """A read-only copy (chmod a-w: read-only to root as well, so the test means the same as root):
    every reading verb works without creating SQLite's -wal or -shm beside it; every writing verb
    says the study is read-only."""
    archive = copy("archive")
    before = sha256(archive / DATABASE)
    read_only(archive)
    try:
        status = cli("study", "status", archive)
        assert status.exit_code == 0 and "P01" in status.output and "read only here (an archive)" in status.output
        assert cli("study", "check", archive).exit_code == 0
        assert cli("participant", "list", archive).exit_code == 0
        result = cli("export", archive, "--out", tmp_path / "out", "--quiet", "--no-bids")
        assert result.exit_code == 0, result.output
        trials, _ = read_tables(archive)  # what microg report STUDY reads
        pd.testing.assert_frame_equal(trials, pd.read_parquet(tmp_path / "out" / "trials.parquet"))
        assert sorted(p.name for p in archive.iterdir()) == [ledger.HEAD_FILE, DATABASE]
        for result in (add_p02(archive), cli("session", "resume", archive, "--participant", "P01")):
            assert result.exit_code == 1 and f"{archive} is read-only" in result.output
            assert "Copy the study folder to a writable place" in result.output
        result = cli("session", "resimulate", archive, "--all", "--interaction", "soft_hand", "--quiet")
        assert result.exit_code == 1 and "the folder is read-only" in result.output  # its runs would go inside
        result = cli("export", archive, "--quiet")  # its default folder is inside the archive
        assert result.exit_code == 1 and "the folder is read-only" in result.output
        assert sorted(p.name for p in archive.iterdir()) == [ledger.HEAD_FILE, DATABASE]
    finally:
        writable_again(archive)
    assert sha256(archive / DATABASE) == before


def test_an_archive_copied_while_a_session_wrote_reads_its_write_ahead_log(make_study, tmp_path):
    """A copy taken while the study was open holds commits in study.db-wal only: it is read with
    them (an immutable open would silently miss them)."""
    store, _ = make_study("tiny")
    store.add_participant(Participant("P02", "male", 30, "left", False))
    archive = tmp_path / "archive"
    archive.mkdir()
    for name in (DATABASE, DATABASE + "-wal", DATABASE + "-shm", ledger.HEAD_FILE):
        shutil.copy2(store.dir / name, archive / name)
    assert (archive / (DATABASE + "-wal")).stat().st_size > 0
    read_only(archive)
    try:
        result = cli("participant", "list", archive)
        assert result.exit_code == 0 and "P01" in result.output and "P02" in result.output, result.output
    finally:
        writable_again(archive)


@pytest.fixture
def exported(finished, tmp_path) -> Path:
    out = tmp_path / "earlier"
    assert cli("export", finished, "--out", out, "--quiet", "--no-frames", "--no-bids").exit_code == 0
    return out


def test_a_symbolic_link_as_export_target_is_refused_and_nothing_is_written_through_it(finished, exported, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "notes.txt").write_text("mine")
    dangling, to_folder, to_export = tmp_path / "dangling", tmp_path / "to-folder", tmp_path / "to-export"
    dangling.symlink_to(tmp_path / "nowhere")
    to_folder.symlink_to(elsewhere)
    to_export.symlink_to(exported)
    listed = sorted(p.name for p in exported.iterdir())
    for link, extra in ((dangling, ()), (dangling, ("--overwrite",)), (to_folder, ()), (to_folder, ("--overwrite",)),
                        (to_export, ("--overwrite",))):
        result = cli("export", finished, "--out", link, "--quiet", *extra)
        assert result.exit_code == 1 and f"{link} is a symbolic link" in result.output, (link, extra, result.output)
    assert not (tmp_path / "nowhere").exists() and not (tmp_path / "nowhere.partial").exists()
    assert [p.name for p in elsewhere.iterdir()] == ["notes.txt"]
    assert sorted(p.name for p in exported.iterdir()) == listed
    partial_link = tmp_path / "fresh.partial"
    partial_link.symlink_to(elsewhere)
    result = cli("export", finished, "--out", tmp_path / "fresh", "--quiet")
    assert result.exit_code == 1 and f"{partial_link} is a symbolic link" in result.output
    assert [p.name for p in elsewhere.iterdir()] == ["notes.txt"]
    result = cli("export", finished, "--xdf", tmp_path / "none.xdf", "--out", to_folder)
    assert result.exit_code == 1 and f"{to_folder} is a symbolic link" in result.output


def test_overwrite_replaces_an_earlier_export_only(finished, exported, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    for target in (mine, finished):
        result = cli("export", finished, "--out", target, "--quiet", "--overwrite")
        assert result.exit_code == 1 and "is not an export" in result.output, (target, result.output)
    with pytest.raises(FileExistsError, match="is not an export"):  # the command line refuses a file itself
        export_study(finished, mine / "thesis.tex", overwrite=True, progress=False)
    assert (mine / "thesis.tex").read_text() == "years of work" and (finished / DATABASE).exists()
    result = cli("export", finished, "--out", exported, "--quiet", "--overwrite", "--no-bids")
    assert result.exit_code == 0 and (exported / "frames.parquet").exists()


# ---------------------------------------------------------------- the check before a write (issue 45)


def damage_frames_page(study: Path, kind: str) -> None:
    """Turn 64 bytes of a page of the frames table in the file itself (a failing disk, a bad copy):
    a ``leaf`` page's last blob bytes before its cell's overflow pointer, or the middle of a full
    ``overflow`` page (nothing but blob bytes)."""
    full = " AND payload = pgsize - 4" if kind == "overflow" else ""
    pages = [p for (p,) in query(study, f"SELECT pageno FROM dbstat WHERE name = 'frames' AND pagetype = ?{full} "
                                        "ORDER BY pageno", kind)]
    size = query(study, "PRAGMA page_size")[0][0]
    at = (pages[len(pages) // 2] - 1) * size + (size - 72 if kind == "leaf" else size // 2)
    with open(study / DATABASE, "r+b") as stream:
        stream.seek(at)
        old = stream.read(64)
        stream.seek(at)
        stream.write(bytes(b ^ 0xFF for b in old))


DAMAGED_BATCH = re.compile(r"frames of participant P01's session 1, task \d+ \([a-z0-9_]+, [a-z_]+\), run \d+ "
                           r"\(task run \d+\), the batch from frame \d+ \(\d+ frames\): does not match its checksum")


def record(study: Path) -> dict:
    return json.loads((study / integrity.RECORD).read_text())


@pytest.mark.parametrize("kind", ["leaf", "overflow"])
def test_64_bytes_damaged_in_a_frames_page_stop_every_writer_and_every_reader_says_so(copy_long, tmp_path, kind):
    """The issue's reproduction, after a writer's check had vouched for the file: every verb that
    writes refuses naming the batch and what to do, nothing is written, the record beside the study
    marks the damage; every verb that reads says so on a warning line."""
    study = copy_long()
    assert add_p02(study).exit_code == 0
    assert record(study)["sound"] and record(study)["verified"] and record(study)["file"]
    damage_frames_page(study, kind)
    before = sha256(study / DATABASE)

    writers = [cli("participant", "add", study, "--id", "P03", *ADD_P02[4:]),
               cli("participant", "add-sample", study),
               cli("participant", "withdraw", study, "--participant", "P02", "--reason", "moved away"),
               cli("session", "run", study, "--participant", "P02", "--input", "simulated", "--quiet"),
               cli("session", "resume", study, "--participant", "P01"),
               cli("study", "station", study, "--name", "B", "--out", tmp_path / "b"),
               cli("study", "merge", study, tmp_path / "b")]
    for result in writers:
        assert result.exit_code == 1 and "the study is damaged" in result.output, result.output
        assert DAMAGED_BATCH.search(result.output), result.output
        assert f"microg study check {study}" in result.output and "restore it from a copy" in result.output
    result = cli("session", "resimulate", study, "--all", "--interaction", "soft_hand", "--quiet")
    assert result.exit_code == 1 and DAMAGED_BATCH.search(result.output) and "Nothing was re-simulated" \
        in result.output
    assert sha256(study / DATABASE) == before and not (study / "resimulated").exists()
    assert not (tmp_path / "b").exists()
    mark = record(study)
    assert not mark["sound"] and mark["verified"] is None and DAMAGED_BATCH.search(mark["problems"][0])

    status = cli("study", "status", study)
    assert status.exit_code == 0 and DAMAGED_BATCH.search(status.output) and "the study is damaged" in status.output
    listed = cli("participant", "list", study)
    assert listed.exit_code == 0 and "P02" in listed.output
    assert re.search("warning: the study is damaged: " + DAMAGED_BATCH.pattern, listed.output)
    tables = cli("export", study, "--out", tmp_path / "tables", "--quiet", "--no-frames", "--no-bids")
    assert tables.exit_code == 0 and re.search("warning: exporting a damaged study: " + DAMAGED_BATCH.pattern,
                                               tables.output)
    refused = cli("export", study, "--out", tmp_path / "all", "--quiet")
    assert refused.exit_code == 1 and "Nothing was exported" in refused.output and not (tmp_path / "all").exists()
    reported = cli("report", study, "--out", tmp_path / "report")  # one participant: no ANOVA, but the warning
    assert re.search("warning: the study is damaged: " + DAMAGED_BATCH.pattern, reported.output), reported.output
    task = query(study, "SELECT task_index FROM tasks ORDER BY task_index LIMIT 1")[0][0]
    viewed = cli("view", study, "--session", "P01", "--task", task, "--out", tmp_path / "strip.png")
    assert re.search("warning: the study is damaged: " + DAMAGED_BATCH.pattern, viewed.output), viewed.output
    assert sha256(study / DATABASE) == before


def test_a_study_put_back_from_a_copy_is_found_sound_and_written_again(copy_long):
    """After the refusal, the study restored from a copy: the next writer's check reads every batch
    (the record no longer vouches), finds it sound, records it and writes."""
    study = copy_long()
    pristine = (study / DATABASE).read_bytes()
    damage_frames_page(study, "overflow")
    assert add_p02(study).exit_code == 1 and not record(study)["sound"]
    (study / DATABASE).write_bytes(pristine)
    assert add_p02(study).exit_code == 0
    assert record(study)["sound"] and record(study)["problems"] == []
    result = cli("study", "check", study)
    assert result.exit_code == 0 and record(study)["check"] == "full" and record(study)["sound"]


def test_the_check_on_open_reads_only_batches_new_since_a_record_that_still_vouches(copy_long):
    """The record vouches only for the file as microg left it, and for a chain that still holds its
    entry; then only the batches sealed after that entry are read (a damaged older batch is left to
    study check), else every batch is."""
    study = copy_long()
    assert add_p02(study).exit_code == 0
    kept = integrity.read(study)
    database = study / DATABASE
    enrolled, = query(study, "SELECT seq FROM ledger WHERE fact = 'participant' AND key = '[\"P02\"]'")[0]
    with open_study(study, readonly=True) as store:  # what the writer verified before it wrote
        assert integrity.vouched(store.db, kept, integrity.file_state(database)) == enrolled - 1
        assert integrity.vouched(store.db, None, integrity.file_state(database)) is None
        unsound = integrity.Record(kept.checked_at, "open", False, ("x",), kept.verified, kept.file)
        assert integrity.vouched(store.db, unsound, integrity.file_state(database)) is None
        rewritten = ledger.Head(ledger.head_of(store.db).entry, "0" * 64)
        other_chain = integrity.Record(kept.checked_at, "open", True, (), str(rewritten), kept.file)
        assert integrity.vouched(store.db, other_chain, integrity.file_state(database)) is None
    stat = database.stat()
    os.utime(database, ns=(stat.st_atime_ns, stat.st_mtime_ns))  # the same times written back: a change all the same
    with open_study(study, readonly=True) as store:
        assert integrity.vouched(store.db, kept, integrity.file_state(database)) is None

    damage_frames_page(study, "overflow")
    with sqlite3.connect(f"file:{database}?mode=ro", uri=True) as db:
        head = ledger.head_of(db).entry
        earlier = db.execute("SELECT MIN(seq) FROM ledger WHERE fact = 'frames'").fetchone()[0]
        assert integrity.verify_frames(db, head).batches == []  # nothing new since the head
        assert DAMAGED_BATCH.search(integrity.verify_frames(db, earlier - 1).batches[0])
        whole = integrity.verify_frames(db, None)
        assert whole.everything and len(whole.batches) == 1 and DAMAGED_BATCH.search(whole.batches[0])
    db.close()


FORGED_HOLD = ("DROP TRIGGER protocols_no_update",
               "UPDATE protocols SET resolved = replace(resolved, '\"hold_s\":0.5', '\"hold_s\":9')")


@pytest.mark.parametrize("rehash", [False, True], ids=["text", "text-and-hash"])
def test_a_stored_protocol_changed_after_the_study_was_made_is_named_before_its_content(copy, tmp_path, rehash):
    """The stored protocol's hold_s edited to a value its own validation refuses (the triggers dropped
    and put back; with ``rehash`` its sha256 column recomputed too): every verb names the change and
    the hashes, never the protocol's content, which would send the researcher to a file that is fine."""
    study = copy()
    recorded = query(study, "SELECT sha256 FROM protocols")[0][0]
    forge(study, *FORGED_HOLD, trigger("protocols_no_update"))
    resolved = query(study, "SELECT resolved FROM protocols")[0][0]
    found = hashlib.sha256(json.dumps(json.loads(resolved), sort_keys=True, separators=(",", ":")).encode()
                           ).hexdigest()
    assert '"hold_s":9' in resolved and found != recorded
    if rehash:
        forge(study, "DROP TRIGGER protocols_no_update", ("UPDATE protocols SET sha256 = ?", (found,)),
              trigger("protocols_no_update"))
        named = ["protocols row 1", "no longer matches ledger entry 1"]  # the ledger's word, or the store's
    else:
        named = [f"the stored protocol was changed after the study was made: its recorded sha256 is {recorded}, "
                 f"its text now hashes to {found}"]
    verbs = [("participant", "add", study, "--id", "P03", *ADD_P02[4:]),
             ("session", "run", study, "--participant", "P02", "--input", "simulated"),
             ("session", "resume", study, "--participant", "P01"),
             ("study", "status", study), ("study", "check", study), ("participant", "list", study),
             ("export", study, "--out", tmp_path / "out", "--accept-damaged", "--quiet"),
             ("view", study, "--session", "P01", "--task", "0", "--out", tmp_path / "strip.png"),
             ("report", study, "--out", tmp_path / "report")]
    for verb in verbs:
        result = cli(*verb)
        assert result.exit_code == 1, (verb, result.output)
        assert all(name in result.output for name in named), (verb, result.output)
        assert "hold_s = 9" not in result.output and "timeout_s" not in result.output, (verb, result.output)
    assert not (tmp_path / "out").exists() and not (tmp_path / "strip.png").exists()
