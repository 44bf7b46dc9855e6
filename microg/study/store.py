"""The log store: one SQLite database per study (``<study>/study.db``), in WAL mode.

Every event, task result and answer is committed when it happens; frames go in batches of the
protocol's ``logging.frame_batch``. With ``synchronous = FULL`` a commit is on disk before the
session goes on, so a crash (even SIGKILL or a power cut) loses at most the frames of the batch
in progress and never a task result. Nothing is overwritten: triggers make events, frames,
answers, plans and protocols append-only, and a task run, session or participant can only move
forward from its open state (running -> finished, active -> withdrawn), never back or twice.

Tables (see ``SCHEMA``): ``study`` (one row: name, seed, version), ``protocols`` (the resolved
protocol with its object files, as JSON, plus the file's own text), ``participants``
(demographics, group, object order, status), ``sessions`` (one per participant, with provenance:
protocol, seed, package and Python version, input, clock), ``tasks`` (the session's planned
tasks), ``task_runs`` (each time a task is run; a run cut off by a crash is marked
``interrupted`` on resume and the task runs again), ``events``, ``answers`` and ``frames``.

A frame row holds the task state (stage, current place, lit, timer, grasped, held), the phalanx
slots touching the object as a bit mask (bit k = slot k, ``microg.sim.slot_name(k)``), the
object's pose and velocities, and one blob per hand side (NULL when that hand was not tracked):
float64 little-endian, ``HAND_LAYOUT`` in order. That is enough to draw a session again, and the
tracked joints (exactly as the source delivered them) are enough to simulate it again.
"""

from __future__ import annotations

import datetime
import fcntl
import json
import os
import platform
import sqlite3
import sys
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from microg import __version__

from .assignment import Enrolled, Participant, ParticipantError, assign_group, assign_order, check_participant
from .protocol import Protocol, canonical_json, protocol_from_resolved

DATABASE = "study.db"
SCHEMA_VERSION = 1
FINAL_RUN = ("completed", "timeout", "aborted", "skipped")
RUN_STATUSES = FINAL_RUN + ("running", "interrupted")
HAND_LAYOUT = (("joints", 75), ("widths", 20), ("palm_position", 3), ("palm_orientation", 4), ("rendered", 60))
"""A hand blob: joints (5 digits x 5 joints x 3, the source's values), bone widths (5 x 4), palm
position (3), palm orientation (w, x, y, z), rendered (god-object) phalanx centres (20 x 3)."""
HAND_VALUES = sum(n for _, n in HAND_LAYOUT)


def hand_values(blob: bytes | None) -> np.ndarray:
    """The ``HAND_VALUES`` numbers of a logged hand blob; all NaN where the hand was not tracked (NULL)."""
    return np.full(HAND_VALUES, np.nan) if blob is None else np.frombuffer(blob, dtype="<f8")


def hand_parts(values: np.ndarray) -> dict[str, np.ndarray]:
    """Hand values split by name as ``HAND_LAYOUT`` says (flat views)."""
    parts, start = {}, 0
    for name, size in HAND_LAYOUT:
        parts[name] = values[start:start + size]
        start += size
    return parts

