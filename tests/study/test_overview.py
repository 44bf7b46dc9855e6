"""The study's overview (what the dashboard shows), read from the store: its numbers against the export's
trials table, read on batch by batch while a session writes, and the same read on as read at once."""

from __future__ import annotations

import dataclasses
import json
import threading

import numpy as np
import pandas as pd
import pytest

from microg.hands.guard import GuardCounts
from microg.schema import REPORT_FILE
from microg.study.assignment import Participant
from microg.study.export import export_study, trials_table
from microg.study.overview import GUARD, Overview, study_overview
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import Event, create_study, open_study

from tests.waiting import joined, wait_until

from .conftest import PROTOCOLS, answers, scripted_inputs
from .scripted import gated_session

PAGE_LOGGED = {"display_quality": {"render_scale": 0.7, "render_width": 896, "render_height": 560, "antialias": False,
                                   "refresh_ms": 16.7, "gpu_ms": 9.5},
               "display_clock": {"offset_ms": -3.1, "rtt_ms": 0.8, "spread_ms": 0.3}}
PEOPLE = (("P01", "female"), ("P02", "male"), ("P03", "female"), ("P04", "male"), ("P05", "female"),
          ("P06", "male"))


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Six enrolled: P01-P04 ran their sessions (P02 dropped the cube once at place 2, P04 stayed at
    place 1 and timed out), P05 ran and was withdrawn, P06 has no session."""
    folder = tmp_path_factory.mktemp("overview") / "study"
    with create_study(folder, load_protocol(PROTOCOLS / "tiny.toml"), 3) as store:
        for pid, gender in PEOPLE:
            store.add_participant(Participant(pid, gender, 24, "right", True))
        scripts = {"P02": {"drop_at_place": 1}, "P04": {"dwell": 16.0}}
        for pid in ("P01", "P02", "P03", "P04", "P05"):
            session = store.create_session(pid, input_spec="scripted", simulated=True, clock="simulation")
            if pid == "P01":  # what a participant's page logs
                store.log(session.id, [Event(0.0, kind, data) for kind, data in PAGE_LOGGED.items()])
            run_session(store, session.id, scripted_inputs(**scripts.get(pid, {})), clock=SimulationClock(),
                        rater=answers("7", "6", "3", "4"))
        store.withdraw("P05", "moved away")
    return folder


def test_enrolment_and_the_means_per_phase_group_and_object_are_the_trials_tables(study):
    with open_study(study, readonly=True) as store:
        seen = study_overview(store)
        trials = trials_table(store)
        people = store.participants()
    json.dumps(seen)  # plain data, as the page gets it

    active = [p for p in people if p.status == "active"]
    for group in seen["enrolment"]["groups"]:
        members = [p for p in active if p.group == group["code"]]
        assert group["active"] == len(members)
        assert group["by"] == dict(pd.Series([p.participant.gender for p in members], dtype=object).value_counts())
        assert group["withdrawn"] == sum(p.status == "withdrawn" and p.group == group["code"] for p in people)
    assert seen["enrolment"]["active"] == 5 and seen["enrolment"]["withdrawn"] == 1
    assert seen["enrolment"]["target"] == sum(g["size"] for g in seen["enrolment"]["groups"]) == 30

    kept = trials[~trials["withdrawn"]]
    measured = kept[kept["attempts"].notna()]
    assert len(seen["results"]["points"]) == len(measured)
    assert {p["participant"] for p in seen["results"]["points"]} == {"P01", "P02", "P03", "P04"}
    expected = measured.groupby(["phase", "group", "object"]).agg(
        time_s=("time_s", "mean"), attempts=("attempts", "mean"), tasks=("attempts", "size"),
        completed=("time_s", "count"))
    means = {(m["phase"], m["group"], m["object"]): m for m in seen["results"]["means"]}
    assert set(means) == set(expected.index)
    for cell, row in expected.iterrows():
        mean = means[cell]
        assert (mean["tasks"], mean["completed"]) == (row["tasks"], row["completed"]), cell
        assert mean["attempts"] == pytest.approx(row["attempts"], rel=1e-12), cell
        assert (mean["time_s"] is None) if np.isnan(row["time_s"]) else \
            mean["time_s"] == pytest.approx(row["time_s"], rel=1e-12), cell
    # the scripts show in the numbers: P02's drop, P04's timeout
    assert any(p["participant"] == "P02" and p["attempts"] == 1 for p in seen["results"]["points"])
    assert any(p["participant"] == "P04" and p["status"] == "timeout" and p["time_s"] is None
               for p in seen["results"]["points"])


def test_every_session_and_participant_is_there_with_its_tasks_and_quality(study):
    with open_study(study, readonly=True) as store:
        seen = study_overview(store)
        trials = trials_table(store)
        runs = store.db.execute("SELECT session_id, SUM(frames), COUNT(*) FROM task_runs GROUP BY session_id").fetchall()
        spans = store.db.execute("SELECT run_id, SUM(count), MAX(t_last) - MIN(t_first) FROM frames "
                                 "GROUP BY run_id").fetchall()
        guard = [json.loads(d) for (d,) in store.db.execute("SELECT data FROM events WHERE kind = 'tracking_guard'")]
    people = {p["id"]: p for p in seen["participants"]}
    assert people["P06"]["sessions"] == [] and people["P05"]["status"] == "withdrawn"
    sessions = {s["participant"]: s for s in seen["sessions"]}
    assert set(sessions) == {"P01", "P02", "P03", "P04", "P05"}
    frames = {sid: n for sid, n, _ in runs}
    rate = sum(n - 1 for _, n, _ in spans) / sum(span for _, _, span in spans)
    for pid, session in sessions.items():
        rows = trials[trials["participant"] == pid]
        assert session["tasks"] == len(rows) and session["running"] is None and session["status"] != "running"
        assert session["counts"] == rows["status"].value_counts().to_dict()
        assert session["quality"]["frames"] == frames[session["id"]]
        assert session["quality"]["rate_hz"] == pytest.approx(rate, rel=1e-9)
        assert session["answers"] == session["answers_expected"] == 4
        for name, status in (("timeouts", "timeout"), ("skipped", "skipped"), ("aborted", "aborted")):
            assert session["quality"][name] == (rows["status"] == status).sum(), (pid, name)
    assert sessions["P04"]["quality"]["timeouts"] and not sessions["P01"]["quality"]["timeouts"]
    assert sessions["P01"]["quality"]["display"] == {kind.removeprefix("display_"): data
                                                     for kind, data in PAGE_LOGGED.items()}
    assert sessions["P02"]["quality"]["display"] is None
    assert all(session["quality"]["rate_hz"] == pytest.approx(110.0) for session in sessions.values())
    total = {name: sum(sum(g[c] for c in parts) for g in guard) for name, parts in GUARD.items()}
    assert {name: sum(s["quality"]["guard"][name] for s in sessions.values()) for name in GUARD} == total
    assert seen["questionnaires"] == [
        {"instrument": "paper", "administration": "questionnaire", "interaction": interaction, "answers": 10,
         "sessions": 5} for interaction in ("impulse_penetration", "soft_hand")]


def test_the_guard_counts_grouped_are_the_guards_own():
    counted = [name for parts in GUARD.values() for name in parts]
    assert len(counted) == len(set(counted))
    assert set(counted) <= {field.name for field in dataclasses.fields(GuardCounts)}


def test_read_on_batch_by_batch_it_follows_a_running_session_and_ends_as_read_at_once(tmp_path):
    folder = tmp_path / "study"
    with create_study(folder, load_protocol(PROTOCOLS / "tiny.toml"), 1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
    gate, waiting = threading.Semaphore(0), threading.Semaphore(0)
    writer = gated_session(folder, gate, waiting)  # commits a frame batch, says so, waits for the gate

    def batch_or_end():
        return "batch" if waiting.acquire(blocking=False) else "end" if not writer.is_alive() else None

    seen = []  # (task, frames, stage) of the running task, and the frames its run has stored, after each batch
    with open_study(folder, readonly=True) as store:
        overview = Overview(store)
        batch = store.protocol.frame_batch
        while wait_until(batch_or_end, "the session to commit a batch and wait, or to end",
                         seen=lambda: seen[-1:]) == "batch":
            assert overview.refresh()
            running = overview.summary()["sessions"][0]["running"]
            stored = store.db.execute("SELECT COALESCE(SUM(count), 0) FROM frames WHERE run_id = "
                                      "(SELECT MAX(id) FROM task_runs)").fetchone()[0]
            seen.append((running["task"], running["frames"], running["stage"], stored))
            assert not overview.refresh()  # nothing committed since: nothing read, nothing changed
            gate.release()
        joined(writer, "the session")
        overview.refresh()
        ended = overview.summary()
        assert ended == study_overview(store)
    assert all(frames == stored for _, frames, _, stored in seen)
    first = [frames for task, frames, _, _ in seen if task == seen[0][0]]
    assert len(first) >= 3 and first == [batch * (i + 1) for i in range(len(first))]  # batch by batch
    assert {task for task, *_ in seen} == set(range(ended["sessions"][0]["tasks"]))  # every task seen running
    assert {stage for _, _, stage, _ in seen} >= {"manipulation", "maintenance"}
    assert ended["sessions"][0]["running"] is None and ended["sessions"][0]["status"] != "running"


def test_the_newest_export_and_report_in_the_study_folder_and_what_came_since(study, tmp_path):
    import shutil

    copy = tmp_path / "study"
    shutil.copytree(study, copy)
    with open_study(copy, readonly=True) as store:
        assert study_overview(store)["export"] is None
    export_study(copy, copy / "export", frames=False, bids=False, progress=False)
    (copy / "report").mkdir()
    (copy / "report" / REPORT_FILE).write_text("<html>report</html>")
    with open_study(copy, readonly=True) as store:
        overview = Overview(store)
        overview.refresh()
        export = overview.summary()["export"]
        assert (export["folder"], export["facts_since"], export["damaged"]) == ("export", 0, [])
        assert export["files"] == len(json.loads((copy / "export" / "export.json").read_text())["files"])
        assert export["report"]["path"] == f"report/{REPORT_FILE}" and overview.report == copy / "report" / REPORT_FILE
        with open_study(copy) as writer:
            writer.add_participant(Participant("P07", "female", 30, "left", False))
        assert overview.refresh()
        assert overview.summary()["export"]["facts_since"] == 1
        assert overview.summary()["enrolment"]["active"] == 6


def test_a_training_programs_sessions_are_named_with_their_dates_and_the_next_one_is_due(tmp_path):
    """A trainee who ran the pre-test today (the real calendar): their session by name and date, and
    train1 due tomorrow (``microg.study.schedule``)."""
    import datetime

    from microg.paths import protocol_file
    from microg.study import Participant, create_study, open_inputs
    from microg.study.protocol import load_protocol
    from microg.study.session import SimulationClock, run_session

    today = datetime.date.today()
    with create_study(tmp_path / "study", load_protocol(protocol_file("microgravity-training")), 4) as store:
        store.add_participant(Participant("P01", "female", 24, "right", False))
        session = store.create_session("P01", input_spec="leap", simulated=False, clock="wall", today=today)
        run_session(store, session.id, open_inputs("simulated", store.protocol.group(store.participant("P01").group)),
                    clock=SimulationClock())
        seen = study_overview(store)
    assert seen["study"]["program"]
    [row] = seen["sessions"]
    assert (row["name"], row["date"], row["status"]) == ("pretest", today.isoformat(), "completed")
    [person] = seen["participants"]
    assert person["next"] == {"session": "train1", "state": "due",
                              "due": (today + datetime.timedelta(days=1)).isoformat()}
