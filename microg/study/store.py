"""The log store: one SQLite database per study (``<study>/study.db``), in WAL mode.

Every event, task result and answer is committed when it happens; frames go in batches of the
protocol's ``logging.frame_batch``. With ``synchronous = FULL`` a commit is on disk before the
session goes on, so a crash (even SIGKILL or a power cut) loses at most the frames of the batch
in progress and never a task result. A simulated session commits with ``synchronous = NORMAL``
(``Store.commit_for``): as safe against the program's crash, while a power cut may take its last
commits too, which its seed computes again on resume. Nothing is overwritten: triggers make events, frames,
answers, plans and protocols append-only, and a task run, session or participant can only move
forward from its open state (running -> finished, active -> withdrawn), never back or twice.

Tables (``schema.sql`` beside this file): ``study`` (one row: name, seed, version), ``protocols`` (the resolved
protocol with its object files, as JSON, plus the file's own text), ``participants``
(demographics, group, object order, status), ``sessions`` (a participant's sittings: one, or each
session of a training program by name, with its date and provenance: protocol, seed, package and
Python version, input, clock), ``tasks`` (the session's planned tasks; a phase that trains to a
criterion adds each of its tasks as it runs), ``task_runs`` (each time a task is run; a run cut off by a crash is marked
``interrupted`` on resume and the task runs again), ``events``, ``answers`` and ``frames``
(batches of logged frames, written and read by ``microg.study.framelog`` only), ``stations`` (the
stations made from the study, ``microg.study.stations``; a session merged from one names it and
when it was merged, and a station's own study names its station in ``study``).

Every statement goes through ``StudyConnection``, so a database that is locked by another program
(longer than ``BUSY_TIMEOUT_S``), a full disk, a damaged file or a refused change ends in a
``StoreError`` that says what happened and what to do, never in a half-written step. Opening a
study checks its integrity (``check_integrity``: the append-only triggers are there, the stored
protocol matches its SHA-256, finished task runs have their frames and events, participant ids map
one-to-one onto BIDS labels; and the frame batches new since the last check, ``integrity``) and
refuses a damaged study unless the caller accepts it: every verb that writes opens the study so,
and none writes into a damaged one.
"""

from __future__ import annotations

import datetime
import fcntl
import functools
import hashlib
import json
import re
import os
import platform
import sqlite3
import sys
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from microg import __version__

from . import framelog, integrity, ledger
from .assignment import Enrolled, Participant, ParticipantError, assign_group, assign_order, check_participant
from .protocol import Protocol, SessionPlan, canonical_json, protocol_from_resolved
from .schedule import ScheduleError, Sitting, choose_session, due_date

DATABASE = "study.db"
SCHEMA_VERSION = 9
SCHEMA_CHANGES = {
    5: "every committed fact is in the ledger's hash chain",
    6: "sessions keep the station that ran them (microg.study.stations)",
    7: "each answer names its instrument and administration and keeps its response time (issue 22)",
    8: "participants handed to a station can be taken back (station_give_ups, issue 45)",
    9: "a participant has several sessions (a training program's: name, index, date) and a phase trained to a "
       "criterion plans its tasks as they run (task_in_phase, difficulty; issue 43)",
}
"""What each schema version changed, for the message that refuses an older study."""
FINAL_RUN = ("completed", "timeout", "aborted", "skipped")
RUN_STATUSES = FINAL_RUN + ("running", "interrupted")
OUTCOMES = ("completed", "timeout")
"""Final statuses that measured the participant; ``aborted`` and ``skipped`` measured nothing."""
SCHEMA = Path(__file__).with_name("schema.sql")
SQLITE_HEADER = b"SQLite format 3\x00"
BUSY_TIMEOUT_S = 30.0
"""How long a statement waits for a database that another program holds before it gives up."""


class StoreError(RuntimeError):
    """The study database refuses an operation; the message says why and what to do."""


class DamagedStudyError(StoreError):
    """The integrity check on open found problems (``problems``); the message lists them."""

    def __init__(self, message: str, problems: list[str]):
        super().__init__(message)
        self.problems = problems


def database_error(error: sqlite3.Error, path: Path | str) -> StoreError:
    """A StoreError that says what a failed statement on ``path`` means and what to do."""
    code = getattr(error, "sqlite_errorcode", -1) & 0xFF
    if code in (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED):
        return StoreError(f"{path}: another program has held the study database for more than {BUSY_TIMEOUT_S:g} s "
                          f"({error}); this step was not written, everything committed before it is kept. Close the "
                          "program that holds it (a database browser, a backup or sync tool), then run the command "
                          "again (a session carries on with: microg session resume)")
    if code == sqlite3.SQLITE_FULL:
        return StoreError(f"{path}: the disk is full ({error}); this step was not written, everything committed "
                          "before it is kept. Free space on that disk, then run the command again (a session "
                          "carries on with: microg session resume)")
    if code in (sqlite3.SQLITE_NOTADB, sqlite3.SQLITE_CORRUPT):
        return StoreError(f"{path}: the study database is damaged ({error}); nothing more was written. Keep a copy of "
                          f"the study folder as it is and see what is wrong with: microg study check "
                          f"{Path(path).parent}; to carry on, restore the study from a copy made before the damage")
    if code == sqlite3.SQLITE_READONLY:
        return StoreError(f"{path}: the study database cannot be written ({error}); check the permissions of the "
                          "file and its folder")
    if code in (sqlite3.SQLITE_IOERR, sqlite3.SQLITE_CANTOPEN):
        return StoreError(f"{path}: the disk failed to read or write the study database ({error}); check the disk "
                          "(is it full, unplugged, or read-only?), then run the command again")
    if code == sqlite3.SQLITE_CONSTRAINT:
        return StoreError(f"{path}: the study database refused the change: {error}")
    return StoreError(f"{path}: {error}")


class StudyConnection(sqlite3.Connection):
    """A connection to a study database whose failures are ``StoreError``s (see ``database_error``)."""

    path: Path

    def execute(self, *args):
        try:
            return super().execute(*args)
        except sqlite3.Error as error:
            raise database_error(error, self.path) from None

    def executemany(self, *args):
        try:
            return super().executemany(*args)
        except sqlite3.Error as error:
            raise database_error(error, self.path) from None

    def executescript(self, *args):
        try:
            return super().executescript(*args)
        except sqlite3.Error as error:
            raise database_error(error, self.path) from None