SCHEMA = """
CREATE TABLE study (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    name TEXT NOT NULL,
    seed INTEGER NOT NULL,
    protocol_id INTEGER NOT NULL REFERENCES protocols(id),
    created_at TEXT NOT NULL,
    microg_version TEXT NOT NULL,
    schema_version INTEGER NOT NULL
);
CREATE TABLE protocols (
    id INTEGER PRIMARY KEY,
    name TEXT NOT NULL,
    sha256 TEXT NOT NULL UNIQUE,
    resolved TEXT NOT NULL,
    source_text TEXT NOT NULL,
    added_at TEXT NOT NULL
);
CREATE TABLE participants (
    id TEXT PRIMARY KEY,
    number INTEGER NOT NULL UNIQUE,
    group_code TEXT NOT NULL,
    gender TEXT NOT NULL,
    age INTEGER NOT NULL,
    handedness TEXT NOT NULL,
    mr_experience INTEGER NOT NULL,
    order_row INTEGER,
    object_order TEXT NOT NULL,
    status TEXT NOT NULL DEFAULT 'active' CHECK (status IN ('active', 'withdrawn')),
    added_at TEXT NOT NULL,
    withdrawn_at TEXT,
    withdraw_reason TEXT
);
CREATE TABLE sessions (
    id INTEGER PRIMARY KEY,
    participant_id TEXT NOT NULL UNIQUE REFERENCES participants(id),
    protocol_id INTEGER NOT NULL REFERENCES protocols(id),
    seed INTEGER NOT NULL,
    input TEXT NOT NULL,
    simulated INTEGER NOT NULL,
    clock TEXT NOT NULL,
    object_order TEXT NOT NULL,
    microg_version TEXT NOT NULL,
    python TEXT NOT NULL,
    platform TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('running', 'completed', 'aborted')),
    created_at TEXT NOT NULL,
    ended_at TEXT
);
CREATE TABLE tasks (
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    task_index INTEGER NOT NULL,
    phase TEXT NOT NULL,
    system TEXT NOT NULL,
    object TEXT NOT NULL,
    object_code TEXT NOT NULL,
    order_position INTEGER NOT NULL,
    PRIMARY KEY (session_id, task_index)
);
CREATE TABLE task_runs (
    id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL,
    task_index INTEGER NOT NULL,
    run INTEGER NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('running', 'completed', 'timeout', 'aborted', 'skipped', 'interrupted')),
    reason TEXT,
    source TEXT NOT NULL,
    seed INTEGER NOT NULL,
    started_at REAL NOT NULL,
    ended_at REAL,
    time_s REAL,
    attempts INTEGER,
    frames INTEGER,
    started_wall TEXT NOT NULL,
    ended_wall TEXT,
    UNIQUE (session_id, task_index, run),
    FOREIGN KEY (session_id, task_index) REFERENCES tasks(session_id, task_index)
);
CREATE TABLE events (
    id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    run_id INTEGER REFERENCES task_runs(id),
    t REAL NOT NULL,
    wall TEXT NOT NULL,
    kind TEXT NOT NULL,
    data TEXT NOT NULL
);
CREATE INDEX events_by_session ON events(session_id, run_id);
CREATE TABLE answers (
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    system TEXT NOT NULL,
    item TEXT NOT NULL,
    rating INTEGER NOT NULL,
    source TEXT NOT NULL CHECK (source IN ('participant', 'model')),
    t REAL NOT NULL,
    wall TEXT NOT NULL,
    PRIMARY KEY (session_id, system, item)
);
CREATE TABLE frames (
    run_id INTEGER NOT NULL REFERENCES task_runs(id),
    frame INTEGER NOT NULL,
    t REAL NOT NULL,
    stage TEXT NOT NULL,
    place INTEGER NOT NULL,
    place_lit INTEGER NOT NULL,
    place_timer REAL NOT NULL,
    grasped INTEGER NOT NULL,
    held INTEGER NOT NULL,
    touching INTEGER NOT NULL,
    px REAL NOT NULL, py REAL NOT NULL, pz REAL NOT NULL,
    qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
    vx REAL NOT NULL, vy REAL NOT NULL, vz REAL NOT NULL,
    wx REAL NOT NULL, wy REAL NOT NULL, wz REAL NOT NULL,
    left BLOB,
    right BLOB,
    PRIMARY KEY (run_id, frame)
);
"""

_INSERT_FRAMES = f"INSERT INTO frames VALUES ({', '.join('?' * 25)})"
"""A ``frames`` row has 25 columns (``microg.study.session.frame_row``)."""

