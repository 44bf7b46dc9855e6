"""Another program holding part of a study until its standard input closes: ``db`` holds a write
transaction on the study database (as a database browser might), ``session`` holds a session's
lock with a task run open (as a running session does). Prints ``held`` once it holds it."""

from __future__ import annotations

import sqlite3
import sys

from microg.study.store import open_study


def main(what: str, study_dir: str) -> None:
    if what == "db":
        db = sqlite3.connect(f"{study_dir}/study.db", isolation_level=None)
        db.execute("BEGIN IMMEDIATE")
    else:
        store = open_study(study_dir)
        session = store.session_of("P01")
        store.lock_session(session.id)
        store.begin_run(session.id, task=store.tasks(session.id)[0], source="held by a test", seed=0, t=0.0)
    print("held", flush=True)
    sys.stdin.read()


if __name__ == "__main__":
    main(*sys.argv[1:])
