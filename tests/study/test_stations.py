"""Several stations, one study: stations made from a central study run simulated participants, are
merged, and the merged study exports as the same sessions run in one place; merging is idempotent,
refuses conflicts naming them, and a merge killed with SIGKILL leaves the central study as it was."""

from __future__ import annotations

import datetime
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
from microg.study import ledger, open_inputs
from microg.study.assignment import Participant
from microg.study.export import export_study
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, earlier_sessions, run_session
from microg.study.stations import session_content
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


# ---------------------------------------------------------------- a trainee's sessions at several places

MONDAY = datetime.date(2027, 3, 1)
"""The lab's calendar of P03, who runs their first session centrally on a Monday."""


def refusal(action) -> str:
    """What ``action`` was refused with (a StoreError)."""
    with pytest.raises(StoreError) as refused:
        action()
    return str(refused.value)


def on_the_lab_calendar(study: Path, participant: str, day: datetime.date, **asked) -> None:
    """Run ``participant``'s next session on ``day`` of the lab's calendar, played by the simulated participant."""
    with open_study(study) as store:
        inputs = open_inputs("simulated", store.protocol.group(store.participant(participant).group))
        session = store.create_session(participant, input_spec="leap", simulated=False, clock="wall", today=day,
                                       **asked)
        run_session(store, session.id, inputs, clock=SimulationClock())


@pytest.fixture(scope="module")
def trainees(tmp_path_factory) -> dict:
    """The toy program (train1, then retention a week later) run at several places. Centrally, P01
    runs train1 on the simulated calendar and P03 on a Monday of the lab's calendar; station B gets
    P01 (with their train1) and P02 (no session yet), station C gets P03. B runs P01's retention and
    P02's train1; C refuses P03's retention three days after the Monday, then runs it with
    ``ignore_schedule``. Kept: the central study before the merge (``before``: a copy, its state,
    its ledger head, P01's train1), what each step said, and ``single``: P01 run through in one study
    with the same seed."""
    root = tmp_path_factory.mktemp("trainees")
    central = enrolled(root / "central", protocol="program-toy")
    single = enrolled(root / "single", protocol="program-toy")
    said = {"central": ok("session", "run", central, "--participant", "P01", "--input", "simulated", "--quiet")}
    for _ in range(2):
        ok("session", "run", single, "--participant", "P01", "--input", "simulated", "--quiet")
    on_the_lab_calendar(central, "P03", MONDAY)
    said["B"] = ok("study", "station", central, "--name", "B", "--out", root / "b", "--participant", "P01",
                   "--participant", "P02")
    said["C"] = ok("study", "station", central, "--name", "C", "--out", root / "c", "--participant", "P03")
    said["held"] = cli("session", "run", central, "--participant", "P01", "--input", "simulated")
    said["at B"] = ok("session", "run", root / "b", "--all", "--input", "simulated", "--quiet")
    thursday = MONDAY + datetime.timedelta(days=3)
    with open_study(root / "c") as store:
        said["early"] = refusal(lambda: store.create_session("P03", input_spec="leap", simulated=False, clock="wall",
                                                             today=thursday))
    on_the_lab_calendar(root / "c", "P03", thursday, ignore_schedule=True)
    with open_study(central, readonly=True) as store:
        train1 = session_content(store.db, store.session_of("P01", "train1").id)
        head = ledger.head_of(store.db)
    before = copied(central, root / "before")
    said["merge"] = ok("study", "merge", central, root / "b", root / "c")
    return {"central": central, "b": root / "b", "c": root / "c", "single": single, "before": before,
            "state": state(before), "head": head, "train1": train1, "said": said}


