"""Several stations, one study: stations made from a central study run simulated participants, are
merged, and the merged study exports as the same sessions run in one place; merging is idempotent,
refuses conflicts naming them, and a merge killed with SIGKILL leaves the central study as it was."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study import ledger
from microg.study.assignment import Participant
from microg.study.export import export_study
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import DATABASE, StoreError, create_study, open_study

from .conftest import PROTOCOLS, scripted_inputs

ROOT = Path(__file__).resolve().parents[2]
PEOPLE = [Participant("P01", "female", 24, "right", True), Participant("P02", "male", 29, "left", False),
          Participant("P03", "female", 22, "right", False), Participant("P04", "male", 27, "right", True)]
SEED = 3
WORK_S = 300.0
"""A generous bound for the merge child to reach the point where it is killed."""


def cli(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in result.output, result.output
    return result


def ok(*args) -> str:
    result = cli(*args)
    assert result.exit_code == 0, result.output
    return result.output


def enrolled(folder: Path, people=PEOPLE, protocol: str = "tiny") -> Path:
    with create_study(folder, load_protocol(PROTOCOLS / f"{protocol}.toml"), SEED) as store:
        for person in people:
            store.add_participant(person)
    return folder


def copied(folder: Path, to: Path) -> Path:
    shutil.copytree(folder, to)
    return to


def state(study: Path) -> tuple:
    """What a study holds, as another program reads it: its rows per table, its ledger's head, the head file."""
    with sqlite3.connect(f"file:{study / DATABASE}?mode=ro", uri=True) as db:
        counts = tuple(db.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0]
                       for table in ("participants", "sessions", "task_runs", "events", "answers", "frames", "ledger"))
        head = db.execute("SELECT seq, link FROM ledger ORDER BY seq DESC LIMIT 1").fetchone()
    return counts, head, (study / ledger.HEAD_FILE).read_text()


def run_scripted(folder: Path, participant: str) -> None:
    with open_study(folder) as store:
        session = store.create_session(participant, input_spec="scripted", simulated=True, clock="simulation")
        run_session(store, session.id, scripted_inputs(), clock=SimulationClock())


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> dict[str, Path]:
    """A central study of four participants and its two stations, A (P01, P02) and B (P03, P04), each
    run with simulated participants (``B-fresh``: B as it was made, before it ran); and ``single``,
    the same four run in one study with the same seed. The central study is not merged here: tests
    merge into copies of it."""
    root = tmp_path_factory.mktemp("lab")
    central = enrolled(root / "central")
    ok("study", "station", central, "--name", "A", "--out", root / "a", "--participant", "P01", "--participant", "P02")
    ok("study", "station", central, "--name", "B", "--out", root / "b")
    copied(root / "b", root / "b-fresh")
    single = enrolled(root / "single")
    for study in (root / "a", root / "b", single):
        ok("session", "run", study, "--all", "--input", "simulated", "--quiet")
    return {"central": central, "a": root / "a", "b": root / "b", "b-fresh": root / "b-fresh", "single": single}


def tables(export: Path) -> dict[str, pd.DataFrame]:
    return {name: pd.read_parquet(export / f"{name}.parquet") for name in ("trials", "questionnaire", "frames")}