@dataclass(frozen=True)
class ParticipantRecord:
    participant: Participant
    number: int
    group: str
    order_row: int | None
    object_order: tuple[str, ...]
    status: str
    seed: int
    """The person's own seed (``derived_seed(study seed, number)``), the same in every session: a simulated
    participant drawn from a population gets their parameters from it; their first session runs with it."""

    @property
    def id(self) -> str:
        return self.participant.id


@dataclass(frozen=True)
class PlannedTask:
    index: int
    phase: str
    """``training`` or the name of one of the protocol's ``phases``."""
    interaction: str
    object: str
    object_code: str
    order_position: int
    """1-based position of the object within its phase (its object order, or the protocol's objects in
    turn for a phase trained to a criterion)."""
    task_in_phase: int = 1
    """1-based place of the task in its phase."""
    difficulty: float | None = None
    """The staircase's value the task ran with (None: its phase has no staircase)."""


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
    name: str
    """The protocol's session it runs (``ONE_SESSION`` for a protocol without ``[[sessions]]``)."""
    index: int
    """1-based: the participant's first session, second..."""
    date: datetime.date
    """The day it ran (on the simulated calendar for a simulated participant: ``date_simulated``)."""
    date_simulated: bool
    due: datetime.date
    """The earliest day it could run (``microg.study.schedule``)."""
    ignored_schedule: bool
    """It ran before its due date (``--ignore-schedule``)."""

    @property
    def sitting(self) -> Sitting:
        return Sitting(self.name, self.date, self.status)


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


def plan_tasks(protocol: Protocol, group: str, object_order: tuple[str, ...],
               session: str | None = None) -> list[PlannedTask]:
    """The tasks planned before a participant of ``group`` starts ``session`` (default: the group's
    first), in order: training (if the session has it), then each phase of tasks with the
    participant's object order. A phase trained to a criterion plans none: it keeps ``max_tasks``
    task indexes for the tasks it adds as they run (``criterion_task``)."""
    return [task for _, _, fixed in _layout(protocol, group, object_order, session) for task in fixed]


def criterion_first_index(protocol: Protocol, group: str, object_order: tuple[str, ...], session: str | None,
                          phase: str) -> int:
    """The first task index a phase trained to a criterion keeps for its tasks."""
    return next(first for name, first, _ in _layout(protocol, group, object_order, session) if name == phase)


def criterion_task(protocol: Protocol, phase: str, first: int, task_in_phase: int,
                   difficulty: float | None) -> PlannedTask:
    """The ``task_in_phase``-th task (1-based) of a phase trained to a criterion whose tasks start at
    index ``first``: the phase's objects in turn (its ``cycle``, else the protocol's objects)."""
    names = protocol.phase(phase).cycle or tuple(o.name for o in protocol.objects)
    position = (task_in_phase - 1) % len(names)
    name = names[position]
    return PlannedTask(first + task_in_phase - 1, phase, protocol.phase(phase).interaction, name,
                       protocol.object(name).code, position + 1, task_in_phase, difficulty)


def _layout(protocol: Protocol, group: str, object_order: tuple[str, ...], session: str | None):
    """Each phase of tasks of the session: (its name, its first task index, its planned tasks)."""
    index = 0
    for phase in protocol.phases_for(group, session):
        if phase.name == "training":
            names, interaction = list(protocol.training.object_names), protocol.training.interaction
        elif (task_phase := protocol.phase(phase.name)) is not None:
            if task_phase.until is not None:
                yield phase.name, index, []
                index += task_phase.max_tasks
                continue
            names, interaction = list(object_order), task_phase.interaction
        else:
            continue
        fixed = [PlannedTask(index + i, phase.name, interaction, name, protocol.object(name).code, i + 1, i + 1)
                 for i, name in enumerate(names)]
        yield phase.name, index, fixed
        index += len(fixed)


def writable(path: Path) -> bool:
    """Whether ``path`` (a file or folder) may be written: this process may (its permissions, a
    read-only mount) and someone may (a copy marked read-only, ``chmod a-w``, is read-only to root
    as well, who could otherwise write anything)."""
    try:
        return os.access(path, os.W_OK) and bool(path.stat().st_mode & 0o222)
    except OSError:
        return False


def nearest_folder(path: Path) -> Path:
    """The folder that holds ``path`` or would hold it once made: its nearest existing ancestor."""
    return next(p for p in (path.absolute().parent, *path.absolute().parents) if p.exists())


def archived(path: Path) -> bool:
    """Whether the study database ``path`` is read-only where it lies (a copied archive, a published
    data set, a read-only mount): it or its folder cannot be written."""
    return not (writable(path.parent) and writable(path))


def _wal_holds_commits(path: Path) -> bool:
    wal = path.with_name(DATABASE + "-wal")
    return wal.exists() and wal.stat().st_size > 0


def _connect(path: Path, readonly: bool = False) -> StudyConnection:
    """A connection to ``path``: WAL, durable commits and foreign keys; read-only ones never write
    into the file (and may be shared by the view's threads). An archived study is opened immutable
    (no shared-memory file, no locks: nothing can change it), unless its write-ahead log holds
    commits not yet in the database file, which only WAL's shared memory reads."""
    try:
        if readonly:
            immutable = archived(path) and not _wal_holds_commits(path)
            connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro{'&immutable=1' if immutable else ''}",
                                         uri=True, isolation_level=None, timeout=BUSY_TIMEOUT_S,
                                         check_same_thread=False, factory=StudyConnection)
        else:
            connection = sqlite3.connect(path, isolation_level=None, timeout=BUSY_TIMEOUT_S, factory=StudyConnection)
    except sqlite3.Error as error:
        raise database_error(error, path) from None
    connection.path = path
    if not readonly:
        connection.execute("PRAGMA page_size = 16384")
        connection.execute("PRAGMA journal_mode = WAL")
        connection.execute("PRAGMA synchronous = FULL")
    connection.execute("PRAGMA foreign_keys = ON")
    connection.row_factory = sqlite3.Row
    return connection