@pytest.mark.slow
@pytest.mark.timeout(1800)  # the toy's catch kind compiles on a cold numba cache; a bound against a hang
def test_a_trainee_runs_their_next_session_at_a_station_and_the_merge_brings_back_only_it(trainees, tmp_path):
    central, said = trainees["central"], trainees["said"]
    assert "P01's sessions run so far went with them: train1" in said["B"] and "P02's" not in said["B"]
    assert "P03's sessions run so far went with them: train1" in said["C"]
    assert "session 'retention' of P01: completed" in said["at B"] and "session 'train1' of P02" in said["at B"]
    assert f"station B ({trainees['b']}): merged 2 session(s) (P01 retention, P02 train1); 1 given to the station " \
           "from here, unchanged (P01 train1)" in said["merge"]
    assert f"station C ({trainees['c']}): merged 1 session(s) (P03 retention); 1 given to the station from here, " \
           "unchanged (P03 train1)" in said["merge"]

    with open_study(central, readonly=True) as store, open_study(trainees["b"], readonly=True) as b, \
            open_study(trainees["single"], readonly=True) as single:
        sessions = store.sessions_of("P01")
        rows = [tuple(r) for r in store.db.execute("SELECT name, session_index, station, merged_at IS NOT NULL "
                                                   "FROM sessions WHERE participant_id = 'P01' ORDER BY id")]
        assert rows == [("train1", 1, None, 0), ("retention", 2, "B", 1)]
        assert session_content(store.db, sessions[0].id) == trainees["train1"]  # train1 as it was
        assert session_content(store.db, sessions[1].id) == session_content(b.db, b.session_of("P01", "retention").id)
        # the station knew P01's first session: the due date a week after it, the second session's seed and practice
        alone = single.sessions_of("P01")
        assert [(s.date, s.due, s.seed) for s in sessions] == [(s.date, s.due, s.seed) for s in alone]
        assert sessions[1].due == sessions[0].date + datetime.timedelta(days=7)
        assert earlier_sessions(store, sessions[1]) == earlier_sessions(single, alone[1]) and \
            earlier_sessions(store, sessions[1])[0][1] > 0
    for study in (central, trainees["b"], trainees["c"]):
        assert "sound" in ok("study", "check", study)
    assert "sound" in ok("study", "check", central, "--head", str(trainees["head"]))  # the chain only grew

    export_study(central, tmp_path / "merged", progress=False, say=lambda text: None, frames=False, bids=False)
    export_study(trainees["single"], tmp_path / "one", progress=False, say=lambda text: None, frames=False, bids=False)
    progression = pd.read_csv(tmp_path / "merged" / "progression.csv")
    assert set(map(tuple, progression[["participant", "session"]].values)) == {
        ("P01", "train1"), ("P01", "retention"), ("P02", "train1"), ("P03", "train1"), ("P03", "retention")}
    merged, one = (pd.read_csv(folder / "trials.csv") for folder in (tmp_path / "merged", tmp_path / "one"))
    assert merged.groupby("session")["station"].unique().map(list).to_dict()["retention"] == ["B", "C"]
    keep = [c for c in one.columns if c not in ("station", "session_id")]
    pd.testing.assert_frame_equal(merged[merged.participant == "P01"][keep].reset_index(drop=True),
                                  one[keep].reset_index(drop=True))  # as if P01 had run both here

    before = state(central)
    again = ok("study", "merge", central, trainees["c"], trainees["b"])
    assert "merged 0 session(s); 2 merged before, unchanged (P01 retention, P02 train1); 1 given to the station " \
           "from here, unchanged (P01 train1)" in again
    assert state(central) == before


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_a_station_keeps_the_schedule_and_the_central_study_keeps_its_hands_off(trainees):
    """C refused P03's retention before its day, naming the date, and ran it with ``ignore_schedule``
    (logged); the central study refuses to run P01 and P02 while B has them, before the merge and after
    (P02's retention is left to run at B)."""
    assert "participant P03's session 'retention' is due on 2027-03-08 (7 day(s) after their session 'train1' " \
           "on 2027-03-01)" in trainees["said"]["early"] and "--ignore-schedule" in trainees["said"]["early"]
    held = trainees["said"]["held"]
    assert held.exit_code == 1 and "participant P01 was handed to station B on 20" in held.output
    with open_study(trainees["central"], readonly=True) as store:
        retention = store.session_of("P03", "retention")
        assert (retention.date, retention.due, retention.ignored_schedule) == (
            MONDAY + datetime.timedelta(days=3), MONDAY + datetime.timedelta(days=7), True)
        assert [e.data for e in store.events(retention.id) if e.kind == "schedule_ignored"] == [
            {"session": "retention", "due": "2027-03-08", "date": "2027-03-04"}]
    refused = cli("session", "run", trainees["central"], "--participant", "P02", "--input", "simulated")
    assert refused.exit_code == 1 and "participant P02 was handed to station B" in refused.output  # merged, still B's


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_one_session_run_at_two_stations_is_refused_naming_trainee_session_and_both(trainees, tmp_path):
    central = copied(trainees["before"], tmp_path / "central")
    made = cli("study", "station", central, "--name", "D", "--out", tmp_path / "d", "--participant", "P01")
    assert made.exit_code == 0 and "P01 was given to station B too" in made.output
    assert "--name B --give-up --participant P01" in made.output
    ok("session", "run", tmp_path / "d", "--participant", "P01", "--input", "simulated", "--quiet")
    before = state(central)
    refused = cli("study", "merge", central, trainees["b"], tmp_path / "d")
    assert refused.exit_code == 1 and "1 conflict(s)" in refused.output
    assert f"participant P01 (session 'retention') was run at station B ({trainees['b']}) and at station D " \
           f"({tmp_path / 'd'}): a session is run once" in refused.output
    assert state(central) == before
    ok("study", "merge", central, trainees["b"])
    refused = cli("study", "merge", central, tmp_path / "d")
    assert refused.exit_code == 1 and "participant P01 (session 'retention') was run at station B (merged 20" \
        in refused.output and f"and at station D ({tmp_path / 'd'})" in refused.output


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_a_trainee_is_taken_back_for_the_sessions_left_and_a_finished_one_is_not(trainees, tmp_path):
    """After the merge P01 has run the whole program (B's retention merged): not taken back, not
    handed again. P02 (train1 merged from B) is taken back, runs retention here, and B's own
    retention of P02 is left out of a later merge; train1 stays merged."""
    central = copied(trainees["central"], tmp_path / "central")
    b = copied(trainees["b"], tmp_path / "b")
    refused = cli("study", "station", central, "--name", "B", "--give-up", "--participant", "P01")
    assert refused.exit_code == 1 and "P01's session 'retention' was merged from station B on 20" in refused.output
    assert "(the last of their program): it stays in the study, and no session is left to run" in refused.output
    refused = cli("study", "station", central, "--name", "E", "--out", tmp_path / "e", "--participant", "P01")
    assert refused.exit_code == 1 and "--participant P01: not handed to station E: participant P01 has run every " \
        "session of the program (train1, retention)" in refused.output
    assert not (tmp_path / "e").exists()

    said = ok("study", "station", central, "--name", "B", "--give-up")  # everyone of B's with a session left
    assert "took P02 back from station B" in said
    ok("session", "run", central, "--participant", "P02", "--input", "simulated", "--quiet")
    ok("session", "run", b, "--participant", "P02", "--input", "simulated", "--quiet")
    merged = state(central)
    said = ok("study", "merge", central, b)
    assert "merged 0 session(s); 2 merged before, unchanged (P01 retention, P02 train1)" in said
    assert "taken back from the station (study station --give-up), not merged: P02" in said
    assert state(central) == merged and "sound" in ok("study", "check", central)
    with open_study(central, readonly=True) as store:
        assert [(s.name, store.db.execute("SELECT station FROM sessions WHERE id = ?", (s.id,)).fetchone()[0])
                for s in store.sessions_of("P02")] == [("train1", "B"), ("retention", None)]


def test_a_trainee_whose_session_is_under_way_here_is_not_handed_to_a_station(tmp_path):
    central = enrolled(tmp_path / "central", protocol="program-toy")
    with open_study(central) as store:
        store.create_session("P04", input_spec="scripted", simulated=True, clock="simulation")
    refused = cli("study", "station", central, "--name", "F", "--out", tmp_path / "f", "--participant", "P04")
    assert refused.exit_code == 1 and "--participant P04: not handed to station F: participant P04's session " \
        "'train1' is running (not ended); continue it with: microg session resume" in refused.output
    assert not (tmp_path / "f").exists()