_APPEND_ONLY = ("study", "protocols", "tasks", "events", "answers", "frames")
_GUARDS = "".join(
    f"""
CREATE TRIGGER {table}_no_update BEFORE UPDATE ON {table}
BEGIN SELECT RAISE(ABORT, '{table} rows are never changed: the log is append-only'); END;
CREATE TRIGGER {table}_no_delete BEFORE DELETE ON {table}
BEGIN SELECT RAISE(ABORT, '{table} rows are never deleted: the log is append-only'); END;
""" for table in _APPEND_ONLY) + """
CREATE TRIGGER task_runs_once BEFORE UPDATE ON task_runs
WHEN OLD.status != 'running' OR NEW.status = 'running'
  OR NEW.session_id IS NOT OLD.session_id OR NEW.task_index IS NOT OLD.task_index OR NEW.run IS NOT OLD.run
  OR NEW.started_at IS NOT OLD.started_at OR NEW.seed IS NOT OLD.seed OR NEW.source IS NOT OLD.source
BEGIN SELECT RAISE(ABORT, 'a finished task run is never changed'); END;
CREATE TRIGGER sessions_once BEFORE UPDATE ON sessions
WHEN OLD.status != 'running' OR NEW.status = 'running' OR NEW.participant_id IS NOT OLD.participant_id
  OR NEW.seed IS NOT OLD.seed OR NEW.protocol_id IS NOT OLD.protocol_id OR NEW.created_at IS NOT OLD.created_at
BEGIN SELECT RAISE(ABORT, 'a finished session is never changed'); END;
CREATE TRIGGER participants_withdraw_only BEFORE UPDATE ON participants
WHEN OLD.status != 'active' OR NEW.status != 'withdrawn' OR NEW.id IS NOT OLD.id OR NEW.number IS NOT OLD.number
  OR NEW.group_code IS NOT OLD.group_code OR NEW.gender IS NOT OLD.gender OR NEW.age IS NOT OLD.age
  OR NEW.handedness IS NOT OLD.handedness OR NEW.mr_experience IS NOT OLD.mr_experience
  OR NEW.object_order IS NOT OLD.object_order OR NEW.order_row IS NOT OLD.order_row
BEGIN SELECT RAISE(ABORT, 'a participant can only be withdrawn, once; demographics are never changed'); END;
CREATE TRIGGER runs_no_delete BEFORE DELETE ON task_runs
BEGIN SELECT RAISE(ABORT, 'task_runs rows are never deleted'); END;
CREATE TRIGGER sessions_no_delete BEFORE DELETE ON sessions
BEGIN SELECT RAISE(ABORT, 'sessions rows are never deleted'); END;
CREATE TRIGGER participants_no_delete BEFORE DELETE ON participants
BEGIN SELECT RAISE(ABORT, 'participants rows are never deleted (withdraw instead)'); END;
"""


class StoreError(RuntimeError):
    """The study database refuses an operation; the message says why and what to do."""


@dataclass(frozen=True)
class ParticipantRecord:
    participant: Participant
    number: int
    group: str
    order_row: int | None
    object_order: tuple[str, ...]
    status: str

    @property
    def id(self) -> str:
        return self.participant.id


@dataclass(frozen=True)
class PlannedTask:
    index: int
    phase: str
    """``training`` or a stage name."""
    system: str
    object: str
    object_code: str
    order_position: int
    """1-based position of the object within its phase."""


@dataclass(frozen=True)
class SessionRecord:
    id: int
    participant_id: str
    seed: int
    input: str
    simulated: bool
    clock: str
    object_order: tuple[str, ...]
    status: str


@dataclass(frozen=True)
class RunRecord:
    id: int
    task_index: int
    run: int
    status: str
    started_at: float
    ended_at: float | None


@dataclass(frozen=True)
class Event:
    t: float
    kind: str
    data: dict


def utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")


def derived_seed(*parts: int) -> int:
    """A 63-bit seed drawn from ``parts``: independent streams for sessions and tasks."""
    return int(np.random.SeedSequence(list(parts)).generate_state(2, dtype=np.uint64)[0] >> np.uint64(1))


