"""A session killed with SIGKILL mid-task loses no finished task and at most the frame batch in
progress; resuming runs the cut-off task again and keeps its partial frames."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

from microg.study.export import trials_table
from microg.study.session import SimulationClock, resume_session
from microg.study.store import open_study

from .conftest import scripted_inputs

ROOT = Path(__file__).resolve().parents[2]


def committed(db_path: Path) -> list[tuple]:
    """(task_index, status, frames) of each run, as another process sees the database."""
    with sqlite3.connect(f"file:{db_path}?mode=ro", uri=True, timeout=5) as db:
        return db.execute("SELECT r.task_index, r.status, (SELECT COUNT(*) FROM frames f WHERE f.run_id = r.id) "
                          "FROM task_runs r ORDER BY r.id").fetchall()


def test_sigkill_mid_task_loses_no_finished_task_and_at_most_one_frame_batch(make_study):
    store, _ = make_study("tiny")
    study_dir, batch = store.dir, store.protocol.frame_batch
    store.close()
    child = subprocess.Popen([sys.executable, "-m", "tests.study.crash_child", str(study_dir)], cwd=ROOT,
                             stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    handed_over = {}
    deadline = time.monotonic() + 60
    try:
        for line in child.stdout:
            word, task, n = line.split()
            handed_over[int(task)] = int(n)
            # kill once the second task has handed over frames for three batches and then some
            if int(task) == 1 and int(n) >= 3 * batch + batch // 2:
                break
            assert time.monotonic() < deadline, "the child never reached the second task"
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == -signal.SIGKILL

    runs = committed(study_dir / "study.db")
    (first_task, first_status, first_frames), (second_task, second_status, kept) = runs
    assert (first_task, first_status) == (0, "completed") and first_frames == handed_over[0]
    assert (second_task, second_status) == (1, "running")
    # the child may have handed over a few more frames than we read; what it committed is whole batches
    assert kept % batch == 0 and kept >= handed_over[1] - batch - 1

    with open_study(study_dir) as store:
        session = store.session_of("P01")
        assert store.db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        before = trials_table(store).iloc[0]
        status = resume_session(store, session.id, scripted_inputs(), clock=SimulationClock(store.last_time(session.id)),
                                progress=False)
        assert status == "completed"
        runs = store.runs(session.id)
        later = [(i, 1, "completed") for i in range(2, len(store.tasks(session.id)))]
        assert [(r.task_index, r.run, r.status) for r in runs] == [(0, 1, "completed"), (1, 1, "interrupted"),
                                                                    (1, 2, "completed")] + later
        assert store.db.execute("SELECT COUNT(*) FROM frames WHERE run_id = ?", (runs[1].id,)).fetchone()[0] == kept
        after = trials_table(store)
        assert after.iloc[0].time_s == before.time_s and after.completed.all()
        resumed = [e for e in store.events(session.id) if e.kind == "session_resume"]
        assert resumed and resumed[0].data["interrupted_runs"] == [runs[1].id]