class Store:
    """An open study database. Create with ``create_study``, open with ``open_study``."""

    def __init__(self, study_dir: Path, connection: StudyConnection, problems: list[str] = (), *,
                 damaged_batches: list[str] = (), checked: integrity.Record | None = None):
        self.dir = study_dir
        self.db = connection
        self.problems = list(problems)
        """What the integrity check on open found (empty for a sound study)."""
        self.damaged_batches = list(damaged_batches)
        """Those of ``problems`` that are frame batches failing their checksums: a study opened read
        only is read with them (``open_study``), and only a read of those batches fails."""
        self._checked = checked
        """The check on open of a study opened for writing, recorded again with the file as it is left (``close``)."""
        self._locks: dict[int, int] = {}
        row = self.db.execute("SELECT name, seed, station FROM study").fetchone()
        if row is None:
            raise StoreError(f"{study_dir / DATABASE}: the study row is missing; see: microg study check {study_dir}")
        self.name: str = row["name"]
        self.seed: int = row["seed"]
        self.station: str | None = row["station"]
        """The station's name in a station's study (``microg.study.stations``), else None."""

    @functools.cached_property
    def protocol(self) -> Protocol:
        """The study's protocol as stored. One changed after the study was made is refused as such,
        naming the hash recorded and the hash found, before anything of its content is read (its
        values could send the researcher to mend a protocol file that is fine)."""
        where = self.dir / DATABASE
        row = self.db.execute("SELECT p.id, p.resolved FROM study s JOIN protocols p ON p.id = s.protocol_id").fetchone()
        if row is None:
            raise StoreError(f"{where}: the study's protocol is missing; see: microg study check {self.dir}")
        changed = protocol_change(self.db, row["id"])
        if changed is not None:
            raise StoreError(f"{where}: {changed}. Nothing was changed; the protocol file the study was made from is "
                             f"not at fault. See: microg study check {self.dir}; restore the study folder from a copy "
                             "made before the change to carry on")
        return protocol_from_resolved(json.loads(row["resolved"]), str(where))

    # ------------------------------------------------------------ plumbing

    @contextmanager
    def transaction(self, head: bool = True) -> Iterator[sqlite3.Connection]:
        """One atomic, durable write: everything inside commits together or not at all (a failed
        commit, e.g. on a full disk, rolls back too). The facts written inside seal their ledger
        entries inside; after the commit the ledger's head goes into the study folder, unless not
        ``head``: a frame batch or an event within a task run, whose entries the run's end covers
        (writing a file costs 1-2 ms here, as much as the batch's whole commit)."""
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield self.db
            self.db.execute("COMMIT")
        except BaseException:
            if self.db.in_transaction:
                try:
                    self.db.execute("ROLLBACK")
                except StoreError:
                    pass  # the database rolls the transaction back itself when the connection closes
            raise
        if head:
            ledger.write_head(self.dir, self.db)

    def commit_for(self, simulated: bool) -> None:
        """Set how durable the coming commits are, for a live or a simulated session. A live
        session's frames exist once: each commit is flushed to the disk before the session goes on
        (``synchronous = FULL``). A simulated session's frames come again from its seed, so it skips
        the flush (``synchronous = NORMAL``, in WAL mode still safe against a crash of the program);
        the flush is about 6 ms a commit, and the sessions of a study share one writer's lock."""
        self.db.execute(f"PRAGMA synchronous = {'NORMAL' if simulated else 'FULL'}")

    def close(self) -> None:
        """Close the database; a study opened for writing records its check again with the file as
        this process leaves it (``microg.study.integrity``), unless a later check found damage."""
        for fd in self._locks.values():
            os.close(fd)
        self._locks.clear()
        self.db.close()
        checked, self._checked = self._checked, None
        if checked is not None and checked.sound:
            last = integrity.read(self.dir)
            if last is None or last.sound:
                integrity.write(self.dir, replace(checked, file=integrity.file_state(self.dir / DATABASE)))

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def lock_session(self, session_id: int) -> None:
        """Hold the session for this process; the operating system frees it when the process ends."""
        if session_id in self._locks:
            return
        folder = self.dir / "locks"
        folder.mkdir(exist_ok=True)
        fd = os.open(folder / f"session-{session_id}.lock", os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise StoreError(f"session {session_id} is being run by another process right now") from None
        self._locks[session_id] = fd

    def unlock_session(self, session_id: int) -> None:
        fd = self._locks.pop(session_id, None)
        if fd is not None:
            os.close(fd)

    # ------------------------------------------------------------ participants

    def _enrolled(self) -> list[Enrolled]:
        rows = self.db.execute("SELECT group_code, gender, order_row FROM participants WHERE status = 'active'")
        return [Enrolled(r["group_code"], r["gender"], r["order_row"]) for r in rows]

    def add_participant(self, participant: Participant, like: ParticipantRecord | None = None) -> ParticipantRecord:
        """Enrol a participant: validate, assign a group and an object order (``like``'s, for a
        re-simulated study that must keep the original's), commit."""
        check_participant(participant, self.protocol)
        if self.station is not None:
            raise ParticipantError(f"{self.dir} is station {self.station}'s study: participants are enrolled in the "
                                   "central study, which assigns their group and object order across the stations; "
                                   f"enrol {participant.id} there and make a station for them (microg study station)")
        with self.transaction() as db:
            if db.execute("SELECT 1 FROM participants WHERE id = ?", (participant.id,)).fetchone():
                raise ParticipantError(f"participant {participant.id} is already in study {self.name!r}; "
                                       "ids are never reused")
            twin = db.execute("SELECT id FROM participants WHERE lower(id) = lower(?)", (participant.id,)).fetchone()
            if twin is not None:
                raise ParticipantError(f"participant id = {participant.id!r}: collides with participant {twin[0]!r} "
                                       f"of study {self.name!r}; ids that differ only in case name the same folder "
                                       "on many disks and in the Motion-BIDS export: choose another id")
            number = db.execute("SELECT COALESCE(MAX(number), 0) + 1 FROM participants").fetchone()[0]
            enrolled = self._enrolled()
            if like is not None:
                group, row, order = like.group, like.order_row, list(like.object_order)
            else:
                group = assign_group(self.protocol, enrolled, participant.gender,
                                     np.random.default_rng([self.seed, number]))
                row, order = assign_order(self.protocol, group, enrolled=enrolled, participant_id=participant.id,
                                          seed=self.seed)
            p = participant
            db.execute("INSERT INTO participants (id, number, group_code, gender, age, handedness, mr_experience, "
                       "order_row, object_order, added_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (p.id, number, group, p.gender, p.age, p.handedness, int(p.mr_experience), row,
                        json.dumps(order), utc_now()))
            ledger.seal(db, "participant", p.id)
        return self.participant(participant.id)

    def withdraw(self, participant_id: str, reason: str) -> None:
        """Withdraw a participant: their data stays, their slot and order row are free again, and an
        unfinished session of theirs ends as aborted. A session that another process is running is
        left alone: stop it first."""
        record = self.participant(participant_id)
        if record.status == "withdrawn":
            raise ParticipantError(f"participant {participant_id} is already withdrawn")
        session = self.session_of(participant_id)
        running = session is not None and session.status == "running"
        if running:
            held = session.id in self._locks
            try:
                self.lock_session(session.id)
            except StoreError:
                raise StoreError(f"participant {participant_id}: session {session.id} is running right now (another "
                                 "process holds it); stop that session first (Ctrl-C pauses it), then withdraw") \
                    from None
        try:
            with self.transaction() as db:
                db.execute("UPDATE participants SET status = 'withdrawn', withdrawn_at = ?, withdraw_reason = ? "
                           "WHERE id = ?", (utc_now(), reason, participant_id))
                ledger.seal(db, "withdrawal", participant_id)
                if running:
                    t = self.last_time(session.id)
                    for run_id in self._open_runs(session.id):
                        self._end_run(db, run_id, "interrupted", t, reason="the process running it had ended "
                                      "during the task (found when the participant was withdrawn)")
                    self._end_session(db, session.id, status="aborted", t=t, reason=f"participant withdrawn: {reason}")
        finally:
            if running and not held:
                self.unlock_session(session.id)

    def _participant(self, row: sqlite3.Row) -> ParticipantRecord:
        return ParticipantRecord(
            Participant(row["id"], row["gender"], row["age"], row["handedness"], bool(row["mr_experience"])),
            number=row["number"], group=row["group_code"], order_row=row["order_row"],
            object_order=tuple(json.loads(row["object_order"])), status=row["status"],
            seed=derived_seed(self.seed, row["number"]))

    def participant(self, participant_id: str) -> ParticipantRecord:
        row = self.db.execute("SELECT * FROM participants WHERE id = ?", (participant_id,)).fetchone()
        if row is None:
            if self.station is not None:
                raise ParticipantError(f"participant {participant_id!r} is not one of station {self.station}'s "
                                       f"participants ({self.dir}: see microg participant list); the central study "
                                       "gives a station its participants (microg study station)")
            raise ParticipantError(f"no participant {participant_id!r} in study {self.name!r} "
                                   "(add one with: microg participant add)")
        return self._participant(row)

    def participants(self) -> list[ParticipantRecord]:
        return [self._participant(r) for r in self.db.execute("SELECT * FROM participants ORDER BY number")]

    def station_holding(self, participant_id: str) -> tuple[str, str] | None:
        """(name, made_at) of the station the central study handed the participant to and did not take
        them back from (``microg.study.stations``); None in a station's own study, which runs them."""
        if self.station is not None:
            return None
        row = self.db.execute("""
            SELECT s.name, s.made_at FROM stations s, json_each(s.participants) p WHERE p.value = ?
              AND NOT EXISTS (SELECT 1 FROM station_give_ups g WHERE g.station = s.name AND g.participant = p.value)
            ORDER BY s.made_at DESC LIMIT 1""", (participant_id,)).fetchone()
        return None if row is None else (row[0], row[1])

    def check_runs_here(self, participant_id: str) -> None:
        """Refuse to run a participant handed to a station (``station_holding``): a session of theirs
        here would clash with the station's at the merge, after the person's time was spent."""
        held = self.station_holding(participant_id)
        if held is not None:
            name, made_at = held
            raise StoreError(f"participant {participant_id} was handed to station {name} on {made_at} (microg study "
                             f"station): their session runs there and comes back with: microg study merge {self.dir} "
                             f"STATION_DIR. To run them here instead, take them back from the station first: microg "
                             f"study station {self.dir} --name {name} --give-up --participant {participant_id}")

    # ------------------------------------------------------------ sessions

    def create_session(self, participant_id: str, *, input_spec: str, simulated: bool, clock: str,
                       interaction: str | None = None, session: str | None = None, ignore_schedule: bool = False,
                       today: datetime.date | None = None) -> SessionRecord:
        """The participant's next session (or ``session``, which must be the next), with its planned tasks;
        ``interaction``: every task runs this interaction model instead of its phase's (a re-simulation).

        A session runs on ``today`` (default: the local date) and no earlier than its due date
        (``microg.study.schedule``) unless ``ignore_schedule``, which the session records; a
        simulated participant's session runs on its due date on the simulated calendar."""
        record = self.participant(participant_id)
        plan, date, due = self.schedule_session(participant_id, simulated=simulated, session=session,
                                            ignore_schedule=ignore_schedule, today=today)
        index = len(self.sessions_of(participant_id)) + 1
        protocol_id = self.db.execute("SELECT protocol_id FROM study").fetchone()[0]
        seed = record.seed if index == 1 else derived_seed(self.seed, record.number, index)
        with self.transaction() as db:
            cursor = db.execute(
                "INSERT INTO sessions (participant_id, name, session_index, date, date_simulated, due, "
                "ignored_schedule, protocol_id, seed, input, simulated, clock, object_order, microg_version, python, "
                "platform, status, created_at, station) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'running', ?, ?)",
                (participant_id, plan.name, index, date.isoformat(), int(simulated), due.isoformat(),
                 int(date < due), protocol_id, seed, input_spec, int(simulated), clock,
                 json.dumps(record.object_order), __version__, sys.version.split()[0], platform.platform(), utc_now(),
                 self.station))
            session_id = cursor.lastrowid
            ledger.seal(db, "session", session_id)
            if date < due:
                self._insert_events(db, session_id, None, [Event(0.0, "schedule_ignored", {
                    "session": plan.name, "due": due.isoformat(), "date": date.isoformat()})])
            for t in plan_tasks(self.protocol, record.group, record.object_order, plan.name):
                self._insert_task(db, session_id, replace(t, interaction=interaction or t.interaction))
        return self.session(session_id)

    def schedule_session(self, participant_id: str, *, simulated: bool, session: str | None = None,
                         ignore_schedule: bool = False, today: datetime.date | None = None
                         ) -> tuple[SessionPlan, datetime.date, datetime.date]:
        """The session ``create_session`` would start for the participant (``session``, or their next),
        the day it runs and the day it is due; refused (``StoreError``) for a withdrawn participant, one
        handed to a station, a session out of order or run before, or one not due yet (unless
        ``ignore_schedule``), naming what to run instead."""
        record = self.participant(participant_id)
        if record.status != "active":
            raise StoreError(f"participant {participant_id} is withdrawn; a withdrawn participant runs no session")
        sittings = [s.sitting for s in self.sessions_of(participant_id)]
        try:
            plan = choose_session(self.protocol, participant_id, record.group, sittings, session)
        except ScheduleError as error:
            raise StoreError(str(error)) from None
        self.check_runs_here(participant_id)
        first_day = datetime.date.fromisoformat(self.created_at[:10]) if simulated else \
            (today or datetime.date.today())
        due = due_date(plan, sittings, first_day)
        date = due if simulated else (today or datetime.date.today())
        if date < due and not ignore_schedule:
            raise StoreError(f"participant {participant_id}'s session {plan.name!r} is due on {due.isoformat()} "
                             f"({plan.after_days} day(s) after their session {sittings[-1].name!r} on "
                             f"{sittings[-1].date.isoformat()}); run it then, or now with --ignore-schedule "
                             "(the session records that it did)")
        return plan, date, due

    @staticmethod
    def _insert_task(db: sqlite3.Connection, session_id: int, task: PlannedTask) -> None:
        db.execute("INSERT INTO tasks VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", (
            session_id, task.index, task.phase, task.interaction, task.object, task.object_code, task.order_position,
            task.task_in_phase, task.difficulty))
        ledger.seal(db, "task", session_id, task.index)

    def add_task(self, session_id: int, task: PlannedTask) -> None:
        """Plan one more task of a running session (a phase trained to a criterion adds each as it runs)."""
        with self.transaction() as db:
            self._insert_task(db, session_id, task)

    @functools.cached_property
    def created_at(self) -> str:
        """When the study was made (UTC, ISO 8601): day 0 of the simulated calendar."""
        return self.db.execute("SELECT created_at FROM study").fetchone()[0]

    @staticmethod
    def _session(row: sqlite3.Row) -> SessionRecord:
        return SessionRecord(row["id"], row["participant_id"], row["seed"], row["input"], bool(row["simulated"]),
                             row["clock"], tuple(json.loads(row["object_order"])), row["status"], row["name"],
                             row["session_index"], datetime.date.fromisoformat(row["date"]),
                             bool(row["date_simulated"]), datetime.date.fromisoformat(row["due"]),
                             bool(row["ignored_schedule"]))

    def session(self, session_id: int) -> SessionRecord:
        row = self.db.execute("SELECT * FROM sessions WHERE id = ?", (session_id,)).fetchone()
        if row is None:
            raise StoreError(f"no session {session_id} in study {self.name!r}")
        return self._session(row)

    def sessions_of(self, participant_id: str) -> list[SessionRecord]:
        """The participant's sessions, first to last."""
        rows = self.db.execute("SELECT * FROM sessions WHERE participant_id = ? ORDER BY session_index",
                               (participant_id,))
        return [self._session(r) for r in rows]

    def session_of(self, participant_id: str, name: str | None = None) -> SessionRecord | None:
        """The participant's session called ``name``, or their latest (None: they have none)."""
        sessions = [s for s in self.sessions_of(participant_id) if name is None or s.name == name]
        return sessions[-1] if sessions else None

    def tasks(self, session_id: int) -> list[PlannedTask]:
        rows = self.db.execute("SELECT * FROM tasks WHERE session_id = ? ORDER BY task_index", (session_id,))
        return [PlannedTask(r["task_index"], r["phase"], r["interaction"], r["object"], r["object_code"],
                            r["order_position"], r["task_in_phase"], r["difficulty"]) for r in rows]

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

    def answers(self, session_id: int) -> dict[tuple[str, str, str, str], float | int | str]:
        """The session's answers in the order given: (instrument, administration, interaction, item) -> value."""
        rows = self.db.execute("SELECT instrument, administration, interaction, item, value FROM answers "
                               "WHERE session_id = ? ORDER BY rowid", (session_id,))
        return {(r["instrument"], r["administration"], r["interaction"], r["item"]): r["value"] for r in rows}

    def last_time(self, session_id: int) -> float:
        """The latest session-clock time logged, so a resumed clock carries on from there."""
        row = self.db.execute("SELECT MAX(t) FROM events WHERE session_id = ?", (session_id,)).fetchone()
        return float(row[0] or 0.0)

    # ------------------------------------------------------------ logging while a session runs

    @staticmethod
    def _insert_events(db: sqlite3.Connection, session_id: int, run_id: int | None, events: list[Event]) -> None:
        wall = utc_now()
        for e in events:
            event_id = db.execute("INSERT INTO events (session_id, run_id, t, wall, kind, data) "
                                  "VALUES (?, ?, ?, ?, ?, ?)",
                                  (session_id, run_id, e.t, wall, e.kind, canonical_json(e.data))).lastrowid
            ledger.seal(db, "event", event_id)

    def log(self, session_id: int, events: list[Event], run_id: int | None = None) -> None:
        """Commit events now."""
        if events:
            with self.transaction(head=run_id is None) as db:
                self._insert_events(db, session_id, run_id, events)

    def begin_run(self, session_id: int, *, task: PlannedTask, source: str, seed: int, t: float) -> int:
        """Open a run of ``task`` (the next run number) and log its start."""
        with self.transaction() as db:
            number = db.execute("SELECT COALESCE(MAX(run), 0) + 1 FROM task_runs WHERE session_id = ? AND task_index = ?",
                                (session_id, task.index)).fetchone()[0]
            run_id = db.execute(
                "INSERT INTO task_runs (session_id, task_index, run, status, source, seed, started_at, started_wall) "
                "VALUES (?, ?, ?, 'running', ?, ?, ?, ?)",
                (session_id, task.index, number, source, seed, t, utc_now())).lastrowid
            ledger.seal(db, "run", run_id)
            self._insert_events(db, session_id, run_id, [Event(t, "task_start", {
                "task": task.index, "run": number, "phase": task.phase, "interaction": task.interaction,
                "object": task.object})])
        return run_id

    def add_frames(self, run_id: int, first: int, frames: np.ndarray) -> None:
        """Commit a batch of logged frames (``framelog.FRAME`` records), the run's frames ``first`` on."""
        if len(frames):
            with self.transaction(head=False) as db:
                self._insert_frames(db, run_id, first, frames)

    @staticmethod
    def _insert_frames(db: sqlite3.Connection, run_id: int, first: int, frames: np.ndarray) -> None:
        if framelog.insert(db, run_id, first, frames):
            ledger.seal(db, "frames", run_id, first)

    def end_run(self, run_id: int, status: str, t: float, *, time_s: float | None = None,
                attempts: int | None = None, reason: str | None = None, frames: tuple[int, np.ndarray] = (0, ()),
                events: list[Event] = ()) -> list[Event]:
        """Close a run: its last frames, its result and its end event in one transaction; returns the
        events it logged (``events``, then the end event)."""
        with self.transaction() as db:
            return self._end_run(db, run_id, status, t, time_s=time_s, attempts=attempts, reason=reason,
                                 frames=frames, events=events)

    def _end_run(self, db: sqlite3.Connection, run_id: int, status: str, t: float, *, time_s: float | None = None,
                 attempts: int | None = None, reason: str | None = None, frames: tuple[int, np.ndarray] = (0, ()),
                 events: list[Event] = ()) -> list[Event]:
        if status not in RUN_STATUSES or status == "running":
            raise ValueError(f"end_run(status = {status!r}): must be one of {RUN_STATUSES[:-2] + ('interrupted',)}")
        session_id, = db.execute("SELECT session_id FROM task_runs WHERE id = ?", (run_id,)).fetchone()
        self._insert_frames(db, run_id, *frames)
        count = framelog.count(db, run_id)
        db.execute("UPDATE task_runs SET status = ?, reason = ?, ended_at = ?, time_s = ?, attempts = ?, "
                   "frames = ?, ended_wall = ? WHERE id = ?",
                   (status, reason, t, time_s, attempts, count, utc_now(), run_id))
        ledger.seal(db, "result", run_id)
        logged = list(events) + [Event(t, "task_end", {
            "status": status, "time_s": time_s, "attempts": attempts, "reason": reason})]
        self._insert_events(db, session_id, run_id, logged)
        return logged

    def _open_runs(self, session_id: int) -> list[int]:
        return [r.id for r in self.runs(session_id) if r.status == "running"]

    def interrupt_open_runs(self, session_id: int, t: float) -> list[int]:
        """On resume: mark runs left ``running`` by a process that ended as ``interrupted``; their
        frames stay. The caller holds the session's lock, so no process is running them."""
        open_runs = self._open_runs(session_id)
        for run_id in open_runs:
            self.end_run(run_id, "interrupted", t, reason="the process running it ended during the task "
                         "(found on resume)")
        return open_runs

    def save_answer(self, session_id: int, *, key: tuple[str, str, str, str], value: float | int | str, source: str,
                    t: float, response_time_s: float | None = None) -> None:
        """Commit one answer, ``key`` = (instrument, administration, interaction, item), with its event."""
        instrument, administration, interaction, item = key
        with self.transaction() as db:
            db.execute("INSERT INTO answers (session_id, instrument, administration, interaction, item, value, source, "
                       "response_time_s, t, wall) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (session_id, *key, value, source, response_time_s, t, utc_now()))
            ledger.seal(db, "answer", session_id, *key)
            self._insert_events(db, session_id, None, [Event(t, "answer", {
                "instrument": instrument, "administration": administration, "interaction": interaction, "item": item,
                "value": value, "source": source, "response_time_s": response_time_s})])

    def _end_session(self, db: sqlite3.Connection, session_id: int, *, status: str, t: float, reason: str | None,
                     counts: dict[str, int] | None = None) -> None:
        """The end event first: nothing is logged for a session once it has ended (a trigger sees to it)."""
        data = {"status": status, "reason": reason} | ({"tasks": counts} if counts is not None else {})
        self._insert_events(db, session_id, None, [Event(t, "session_end", data)])
        db.execute("UPDATE sessions SET status = ?, ended_at = ? WHERE id = ?", (status, utc_now(), session_id))
        ledger.seal(db, "session_end", session_id)

    def task_counts(self, session_id: int) -> dict[str, int]:
        """How the session's planned tasks stand, by their last run: completed, timeout, aborted,
        skipped, interrupted, running, and not_run (no run yet)."""
        counts = dict.fromkeys(RUN_STATUSES + ("not_run",), 0)
        rows = self.db.execute("""
            SELECT (SELECT r.status FROM task_runs r WHERE r.session_id = t.session_id AND r.task_index = t.task_index
                    ORDER BY r.run DESC LIMIT 1) AS status
            FROM tasks t WHERE t.session_id = ?""", (session_id,)).fetchall()
        for row in rows:
            counts[row["status"] or "not_run"] += 1
        return counts

    def finish_session(self, session_id: int, t: float) -> str:
        """End a session whose timeline has run through, with an honest status: ``completed`` when
        every task measured the participant (completed or timed out), else ``incomplete`` (a task
        was aborted or skipped); the end event carries the counts. Returns the status."""
        counts = self.task_counts(session_id)
        unmeasured = {k: counts[k] for k in ("aborted", "skipped", "interrupted", "running", "not_run") if counts[k]}
        status = "incomplete" if unmeasured else "completed"
        reason = None if not unmeasured else "no measure from " + ", ".join(
            f"{n} task(s) {k.replace('_', ' ')}" for k, n in unmeasured.items())
        with self.transaction() as db:
            self._end_session(db, session_id, status=status, t=t, reason=reason,
                              counts={k: n for k, n in counts.items() if n})
        return status


def describe_counts(counts: dict[str, int]) -> str:
    """``6 tasks: 4 completed, 1 timed out, 1 aborted`` (only the statuses that occur)."""
    words = {"timeout": "timed out", "not_run": "not run yet"}
    parts = [f"{n} {words.get(k, k)}" for k, n in counts.items() if n]
    return f"{sum(counts.values())} tasks: " + ", ".join(parts)


# ---------------------------------------------------------------- creating and opening


def create_study(study_dir: str | Path, protocol: Protocol, seed: int, station: str | None = None) -> Store:
    """A new study database in ``study_dir`` (created; it must not hold a study already). A study
    that cannot be created whole (a full disk) leaves no database behind. ``station``: the study is
    that station's (``microg.study.stations.make_station`` fills it)."""
    study_dir = Path(study_dir)
    path = study_dir / DATABASE
    if path.exists():
        raise StoreError(f"{path} exists: {study_dir} already holds a study; a study is never overwritten")
    if not isinstance(seed, int) or seed < 0:
        raise StoreError(f"seed = {seed!r}: must be a whole number >= 0")
    if not writable(study_dir if study_dir.is_dir() else nearest_folder(study_dir)):
        raise StoreError(f"{study_dir}: cannot create a study there: the folder is read-only")
    try:
        study_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise StoreError(f"{study_dir}: cannot create the study folder: {error.strerror or error}") from None
    main_text = protocol.resolved["sources"][-1]["text"] if protocol.resolved.get("sources") else ""
    connection = None
    try:
        connection = _connect(path)
        connection.executescript("BEGIN IMMEDIATE;" + SCHEMA.read_text())  # committed below with the study row
        now = utc_now()
        protocol_id = connection.execute(
            "INSERT INTO protocols (name, sha256, resolved, source_text, added_at) VALUES (?, ?, ?, ?, ?)",
            (protocol.name, protocol.sha256, canonical_json(protocol.resolved), main_text, now)).lastrowid
        connection.execute("INSERT INTO study VALUES (1, ?, ?, ?, ?, ?, ?, ?)",
                           (protocol.name, seed, protocol_id, now, __version__, SCHEMA_VERSION, station))
        ledger.seal(connection, "protocol", protocol_id)
        ledger.seal(connection, "study", 1)
        connection.execute("COMMIT")
    except BaseException:
        if connection is not None:
            connection.close()
        for leftover in (path, path.with_name(DATABASE + "-wal"), path.with_name(DATABASE + "-shm")):
            leftover.unlink(missing_ok=True)
        raise
    ledger.write_head(study_dir, connection)
    return Store(study_dir, connection)


def open_study(study_dir: str | Path, *, readonly: bool = False, accept_damaged: bool = False) -> Store:
    """The study in ``study_dir``, after the check on open: ``check_integrity`` and the frame
    batches new since the last check (``microg.study.integrity``; every batch and SQLite's quick
    check when the file changed outside microg), whose result is recorded beside the study.
    ``Store.problems`` lists what is wrong. A damaged study raises ``DamagedStudyError`` unless
    ``accept_damaged``: for writing, whatever the damage (every verb that writes opens the study
    this way, so none writes into a damaged one); ``readonly`` (never write into the database:
    status, check, export, the view), a study whose only damage is frame batches failing their
    checksums is opened, with them in ``Store.damaged_batches`` for the reader to say so."""
    study_dir = Path(study_dir)
    path = study_dir / DATABASE
    if not path.exists():
        raise StoreError(f"no study in {study_dir} (no {DATABASE}); create one with: microg study init {study_dir}")
    try:
        with open(path, "rb") as stream:
            head = stream.read(len(SQLITE_HEADER))
    except OSError as error:
        raise StoreError(f"{path}: cannot read the study database: {error.strerror or error}") from None
    if not head:
        raise StoreError(f"{path}: the file is empty, not a study database (was it cut off while the study was "
                         f"created?); move it away and create the study again with: microg study init")
    if head != SQLITE_HEADER:
        raise StoreError(f"{path}: not a SQLite database (it starts with {head!r}); a study's {DATABASE} is "
                         "written by microg study init")
    if not readonly and archived(path):
        raise StoreError(f"{study_dir} is read-only (it or its {DATABASE} cannot be written: a copied archive, a "
                         "published data set, a read-only mount), and this command writes into the study. Copy the "
                         "study folder to a writable place to carry on there; reading works as it is (microg study "
                         "status, study check, export, report, view)")
    state = integrity.file_state(path)  # before connecting: a connection makes the write-ahead log
    connection = _connect(path, readonly)
    try:
        try:
            is_study = connection.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'study'"
                                          ).fetchone()
        except StoreError as error:
            if readonly and archived(path) and _wal_holds_commits(path):
                raise StoreError(f"{path}: the study is read-only and its {DATABASE}-wal holds commits not yet in "
                                 f"{DATABASE} (the copy was made while a session was writing); SQLite reads them "
                                 f"only through a {DATABASE}-shm file beside it, which cannot be made here. Copy "
                                 f"the study folder to a writable place and read it there ({error})") from None
            raise
        if not is_study:
            raise StoreError(f"{path}: a SQLite database but not a microg study (it has no study table)")
        row = connection.execute("SELECT schema_version FROM study").fetchone()
        if row is None or row[0] != SCHEMA_VERSION:
            since = [f"version {v}: {what}" for v, what in SCHEMA_CHANGES.items()
                     if row is not None and isinstance(row[0], int) and row[0] < v]
            raise StoreError(f"{path}: schema version {None if row is None else row[0]}, this microg "
                             f"{__version__} reads {SCHEMA_VERSION}" + (f" (since then, {'; '.join(since)}); read "
                             "the study with the microg that wrote it" if since else ""))
        record = integrity.read(study_dir)
        keep = not archived(path)  # an archive keeps no record: nothing may be written beside it
        try:
            problems = check_integrity(connection, study_dir)
            try:
                frames = integrity.verify_frames(connection, integrity.vouched(connection, record, state))
            except sqlite3.Error as error:
                raise database_error(error, path) from None
        except StoreError as error:  # SQLite cannot read the file
            if keep:
                integrity.write(study_dir, integrity.Record(utc_now(), "open", False, (str(error),)))
            raise
        found = problems + frames.pages + frames.batches
        checked = integrity.Record(utc_now(), "open", not found, tuple(found),
                                   None if frames.batches or frames.verified is None else str(frames.verified), state)
        if keep:
            integrity.write(study_dir, checked)
        refused = problems + frames.pages if readonly else found
        if refused and not accept_damaged:
            raise DamagedStudyError(
                f"{path}: the study is damaged:\n" + "\n".join(f"  - {p}" for p in found)
                + f"\nNothing was changed. See the full check with: microg study check {study_dir}. Keep the study "
                  "folder as it is; to carry on, restore it from a copy made before the damage (check the copy "
                  "with microg study check first); an export that knows it is damaged: microg export "
                  "--accept-damaged", found)
        return Store(study_dir, connection, found, damaged_batches=frames.batches,
                     checked=None if readonly else checked)
    except BaseException:
        connection.close()
        raise