def files(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_two_merged_stations_export_as_the_same_sessions_run_in_one_study(lab, tmp_path):
    central = copied(lab["central"], tmp_path / "central")
    said = ok("study", "merge", central, lab["a"], lab["b"])
    assert f"station A ({lab['a']}): merged 2 session(s) (P01, P02)" in said
    assert f"station B ({lab['b']}): merged 2 session(s) (P03, P04)" in said
    assert "sound" in ok("study", "check", central)

    export_study(central, tmp_path / "merged", progress=False, say=lambda text: None)
    export_study(lab["single"], tmp_path / "one", progress=False, say=lambda text: None)
    merged, one = tables(tmp_path / "merged"), tables(tmp_path / "one")
    for name in ("trials", "questionnaire"):
        stations = merged[name].groupby("participant")["station"].unique().map(list).to_dict()
        assert stations == {"P01": ["A"], "P02": ["A"], "P03": ["B"], "P04": ["B"]}, name
        assert one[name]["station"].isna().all(), name
        pd.testing.assert_frame_equal(merged[name].drop(columns="station"), one[name].drop(columns="station"))
    assert merged["trials"]["completed"].any() and len(merged["frames"]) > 1000
    pd.testing.assert_frame_equal(merged["frames"], one["frames"])
    bids = files(tmp_path / "merged" / "bids")
    assert bids == files(tmp_path / "one" / "bids") and len(bids) > 20

    with sqlite3.connect(central / DATABASE) as db:
        merged_at = db.execute("SELECT participant_id, station, merged_at FROM sessions ORDER BY id").fetchall()
    assert [(p, s) for p, s, _ in merged_at] == [("P01", "A"), ("P02", "A"), ("P03", "B"), ("P04", "B")]
    assert all(when for _, _, when in merged_at)

    before = state(central)
    again = ok("study", "merge", central, lab["b"], lab["a"])
    assert "merged 0 session(s); 2 merged before, unchanged (P03, P04)" in again
    assert state(central) == before
    for station in (lab["a"], lab["b"]):
        assert "sound" in ok("study", "check", station)


@pytest.mark.slow
def test_a_conflicting_station_is_refused_naming_the_conflict_and_nothing_is_merged(lab, tmp_path):
    central = copied(lab["central"], tmp_path / "central")
    made_c = cli("study", "station", central, "--name", "C", "--out", tmp_path / "c", "--participant", "P01")
    assert made_c.exit_code == 0 and "P01 was given to station A too" in made_c.output
    run_scripted(tmp_path / "c", "P01")
    other = enrolled(tmp_path / "other", protocol="quick")
    ok("study", "station", other, "--name", "A", "--out", tmp_path / "other-a")
    twin = enrolled(tmp_path / "twin")
    ok("study", "station", twin, "--name", "A", "--out", tmp_path / "twin-a")
    before = state(central)

    refused = cli("study", "merge", central, lab["a"], tmp_path / "c", tmp_path / "other-a", tmp_path / "twin-a")
    assert refused.exit_code == 1
    assert "nothing was merged; 3 conflict(s)" in refused.output
    assert f"participant P01 was run at station A ({lab['a']}) and at station C ({tmp_path / 'c'})" in refused.output
    assert f"station A ({tmp_path / 'other-a'}): runs another protocol ('quick'" in refused.output
    assert f"station A ({tmp_path / 'twin-a'}): was not made from this study" in refused.output
    assert state(central) == before

    ok("study", "merge", central, lab["a"])
    refused = cli("study", "merge", central, tmp_path / "c")
    assert refused.exit_code == 1 and "participant P01 was run at station A (merged 20" in refused.output

    ok("study", "merge", central, lab["b"])
    run_scripted(lab["b-fresh"], "P03")  # B's study put back from before it ran, and P03 run again
    merged = state(central)
    refused = cli("study", "merge", central, lab["b-fresh"])
    assert refused.exit_code == 1
    assert f"participant P03's session at station B ({lab['b-fresh']}) differs from the one merged from station B" \
        in refused.output
    assert state(central) == merged


def test_a_station_enrols_nobody_runs_only_its_own_and_its_withdrawals_carry_over(tmp_path):
    central = enrolled(tmp_path / "central")
    ok("study", "station", central, "--name", "D", "--out", tmp_path / "d", "--participant", "P04")
    refused = cli("participant", "add", tmp_path / "d", "--id", "P09", "--gender", "female", "--age", "25",
                  "--handedness", "right", "--mr-experience", "no")
    assert refused.exit_code == 1 and "participants are enrolled in the central study" in refused.output
    refused = cli("session", "run", tmp_path / "d", "--participant", "P01", "--input", "simulated")
    assert refused.exit_code == 1 and "'P01' is not one of station D's participants" in refused.output
    again = cli("study", "station", central, "--name", "D", "--out", tmp_path / "d2")
    assert again.exit_code == 1 and "a station name is used once" in again.output

    ok("participant", "withdraw", tmp_path / "d", "--participant", "P04", "--reason", "felt unwell")
    said = ok("study", "merge", central, tmp_path / "d")
    assert "merged 0 session(s); withdrew P04 as at the station" in said
    with open_study(central, readonly=True) as store:
        assert store.participant("P04").status == "withdrawn"
        assert store.db.execute("SELECT withdraw_reason FROM participants WHERE id = 'P04'").fetchone()[0] \
            == "felt unwell"
    before = state(central)
    assert "withdrew" not in ok("study", "merge", central, tmp_path / "d")
    assert state(central) == before


@pytest.mark.slow
def test_a_merge_killed_with_sigkill_leaves_the_central_study_as_it_was(lab, tmp_path):
    central = copied(lab["central"], tmp_path / "central")
    before = state(central)
    with sqlite3.connect(f"file:{lab['a'] / DATABASE}?mode=ro", uri=True) as db:
        batches_a = db.execute("SELECT COUNT(*) FROM frames").fetchone()[0]
    child = subprocess.Popen([sys.executable, "-m", "tests.study.merge_child", str(central), str(lab["a"]),
                              str(lab["b"])], cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})
    seen = []
    try:
        for line in child.stdout:  # each line comes from the child, which then waits: no clock is raced
            seen.append(line.strip())
            if line.strip() == f"copied {batches_a + 1}":  # all of A's frames and one batch of B's, uncommitted
                break
            child.stdin.write("go\n")
            child.stdin.flush()
        else:
            pytest.fail(f"the merge ended before it copied {batches_a + 1} frame batches; it said: {seen[-3:]}")
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=WORK_S)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == -signal.SIGKILL

    assert state(central) == before
    assert "sound" in ok("study", "check", central)
    said = ok("study", "merge", central, lab["a"], lab["b"])
    assert "merged 2 session(s) (P01, P02)" in said and "merged 2 session(s) (P03, P04)" in said