def plan_tasks(protocol: Protocol, group: str, object_order: tuple[str, ...]) -> list[PlannedTask]:
    """The tasks a participant of ``group`` runs, in order: training (if the group trains), then each
    stage with the participant's object order."""
    tasks: list[PlannedTask] = []
    for phase in protocol.phases_for(group):
        if phase.name == "training":
            names, system = [o.name for o in protocol.training.objects], protocol.training.system
        elif phase.name in [s.name for s in protocol.stages]:
            names, system = list(object_order), next(s.system for s in protocol.stages if s.name == phase.name)
        else:
            continue
        for position, name in enumerate(names, start=1):
            tasks.append(PlannedTask(len(tasks), phase.name, system, name, protocol.object(name).code, position))
    return tasks


def _connect(path: Path) -> sqlite3.Connection:
    connection = sqlite3.connect(path, isolation_level=None, timeout=30.0)
    connection.execute("PRAGMA page_size = 16384")
    connection.execute("PRAGMA journal_mode = WAL")
    connection.execute("PRAGMA synchronous = FULL")
    connection.execute("PRAGMA foreign_keys = ON")
    connection.row_factory = sqlite3.Row
    return connection


class Store:
    """An open study database. Create with ``create_study``, open with ``open_study``."""

    def __init__(self, study_dir: Path, connection: sqlite3.Connection):
        self.dir = study_dir
        self.db = connection
        row = self.db.execute("SELECT s.name, s.seed, p.resolved FROM study s JOIN protocols p ON p.id = s.protocol_id"
                              ).fetchone()
        self.name: str = row["name"]
        self.seed: int = row["seed"]
        self.protocol: Protocol = protocol_from_resolved(json.loads(row["resolved"]), f"{study_dir / DATABASE}")
        self._locks: dict[int, int] = {}

    # ------------------------------------------------------------ plumbing

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """One atomic, durable write: everything inside commits together or not at all."""
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield self.db
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    def close(self) -> None:
        for fd in self._locks.values():
            os.close(fd)
        self._locks.clear()
        self.db.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def lock_session(self, session_id: int) -> None:
        """Hold the session for this process; the operating system frees it when the process ends."""
        folder = self.dir / "locks"
        folder.mkdir(exist_ok=True)
        fd = os.open(folder / f"session-{session_id}.lock", os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise StoreError(f"session {session_id} is being run by another process right now") from None
        self._locks[session_id] = fd

    # ------------------------------------------------------------ participants

    def _enrolled(self) -> list[Enrolled]:
        rows = self.db.execute("SELECT group_code, gender, order_row FROM participants WHERE status = 'active'")
        return [Enrolled(r["group_code"], r["gender"], r["order_row"]) for r in rows]

    def add_participant(self, participant: Participant) -> ParticipantRecord:
        """Enrol a participant: validate, assign a group and an object order, commit."""
        check_participant(participant, self.protocol)
        with self.transaction() as db:
            if db.execute("SELECT 1 FROM participants WHERE id = ?", (participant.id,)).fetchone():
                raise ParticipantError(f"participant {participant.id} is already in study {self.name!r}; "
                                       "ids are never reused")
            number = db.execute("SELECT COALESCE(MAX(number), 0) + 1 FROM participants").fetchone()[0]
            enrolled = self._enrolled()
            group = assign_group(self.protocol, enrolled, participant.gender,
                                 np.random.default_rng([self.seed, number]))
            row, order = assign_order(self.protocol, group, enrolled, participant.id, self.seed)
            p = participant
            db.execute("INSERT INTO participants (id, number, group_code, gender, age, handedness, mr_experience, "
                       "order_row, object_order, added_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (p.id, number, group, p.gender, p.age, p.handedness, int(p.mr_experience), row,
                        json.dumps(order), utc_now()))
        return self.participant(participant.id)

    def withdraw(self, participant_id: str, reason: str) -> None:
        """Withdraw a participant: their data stays, their slot and order row are free again, and an
        unfinished session of theirs ends as aborted."""
        record = self.participant(participant_id)
        if record.status == "withdrawn":
            raise ParticipantError(f"participant {participant_id} is already withdrawn")
        with self.transaction() as db:
            db.execute("UPDATE participants SET status = 'withdrawn', withdrawn_at = ?, withdraw_reason = ? "
                       "WHERE id = ?", (utc_now(), reason, participant_id))
        session = self.session_of(participant_id)
        if session is not None and session.status == "running":
            t = self.last_time(session.id)
            self.interrupt_open_runs(session.id, t)
            self.end_session(session.id, "aborted", t, reason=f"participant withdrawn: {reason}")

    @staticmethod
    def _participant(row: sqlite3.Row) -> ParticipantRecord:
        return ParticipantRecord(
            Participant(row["id"], row["gender"], row["age"], row["handedness"], bool(row["mr_experience"])),
            number=row["number"], group=row["group_code"], order_row=row["order_row"],
            object_order=tuple(json.loads(row["object_order"])), status=row["status"])

    def participant(self, participant_id: str) -> ParticipantRecord:
        row = self.db.execute("SELECT * FROM participants WHERE id = ?", (participant_id,)).fetchone()
        if row is None:
            raise ParticipantError(f"no participant {participant_id!r} in study {self.name!r} "
                                   "(add one with: microg participant add)")
        return self._participant(row)

    def participants(self) -> list[ParticipantRecord]:
        return [self._participant(r) for r in self.db.execute("SELECT * FROM participants ORDER BY number")]

    # ------------------------------------------------------------ sessions

    def create_session(self, participant_id: str, input_spec: str, simulated: bool, clock: str) -> SessionRecord:
        """A new session for an active participant who has none, with its task plan."""
        record = self.participant(participant_id)
        if record.status != "active":
            raise StoreError(f"participant {participant_id} is withdrawn; a withdrawn participant runs no session")
        existing = self.session_of(participant_id)
        if existing is not None:
            raise StoreError(f"participant {participant_id} already has session {existing.id} ({existing.status}); "
                             + ("continue it with: microg session resume" if existing.status == "running"
                                else "a session is never run twice"))
        protocol_id = self.db.execute("SELECT protocol_id FROM study").fetchone()[0]
        seed = derived_seed(self.seed, record.number)
        with self.transaction() as db:
            cursor = db.execute(
                "INSERT INTO sessions (participant_id, protocol_id, seed, input, simulated, clock, object_order, "
                "microg_version, python, platform, status, created_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'running', ?)",
                (participant_id, protocol_id, seed, input_spec, int(simulated), clock, json.dumps(record.object_order),
                 __version__, sys.version.split()[0], platform.platform(), utc_now()))
            session_id = cursor.lastrowid
            db.executemany("INSERT INTO tasks VALUES (?, ?, ?, ?, ?, ?, ?)",
                           [(session_id, t.index, t.phase, t.system, t.object, t.object_code, t.order_position)
                            for t in plan_tasks(self.protocol, record.group, record.object_order)])
        return self.session(session_id)

    @staticmethod
    def _session(row: sqlite3.Row) -> SessionRecord:
        return SessionRecord(row["id"], row["participant_id"], row["seed"], row["input"], bool(row["simulated"]),
                             row["clock"], tuple(json.loads(row["object_order"])), row["status"])

    def session(self, session_id: int) -> SessionRecord:
        row = self.db.execute("SELECT * FROM sessions WHERE id = ?", (session_id,)).fetchone()
        if row is None:
            raise StoreError(f"no session {session_id} in study {self.name!r}")
        return self._session(row)

    def session_of(self, participant_id: str) -> SessionRecord | None:
        row = self.db.execute("SELECT * FROM sessions WHERE participant_id = ?", (participant_id,)).fetchone()
        return None if row is None else self._session(row)

    def tasks(self, session_id: int) -> list[PlannedTask]:
        rows = self.db.execute("SELECT * FROM tasks WHERE session_id = ? ORDER BY task_index", (session_id,))
        return [PlannedTask(r["task_index"], r["phase"], r["system"], r["object"], r["object_code"],
                            r["order_position"]) for r in rows]

    def runs(self, session_id: int) -> list[RunRecord]:
        rows = self.db.execute("SELECT * FROM task_runs WHERE session_id = ? ORDER BY id", (session_id,))
        return [RunRecord(r["id"], r["task_index"], r["run"], r["status"], r["started_at"], r["ended_at"])
                for r in rows]

    def finished_tasks(self, session_id: int) -> set[int]:
        return {r.task_index for r in self.runs(session_id) if r.status in FINAL_RUN}

    def events(self, session_id: int, run_id: int | None = None) -> list[Event]:
        query = "SELECT t, kind, data FROM events WHERE session_id = ?" + (" AND run_id = ?" if run_id else "")
        rows = self.db.execute(query + " ORDER BY id", (session_id, run_id) if run_id else (session_id,))
        return [Event(r["t"], r["kind"], json.loads(r["data"])) for r in rows]

    def answers(self, session_id: int) -> dict[tuple[str, str], int]:
        rows = self.db.execute("SELECT system, item, rating FROM answers WHERE session_id = ?", (session_id,))
        return {(r["system"], r["item"]): r["rating"] for r in rows}

    def last_time(self, session_id: int) -> float:
        """The latest session-clock time logged, so a resumed clock carries on from there."""
        row = self.db.execute("SELECT MAX(t) FROM events WHERE session_id = ?", (session_id,)).fetchone()
        return float(row[0] or 0.0)

    # ------------------------------------------------------------ logging while a session runs

    @staticmethod
    def _insert_events(db: sqlite3.Connection, session_id: int, run_id: int | None, events: list[Event]) -> None:
        wall = utc_now()
        db.executemany("INSERT INTO events (session_id, run_id, t, wall, kind, data) VALUES (?, ?, ?, ?, ?, ?)",
                       [(session_id, run_id, e.t, wall, e.kind, canonical_json(e.data)) for e in events])

    def log(self, session_id: int, events: list[Event], run_id: int | None = None) -> None:
        """Commit events now."""
        if events:
            with self.transaction() as db:
                self._insert_events(db, session_id, run_id, events)

    def begin_run(self, session_id: int, task: PlannedTask, source: str, seed: int, t: float) -> int:
        """Open a run of ``task`` (the next run number) and log its start."""
        with self.transaction() as db:
            number = db.execute("SELECT COALESCE(MAX(run), 0) + 1 FROM task_runs WHERE session_id = ? AND task_index = ?",
                                (session_id, task.index)).fetchone()[0]
            run_id = db.execute(
                "INSERT INTO task_runs (session_id, task_index, run, status, source, seed, started_at, started_wall) "
                "VALUES (?, ?, ?, 'running', ?, ?, ?, ?)",
                (session_id, task.index, number, source, seed, t, utc_now())).lastrowid
            self._insert_events(db, session_id, run_id, [Event(t, "task_start", {
                "task": task.index, "run": number, "phase": task.phase, "system": task.system, "object": task.object})])
        return run_id

    def add_frames(self, rows: list[tuple]) -> None:
        """Commit a batch of frame rows (see ``frame_row``)."""
        if rows:
            with self.transaction() as db:
                db.executemany(_INSERT_FRAMES, rows)

    def end_run(self, run_id: int, status: str, t: float, *, time_s: float | None = None,
                attempts: int | None = None, reason: str | None = None, frames: list[tuple] = (),
                events: list[Event] = ()) -> None:
        """Close a run: its last frames, its result and its end event in one transaction."""
        if status not in RUN_STATUSES or status == "running":
            raise ValueError(f"end_run(status = {status!r}): must be one of {RUN_STATUSES[:-2] + ('interrupted',)}")
        session_id, = self.db.execute("SELECT session_id FROM task_runs WHERE id = ?", (run_id,)).fetchone()
        with self.transaction() as db:
            if frames:
                db.executemany(_INSERT_FRAMES, frames)
            count = db.execute("SELECT COUNT(*) FROM frames WHERE run_id = ?", (run_id,)).fetchone()[0]
            db.execute("UPDATE task_runs SET status = ?, reason = ?, ended_at = ?, time_s = ?, attempts = ?, "
                       "frames = ?, ended_wall = ? WHERE id = ?",
                       (status, reason, t, time_s, attempts, count, utc_now(), run_id))
            self._insert_events(db, session_id, run_id, list(events) + [Event(t, "task_end", {
                "status": status, "time_s": time_s, "attempts": attempts, "reason": reason})])

    def interrupt_open_runs(self, session_id: int, t: float) -> list[int]:
        """Mark runs left ``running`` by a crash as ``interrupted``; their frames stay."""
        open_runs = [r.id for r in self.runs(session_id) if r.status == "running"]
        for run_id in open_runs:
            self.end_run(run_id, "interrupted", t, reason="the process ended during the task (found on resume)")
        return open_runs

    def save_answer(self, session_id: int, system: str, item: str, rating: int, source: str, t: float) -> None:
        with self.transaction() as db:
            db.execute("INSERT INTO answers VALUES (?, ?, ?, ?, ?, ?, ?)",
                       (session_id, system, item, rating, source, t, utc_now()))
            self._insert_events(db, session_id, None, [Event(t, "answer", {
                "system": system, "item": item, "rating": rating, "source": source})])

    def end_session(self, session_id: int, status: str, t: float, reason: str | None = None) -> None:
        with self.transaction() as db:
            db.execute("UPDATE sessions SET status = ?, ended_at = ? WHERE id = ?", (status, utc_now(), session_id))
            self._insert_events(db, session_id, None, [Event(t, "session_end", {"status": status, "reason": reason})])