# ---------------------------------------------------------------- integrity


def _schema_triggers() -> dict[str, str]:
    """Trigger name -> its CREATE statement, as ``schema.sql`` writes it."""
    text = SCHEMA.read_text()
    return {m.group(1): m.group(0) for m in re.finditer(r"CREATE TRIGGER (\w+)\b.*?\bEND", text, re.DOTALL)}


def _squeeze(sql: str) -> str:
    return " ".join(sql.split())


def check_integrity(db: sqlite3.Connection, study_dir: Path | None = None, *, full: bool = False,
                    heads: Sequence[tuple[ledger.Head, str]] = (), snapshot: bool = True) -> list[str]:
    """What is wrong with a study database, each naming the table, row and value (empty: sound).

    Checked on every open: the ledger (``ledger.check``: every fact's digest, every link, and the
    head in ``<study_dir>/ledger-head.json`` and in ``heads``); the append-only triggers are all
    there as ``schema.sql`` writes them; each stored protocol matches its SHA-256; every finished
    task run has its start and end events, its end event says its result, and it has exactly the
    frames it counted (a completed run at least one, with its time); every ended session has its
    end event; participant ids are ASCII letters and digits, one per BIDS label. ``full`` adds
    SQLite's own integrity check and every frame batch against its checksum, then decoded
    (``microg study check``). ``snapshot``: read in a transaction of its own; without it, in the
    caller's (a merge checks what it wrote before it commits).
    """
    problems = []
    heads = list(heads)
    try:  # the head is read before the snapshot, so the snapshot holds every entry the head names
        head = ledger.read_head(study_dir) if study_dir is not None else None
    except ValueError as error:
        problems.append(str(error))
    else:
        heads += [] if head is None else [(head, str(study_dir / ledger.HEAD_FILE))]
    if snapshot:
        db.execute("BEGIN")  # one snapshot: a session writing meanwhile does not tear the picture
    try:
        try:
            problems += ledger.check(db, heads)
        except sqlite3.Error as error:
            raise database_error(error, db.path) from None
        present = {r[0]: r[1] for r in db.execute("SELECT name, sql FROM sqlite_master WHERE type = 'trigger'")}
        for name, sql in _schema_triggers().items():
            if name not in present:
                problems.append(f"trigger {name} is missing: the log is no longer protected against changes")
            elif _squeeze(present[name]) != _squeeze(sql):
                problems.append(f"trigger {name} differs from the one microg wrote: the log may no longer be "
                                "protected against changes")
        for (protocol_id,) in db.execute("SELECT id FROM protocols").fetchall():
            changed = protocol_change(db, protocol_id, against_ledger=False)  # the ledger's check names that
            if changed is not None:
                problems.append(changed)
        for row in db.execute("""
                SELECT r.id, r.session_id, r.task_index, r.run, r.status, r.reason, r.frames, r.time_s, r.attempts,
                       (SELECT e.data FROM events e WHERE e.run_id = r.id AND e.kind = 'task_end') AS ended,
                       (SELECT COALESCE(SUM(f.count), 0) FROM frames f WHERE f.run_id = r.id) AS stored,
                       (SELECT COALESCE(MAX(f.first + f.count), 0) FROM frames f WHERE f.run_id = r.id) AS span,
                       (SELECT COUNT(*) FROM events e WHERE e.run_id = r.id AND e.kind = 'task_start') AS starts,
                       (SELECT COUNT(*) FROM events e WHERE e.run_id = r.id AND e.kind = 'task_end') AS ends
                FROM task_runs r WHERE r.status != 'running' ORDER BY r.id"""):
            run = (f"task_runs row {row['id']} (session {row['session_id']}, task {row['task_index']}, "
                   f"run {row['run']}, {row['status']})")
            if row["starts"] != 1 or row["ends"] != 1:
                problems.append(f"{run}: has {row['starts']} task_start and {row['ends']} task_end events, not one of "
                                "each: it was not written by a session")
            else:
                problems += _result_against_end_event(run, row)
            if row["stored"] != row["frames"] or row["span"] != row["stored"]:
                problems.append(f"{run}: frames = {row['frames']}, but {row['stored']} frames are stored "
                                f"(spanning {row['span']}): frames are missing")
            if row["status"] == "completed" and (not row["stored"] or row["time_s"] is None):
                problems.append(f"{run}: completed with {row['stored']} frames and time_s = {row['time_s']}: a "
                                "completed task has frames and a time")
        for row in db.execute("""
                SELECT s.id, s.status, (SELECT COUNT(*) FROM events e WHERE e.session_id = s.id
                                          AND e.kind = 'session_end') AS ends
                FROM sessions s WHERE s.status != 'running'"""):
            if row["ends"] != 1:
                problems.append(f"sessions row {row['id']} ({row['status']}): has {row['ends']} session_end events, "
                                "not one")
        seen: dict[str, str] = {}
        for (pid,) in db.execute("SELECT id FROM participants ORDER BY number"):
            if not isinstance(pid, str) or not re.fullmatch(r"[A-Za-z0-9]+", pid):
                problems.append(f"participants: id = {pid!r} is not ASCII letters and digits (not a BIDS label)")
            elif pid.lower() in seen:
                problems.append(f"participants: ids {seen[pid.lower()]!r} and {pid!r} differ only in case (one "
                                "BIDS subject)")
            else:
                seen[pid.lower()] = pid
        if full:
            problems += [f"SQLite integrity check: {r[0]}" for r in db.execute("PRAGMA integrity_check")
                         if r[0] != "ok"]
            problems += [problem for _, problem in framelog.damaged(db)]
    finally:
        if snapshot:
            db.execute("COMMIT")
    return problems


