"""A session killed with SIGKILL mid-task loses no finished task and at most the frame batch in
progress; resuming runs the cut-off task again and keeps its partial frames."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from microg.study.export import trials_table
from microg.study.session import SimulationClock, resume_session
from microg.study.store import open_study
from tests.waiting import ended, line_reader, next_item

from .conftest import scripted_inputs

ROOT = Path(__file__).resolve().parents[2]


def committed(db_path: Path) -> list[tuple]:
    """(task_index, status, frames) of each run, as another process sees the database."""
    with sqlite3.connect(f"file:{db_path}?mode=ro", uri=True) as db:
        return db.execute("SELECT r.task_index, r.status, (SELECT COALESCE(SUM(count), 0) FROM frames f WHERE f.run_id = r.id) "
                          "FROM task_runs r ORDER BY r.id").fetchall()


def test_sigkill_mid_task_loses_no_finished_task_and_at_most_one_frame_batch(make_study):
    store, _ = make_study("tiny")
    study_dir, batch = store.dir, store.protocol.frame_batch
    store.close()
    child = subprocess.Popen([sys.executable, "-m", "tests.study.crash_child", str(study_dir)], cwd=ROOT,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})
    made, lines = {}, line_reader(child.stdout)
    try:
        while (line := next_item(lines, "the child's next frame", seen=lambda: made)) is not None:
            word, task, n = line.split()
            made[int(task)] = int(n)
            # kill while the child waits to hand over the second task's frame 3.5 batches in
            if int(task) == 1 and int(n) == 3 * batch + batch // 2:
                break
            child.stdin.write("go\n")
            child.stdin.flush()
        else:
            pytest.fail("the child ended before the second task had handed over three batches")
        child.send_signal(signal.SIGKILL)
        ended(child, "the killed session")
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == -signal.SIGKILL

    runs = committed(study_dir / "study.db")
    (first_task, first_status, first_frames), (second_task, second_status, kept) = runs
    assert (first_task, first_status) == (0, "completed") and first_frames == made[0]
    assert (second_task, second_status) == (1, "running")
    # it had handed over 3.5 batches less the frame it held: the three whole batches are committed
    assert kept == 3 * batch

    with open_study(study_dir) as store:
        session = store.session_of("P01")
        assert store.db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        before = trials_table(store).iloc[0]
        status = resume_session(store, session.id, scripted_inputs(), clock=SimulationClock(store.last_time(session.id)))
        assert status == "completed"
        runs = store.runs(session.id)
        later = [(i, 1, "completed") for i in range(2, len(store.tasks(session.id)))]
        assert [(r.task_index, r.run, r.status) for r in runs] == [(0, 1, "completed"), (1, 1, "interrupted"),
                                                                    (1, 2, "completed")] + later
        assert store.db.execute("SELECT COALESCE(SUM(count), 0) FROM frames WHERE run_id = ?", (runs[1].id,)).fetchone()[0] == kept
        after = trials_table(store)
        assert after.iloc[0].time_s == before.time_s and after.completed.all()
        resumed = [e for e in store.events(session.id) if e.kind == "session_resume"]
        assert resumed and resumed[0].data["interrupted_runs"] == [runs[1].id]
