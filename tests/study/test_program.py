"""A training program end to end (issue 43): a simulated trainee goes through the shipped program's
six sessions on the simulated calendar, killed in the middle of the second training session and
resumed; the criterion phases end at the criterion or the bound, the staircase moves by its rule,
every session's record is intact, and the export carries the sessions, the progression and
``progression.csv``. A session before its day is refused with the date it becomes due."""

from __future__ import annotations

import datetime
import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study import open_inputs
from microg.study.export import trials_table
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.stations import session_content
from microg.study.store import StoreError, open_study
from microg.paths import protocol_file
from tests.waiting import ended

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = load_protocol(protocol_file("microgravity-training"))
pytestmark = pytest.mark.timeout(1800)  # the module's program compiles two kinds under two interaction models
# on a first run (a cold numba cache) on 2 shared cores; a bound against a hang, not a timing


def cli(*args: str) -> str:
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def program(tmp_path_factory):
    """P01's whole program, the second training session (train1 is the first) killed with SIGKILL in
    its third task and resumed; what the first two sessions held before the kill; the export."""
    folder = tmp_path_factory.mktemp("program")
    study = folder / "study"
    cli("study", "init", study, "--protocol", "microgravity-training", "--seed", "7")
    cli("participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24", "--handedness", "right",
        "--mr-experience", "no")
    ran = [cli("session", "run", study, "--participant", "P01", "--input", "simulated", "--quiet") for _ in range(2)]
    with open_study(study, readonly=True) as store:
        before = [session_content(store.db, s.id) for s in store.sessions_of("P01")]
    child = subprocess.Popen([sys.executable, "-m", "tests.study.program_child", str(study)], cwd=ROOT,
                             stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    ended(child, "the session killed in its third task")
    killed = child.returncode
    resumed = cli("session", "resume", study, "--participant", "P01", "--quiet")
    ran += [cli("session", "run", study, "--participant", "P01", "--input", "simulated", "--quiet")
            for _ in range(3)]
    cli("export", study, "--out", folder / "export", "--no-frames", "--no-bids")
    return study, before, killed, resumed, ran, folder / "export"


def test_the_trainee_runs_six_sessions_in_order_on_the_simulated_calendar(program):
    study, _, _, _, ran, export = program
    assert "session 'pretest' of P01: completed" in ran[0] and "session 'retention' of P01" in ran[-1]
    with open_study(study, readonly=True) as store:
        sessions = store.sessions_of("P01")
        created = datetime.date.fromisoformat(store.created_at[:10])
    plans = PROGRAM.sessions_for("P")
    assert [s.name for s in sessions] == [p.name for p in plans] and [s.index for s in sessions] == [1, 2, 3, 4, 5, 6]
    day = created
    for session, plan in zip(sessions, plans):  # each on the earliest day it may run
        day += datetime.timedelta(days=plan.after_days)
        assert (session.date, session.due, session.date_simulated, session.ignored_schedule) == (day, day, True, False)
    result = CliRunner().invoke(main, ["session", "run", str(study), "--participant", "P01", "--input", "simulated"])
    assert result.exit_code == 1 and "has run every session of the program" in result.output


def test_the_trainee_carries_practice_from_one_day_to_the_next(program):
    """Each session's simulated trainee knows the earlier sessions' practice (days ago, tasks done:
    ``TaskPlan.earlier_sessions``), which the population's forgetting discounts."""
    from microg.study.session import earlier_sessions

    with open_study(program[0], readonly=True) as store:
        sessions = store.sessions_of("P01")
        measured = [sum(store.task_counts(s.id)[k] for k in ("completed", "timeout")) for s in sessions]
        assert earlier_sessions(store, sessions[0]) == ()
        assert earlier_sessions(store, sessions[2]) == ((2.0, measured[0]), (1.0, measured[1]))
        last = earlier_sessions(store, sessions[5])
        assert [days for days, _ in last] == [11.0, 10.0, 9.0, 8.0, 7.0] and [n for _, n in last] == measured[:5]


def test_a_session_killed_midway_resumes_there_and_the_earlier_sessions_are_untouched(program):
    study, before, killed, resumed, _, _ = program
    assert killed == -9 and "session 'train2' of P01: completed" in resumed
    with open_study(study, readonly=True) as store:
        sessions = store.sessions_of("P01")
        assert [session_content(store.db, s.id) for s in sessions[:2]] == before
        train2 = sessions[2]
        runs = [(r.task_index, r.run, r.status) for r in store.runs(train2.id)]
        tasks = store.tasks(train2.id)
    assert [run[:2] for run in runs[:4]] == [(tasks[0].index, 1), (tasks[1].index, 1), (tasks[2].index, 1),
                                             (tasks[2].index, 2)]
    assert runs[2][2] == "interrupted" and {run[2] for run in runs[:2] + runs[3:4]} <= {"completed", "timeout"}
    assert [t.task_in_phase for t in tasks] == list(range(1, len(tasks) + 1))  # nothing planned twice or skipped
    check = CliRunner().invoke(main, ["study", "check", str(study)])
    assert check.exit_code == 0 and "sound" in check.output, check.output


def _by_hand(phase, trials: pd.DataFrame) -> int | None:
    """The task at which ``phase``'s criterion is met, counted by hand from the trials: the first
    task ending ``consecutive`` tasks in a row completed within time_s with at most ``attempts``."""
    until, in_a_row = phase.until, 0
    for row in trials.itertuples():
        clean = row.completed and row.time_s <= until.time_s and row.attempts <= until.attempts
        in_a_row = in_a_row + 1 if clean else 0
        if in_a_row == until.consecutive:
            return row.task_in_phase
    return None


def test_each_phase_trained_to_a_criterion_ends_at_the_criterion_or_its_bound(program):
    trials = pd.read_csv(program[5] / "trials.csv")
    progression = pd.read_csv(program[5] / "progression.csv")
    trained = [p for p in PROGRAM.phases if p.until is not None]
    seen = 0
    for (session, phase_name), tasks in trials[trials.phase.isin([p.name for p in trained])].groupby(
            ["session", "phase"], sort=False):
        phase = next(p for p in trained if p.name == phase_name)
        met = _by_hand(phase, tasks)
        assert len(tasks) == (met if met else phase.max_tasks), (session, phase_name)
        assert list(tasks.task_in_phase) == list(range(1, len(tasks) + 1))
        objects = [PROGRAM.object(name).code for name in phase.cycle or [o.name for o in PROGRAM.objects]]
        assert list(tasks.object) == [objects[i % len(objects)] for i in range(len(tasks))]  # in turn
        assert list(tasks.criterion_met) == [met == k for k in tasks.task_in_phase]
        row = progression[(progression.session == session) & (progression.phase == phase_name)].iloc[0]
        assert (row.tasks, bool(row.criterion_met)) == (len(tasks), met is not None)
        assert (row.tasks_to_criterion if met else None) == (met if met else None) or pd.isna(row.tasks_to_criterion)
        seen += 1
    assert seen == 4  # trainpaper or trainbase three times, one catch phase
    tests = trials[trials.phase == "test"]
    assert tests.criterion_met.isna().all() and tests.difficulty.isna().all()
    assert list(tests.session.unique()) == ["pretest", "posttest", "retention"]


def test_the_staircase_moves_by_its_rule_applied_by_hand_to_the_logged_successes(program):
    """2-down-1-up on the catch's launch speed (larger is harder) by a factor: two successes in a row
    multiply it, one failure divides it, within min and max; a success meets the phase's criterion."""
    trials = pd.read_csv(program[5] / "trials.csv")
    catches = trials[trials.task_kind == "catch"]
    phase = next(p for p in PROGRAM.phases if p.name == catches.phase.iloc[0])
    stairs, until = phase.staircase, phase.until
    value, successes = stairs.start, 0
    for row in catches.itertuples():
        assert row.difficulty == pytest.approx(value, rel=1e-12), row.task_in_phase
        if row.completed and row.time_s <= until.time_s and row.attempts <= until.attempts:
            successes += 1
            if successes == 2:
                value, successes = min(stairs.maximum, value * stairs.factor), 0
        else:
            value, successes = max(stairs.minimum, value / stairs.factor), 0


def test_the_export_has_the_sessions_columns_and_progression(program):
    export = program[5]
    trials = pd.read_csv(export / "trials.csv")
    assert {"session", "session_index", "session_date", "task_in_phase", "criterion_met", "difficulty",
            "session_id"} <= set(trials.columns)
    assert list(pd.read_csv(export / "progression.csv").columns) == [
        "participant", "group", "session", "session_index", "phase", "tasks", "criterion_met", "tasks_to_criterion",
        "minutes", "final_difficulty"]
    book = pd.read_csv(export / "codebook.csv", keep_default_na=False)
    assert set(book[book.table == "progression"].column) == set(pd.read_csv(export / "progression.csv").columns)
    with open_study(program[0], readonly=True) as store:
        assert trials_table(store).session_date.tolist() == trials.session_date.tolist()


def test_a_session_before_its_day_is_refused_with_its_due_date_and_run_anyway_when_asked(tmp_path):
    """A trainee at the lab (the real calendar): train1 is due the day after the pre-test; asked for
    on the pre-test's day it is refused naming that date; ``ignore_schedule`` runs it and the log
    says so."""
    study = tmp_path / "study"
    cli("study", "init", study, "--protocol", "microgravity-training", "--seed", "3")
    cli("participant", "add", study, "--id", "P01", "--gender", "male", "--age", "30", "--handedness", "left",
        "--mr-experience", "yes")
    monday = datetime.date(2027, 3, 1)
    with open_study(study) as store:
        inputs = open_inputs("simulated", store.protocol.group(store.participant("P01").group))
        first = store.create_session("P01", input_spec="leap", simulated=False, clock="wall", today=monday)
        assert (first.name, first.date, first.due) == ("pretest", monday, monday)
        run_session(store, first.id, inputs, clock=SimulationClock())
        with pytest.raises(StoreError, match=r"session 'train1' is due on 2027-03-02 \(1 day\(s\) after their "
                                             r"session 'pretest' on 2027-03-01\).*--ignore-schedule"):
            store.create_session("P01", input_spec="leap", simulated=False, clock="wall", today=monday)
        with pytest.raises(StoreError, match="--session 'train2' is out of order for participant P01: their next "
                                             "session is 'train1'"):
            store.create_session("P01", input_spec="leap", simulated=False, clock="wall", session="train2",
                                 today=monday + datetime.timedelta(days=5))
        with pytest.raises(StoreError, match="session 'pretest' ran already .* a session is never run twice"):
            store.create_session("P01", input_spec="leap", simulated=False, clock="wall", session="pretest",
                                 today=monday + datetime.timedelta(days=5))
        early = store.create_session("P01", input_spec="leap", simulated=False, clock="wall", ignore_schedule=True,
                                     today=monday)
        assert (early.name, early.date, early.due, early.ignored_schedule) == (
            "train1", monday, monday + datetime.timedelta(days=1), True)
        logged = [e.data for e in store.events(early.id) if e.kind == "schedule_ignored"]
        assert logged == [{"session": "train1", "due": "2027-03-02", "date": "2027-03-01"}]
    status = cli("study", "status", study)
    assert "pretest: completed on 2027-03-01" in status and "train1: running since 2027-03-01" in status
    schedule = cli("study", "schedule", study, "--days", "3", "--out", tmp_path / "schedule.csv")
    table = pd.read_csv(tmp_path / "schedule.csv")
    assert table[["participant", "session", "state"]].values.tolist() == [["P01", "train1", "running"]]
    assert "wrote" in schedule


def test_motion_bids_names_each_session_and_counts_an_objects_repeated_runs(program, tmp_path):
    from microg.study.bids import write_motion_bids
    from microg.study.export import run_list

    with open_study(program[0], readonly=True) as store:
        runs = [r for r in run_list(store) if r["session"] in ("pretest", "train1")]
        written = write_motion_bids(store, tmp_path / "bids", runs=runs)
    motion = sorted(p.relative_to(tmp_path / "bids").as_posix() for p in written if p.name.endswith("_motion.tsv"))
    assert len(motion) == len(runs)  # no two recordings share a name
    assert "sub-P01/ses-pretest/motion/sub-P01_ses-pretest_task-test_tracksys-hand_acq-cube_run-1_motion.tsv" in motion
    trained = [name for name in motion if "_task-train" in name and "_acq-cube_" in name]
    assert trained and all(name.startswith("sub-P01/ses-train1/motion/") for name in trained)
    assert [name.rsplit("_run-", 1)[1] for name in trained] == [f"{k}_motion.tsv" for k in range(1, len(trained) + 1)]


def test_a_trainee_who_ran_the_whole_program_is_not_handed_to_a_station(program, tmp_path):
    """(A trainee with sessions left goes to a station with their earlier sessions: test_stations.py.)"""
    from microg.study.assignment import ParticipantError
    from microg.study.stations import make_station

    with open_study(program[0]) as store:
        with pytest.raises(ParticipantError, match=r"--participant P01: not handed to station B: participant P01 has "
                                                   r"run every session of the program \(pretest, "):
            make_station(store, "B", out_dir=tmp_path / "station", participants=["P01"])
    assert not (tmp_path / "station").exists()


def test_a_trainees_page_shows_their_sessions_tasks_to_criterion_and_what_is_next(program, tmp_path):
    study, export = program[0], program[5]
    out = tmp_path / "page"
    said = cli("report", study, "--participant", "P01", "--out", out)
    page = (out / "trainee-P01.html").read_text()
    assert f"trainee's page: {out / 'trainee-P01.html'}" in said
    assert "Next: nothing: every session of the program is done" in page and "data:image/png;base64," in page
    summary = pd.read_csv(out / "trainee-P01.csv")
    progression = pd.read_csv(export / "progression.csv")
    assert summary[["session", "phase", "tasks"]].values.tolist() == \
        progression.sort_values(["session_index", "phase"])[["session", "phase", "tasks"]].values.tolist()
    met = progression.dropna(subset=["tasks_to_criterion"]).sort_values(["session_index", "phase"])
    assert summary.dropna(subset=["tasks_to_criterion"])["tasks_to_criterion"].tolist() == \
        met["tasks_to_criterion"].astype(int).tolist()
    result = CliRunner().invoke(main, ["report", str(study), "--participant", "P07", "--out", str(tmp_path / "x")])
    assert result.exit_code == 1 and "--participant 'P07': no participant 'P07'" in result.output