def protocol_change(db: sqlite3.Connection, protocol_id: int, *, against_ledger: bool = True) -> str | None:
    """How the stored protocol ``protocol_id`` was changed after the study was made, or None: its
    text no longer hashes to its recorded SHA-256, or (``against_ledger``; the hash rewritten with
    it) its row no longer matches its ledger entry."""
    fact = ledger.FACT["protocol"]
    row = tuple(db.execute(fact.select_one(), (protocol_id,)).fetchone())
    sha256, resolved = row[2], row[3]
    try:
        found = hashlib.sha256(canonical_json(json.loads(resolved)).encode()).hexdigest()
    except (TypeError, ValueError):
        found = None
    if found != sha256:
        return (f"protocols row {protocol_id}: the stored protocol was changed after the study was made: its "
                f"recorded sha256 is {sha256}, " + (f"its text now hashes to {found}" if found else
                                                   "its text is no longer readable JSON"))
    entry = db.execute("SELECT seq, digest FROM ledger WHERE fact = ? AND key = ?",
                       (fact.name, ledger.key_text((protocol_id,)))).fetchone() if against_ledger else None
    if entry is not None and bytes(entry[1]) != ledger.digest(fact, row):
        return (f"protocols row {protocol_id}: the stored protocol was changed after the study was made: it no longer "
                f"matches ledger entry {entry[0]} (its recorded sha256, now {sha256}, was rewritten with it)")
    return None


def check_study(store: Store, heads: Sequence[tuple[ledger.Head, str]] = ()) -> list[str]:
    """``microg study check``: the full check (``check_integrity``, ``full``), recorded beside the
    study as its last check (``microg.study.integrity``; an archive keeps no record)."""
    state = integrity.file_state(store.dir / DATABASE)
    head = ledger.head_of(store.db)  # before the check's snapshot: every batch up to it is in what is checked
    problems = check_integrity(store.db, store.dir, full=True, heads=heads)
    if not archived(store.dir / DATABASE):
        integrity.write(store.dir, integrity.Record(utc_now(), "full", not problems, tuple(problems),
                                                    None if problems or head is None else str(head), state))
    return problems


def _result_against_end_event(run: str, row: sqlite3.Row) -> list[str]:
    """Where a finished run's row and its task_end event disagree about its result."""
    try:
        said = json.loads(row["ended"])
    except (TypeError, ValueError):
        return [f"{run}: its task_end event is not readable JSON"]
    return [f"{run}: {name} = {row[name]!r}, but its task_end event says {said.get(name)!r}"
            for name in ("status", "time_s", "attempts", "reason") if said.get(name) != row[name]]