# ---------------------------------------------------------------- creating and opening


def create_study(study_dir: str | Path, protocol: Protocol, seed: int) -> Store:
    """A new study database in ``study_dir`` (created; it must not hold a study already)."""
    study_dir = Path(study_dir)
    path = study_dir / DATABASE
    if path.exists():
        raise StoreError(f"{path} exists: {study_dir} already holds a study; a study is never overwritten")
    if not isinstance(seed, int) or seed < 0:
        raise StoreError(f"seed = {seed!r}: must be a whole number >= 0")
    study_dir.mkdir(parents=True, exist_ok=True)
    connection = _connect(path)
    main_text = protocol.resolved["sources"][-1]["text"] if protocol.resolved.get("sources") else ""
    connection.executescript("BEGIN IMMEDIATE;" + SCHEMA + _GUARDS)  # committed below with the study row
    now = utc_now()
    protocol_id = connection.execute(
        "INSERT INTO protocols (name, sha256, resolved, source_text, added_at) VALUES (?, ?, ?, ?, ?)",
        (protocol.name, protocol.sha256, canonical_json(protocol.resolved), main_text, now)).lastrowid
    connection.execute("INSERT INTO study VALUES (1, ?, ?, ?, ?, ?, ?)",
                       (protocol.name, seed, protocol_id, now, __version__, SCHEMA_VERSION))
    connection.execute("COMMIT")
    return Store(study_dir, connection)


def open_study(study_dir: str | Path) -> Store:
    """The study in ``study_dir``."""
    study_dir = Path(study_dir)
    path = study_dir / DATABASE
    if not path.exists():
        raise StoreError(f"no study in {study_dir} (no {DATABASE}); create one with: microg study init {study_dir}")
    connection = _connect(path)
    version = connection.execute("SELECT schema_version FROM study").fetchone()[0]
    if version != SCHEMA_VERSION:
        raise StoreError(f"{path}: schema version {version}, this microg {__version__} reads {SCHEMA_VERSION}")
    return Store(study_dir, connection)