def test_a_participant_handed_to_a_station_runs_there_until_the_station_gives_them_back(tmp_path):
    """The central study refuses to run a participant handed to a station, naming the station and
    how to take them back; giving the station up takes back only who was not merged, refuses the
    rest by name, and a later merge leaves the station's sessions of those taken back out."""
    central = enrolled(tmp_path / "central")
    ok("study", "station", central, "--name", "B", "--out", tmp_path / "b", "--participant", "P03",
       "--participant", "P04")
    before = state(central)
    for verb in (["session", "run", central, "--participant", "P03", "--input", "simulated"],
                 ["session", "run", central, "--participant", "P04", "--input", "replay:nothing.json"]):
        refused = cli(*verb)
        assert refused.exit_code == 1 and "participant " + verb[4] + " was handed to station B on 20" in refused.output
        assert f"microg study station {central} --name B --give-up --participant {verb[4]}" in refused.output
    with open_study(central) as store, pytest.raises(StoreError, match="P03 was handed to station B"):
        store.create_session("P03", input_spec="scripted", simulated=True, clock="simulation")
    assert state(central) == before

    run_scripted(tmp_path / "b", "P03")  # P03's session ends at the station; P04's is cut off after it started
    with open_study(tmp_path / "b") as store:
        store.create_session("P04", input_spec="scripted", simulated=True, clock="simulation")
    said = ok("study", "merge", central, tmp_path / "b")
    assert "merged 1 session(s) (P03)" in said and "still running at the station, not merged: P04" in said

    for args, refusal in ((["--participant", "P03"], "P03's session was merged from station B on 20"),
                          (["--participant", "P01"], "--participant P01: not one of station B's participants"),
                          (["--name", "Z"], "made no station 'Z' (its stations: B)")):
        named = ["--name", "B", *args] if args[0] != "--name" else args
        refused = cli("study", "station", central, *named, "--give-up")
        assert refused.exit_code == 1 and refusal in refused.output, refused.output
    said = ok("study", "station", central, "--name", "B", "--give-up", "--reason", "the station's tracker broke")
    assert "took P04 back from station B" in said
    again = cli("study", "station", central, "--name", "B", "--give-up")
    assert again.exit_code == 1 and "nothing to give up" in again.output and "P04 was taken back from station B" \
        in again.output
    assert "taken back: P04" in ok("study", "status", central)

    run_scripted(central, "P04")  # now it runs here
    with open_study(tmp_path / "b") as store:  # and the station finishes its own session of P04 all the same
        run_session(store, store.session_of("P04").id, scripted_inputs(), clock=SimulationClock())
    merged = state(central)
    said = ok("study", "merge", central, tmp_path / "b")
    assert "merged 0 session(s); 1 merged before, unchanged (P03)" in said
    assert "taken back from the station (study station --give-up), not merged: P04" in said
    assert state(central) == merged and "sound" in ok("study", "check", central)
    with open_study(central, readonly=True) as store:
        assert [tuple(r) for r in store.db.execute("SELECT participant_id, station FROM sessions ORDER BY id")] == [
            ("P03", "B"), ("P04", None)]

    ok("study", "station", central, "--name", "C", "--out", tmp_path / "c")  # everyone left: P01, P02
    said = cli("session", "run", central, "--all", "--input", "simulated", "--quiet")
    assert said.exit_code == 0 and "left out P01: handed to station C" in said.output
    assert "left out P02: handed to station C" in said.output and "ran 0 session(s)" in said.output


def test_a_merge_overtaken_by_another_plans_again_and_merges_nothing_twice(tmp_path, monkeypatch):
    """Two merges of one station at once: the second waits for the first's transaction, then finds
    what the first merged (before, it failed on the database's uniqueness of a participant's session)."""
    from microg.study import stations

    central = enrolled(tmp_path / "central")
    ok("study", "station", central, "--name", "B", "--out", tmp_path / "b", "--participant", "P03")
    run_scripted(tmp_path / "b", "P03")
    planned, overtaken = stations._plan, []

    def overtaking(central_store, sides):
        plan = planned(central_store, sides)
        if not overtaken:  # the other merge commits between this merge's plan and its transaction
            overtaken.append(None)
            overtaken[0] = ok("study", "merge", central, tmp_path / "b")
        return plan

    monkeypatch.setattr(stations, "_plan", overtaking)
    said = ok("study", "merge", central, tmp_path / "b")
    assert "merged 1 session(s) (P03)" in overtaken[0]
    assert "merged 0 session(s); 1 merged before, unchanged (P03)" in said
    with open_study(central, readonly=True) as store:
        assert store.db.execute("SELECT COUNT(*) FROM sessions").fetchone()[0] == 1
    assert "sound" in ok("study", "check", central)
