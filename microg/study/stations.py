"""Several stations, one study: a station's study made from the central one, and its sessions merged back.

    microg study station STUDY --name B --out STATION_DIR [--participant P03 ...]
    microg study merge STUDY STATION_DIR...
    microg study station STUDY --name B --give-up [--participant P03 ...]

Making a station (``make_station``): the station's study has the central study's protocol (the
same resolved protocol, so the same SHA-256), its seed, and the enrolment rows of the participants
it may run exactly as the central study assigned them (group, object order, enrolment number). The
seed and the number make each session's seed, so a session runs at a station as it would have run
centrally; groups and orders are decided centrally, so the balance holds across stations, and a
station enrols nobody. The central study records the station in ``stations`` (its name, its
participants, when it was made) and the station's study holds the same row.

A trainee of a training program who ran sessions already (in the central study, or at a station
and merged back) may be handed to a station for their next ones: their earlier sessions are
carried to the station's study whole (``_carry``: rows, runs, events, answers, frames, as the
central study holds them, station and merge time included), so the station knows their schedule
(the next session is due ``after_days`` after the last one), their session number (which makes
the session's seed) and their practice (the simulated participant's).

Merging (``merge_stations``) brings every ended session of each station into the central store:
the session, its planned tasks, its task runs, events, answers and frame batches, each row as the
station wrote it (new ids; a frame batch's blob as it is, its checksum computed again for its new
run), with the station's name and the merge's time on the session (``sessions.station``,
``sessions.merged_at``). A participant withdrawn at the station is withdrawn centrally too, with the
station's time and reason. It is append-only and idempotent: a session merged before is compared
with the station's, whole (``session_content``), and adds nothing when it is the same; so is a
session carried to the station, which must be the central study's. It refuses, naming every
conflict and merging nothing: a study that is not a station of this one, another protocol, an
enrolment that differs from the central one, one session of a participant run at two stations (or
centrally and at a station), a session that differs from the one merged before from its station,
a carried session that differs from the central study's. Sessions still running at a station are
left for a later merge and said so.

Both sides are checked: a station is opened with the integrity check (a damaged one is refused),
each of its frame batches is verified against its checksum as it is copied, and the central
study's check runs on what the merge wrote before it commits. The merge is one transaction: killed
at any point, it leaves the central study as it was; one that another merge (or a session)
overtook between its plan and its transaction plans again inside it.

A participant handed to a station runs there: the central study refuses to run them
(``Store.check_runs_here``) until the station gives them back (``give_up``: a ``station_give_ups``
row, sealed; a trainee whose sessions were merged from it too, while a session of their program is
left); a merge then leaves the station's new sessions and withdrawals of them out, naming them.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import re
import shutil
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from . import framelog, ledger
from .assignment import ParticipantError
from .protocol import ONE_SESSION
from .schedule import ScheduleError, choose_session, next_session
from .store import Store, StoreError, check_integrity, create_study, open_study, utc_now

NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,31}")
"""A station's name: it names the station in messages, exports and the stations' folders."""


class MergeConflict(StoreError):
    """A merge refused: ``conflicts`` lists each, naming the station, participant and session."""

    def __init__(self, central: Path, conflicts: list[str]):
        super().__init__(f"{central}: nothing was merged; {len(conflicts)} conflict(s):\n"
                         + "\n".join(f"  - {c}" for c in conflicts))
        self.conflicts = conflicts


@dataclass(frozen=True)
class Station:
    """A station as the central study made it: its name, the participants it may run, when."""

    name: str
    participants: tuple[str, ...]
    made_at: str


@dataclass
class StationMerge:
    """What a merge did with one station: sessions it merged now, had merged before (the same),
    found the central study's own (carried to the station with their trainee: the same), each named
    by participant (and session, in a training program); participants left for later (still running
    at the station), withdrawals it carried, and participants taken back from the station
    (``give_up``) whose session or withdrawal there it left out."""

    station: str
    folder: Path
    merged: list[str] = field(default_factory=list)
    already: list[str] = field(default_factory=list)
    carried: list[str] = field(default_factory=list)
    running: list[str] = field(default_factory=list)
    withdrawn: list[str] = field(default_factory=list)
    given_up: list[str] = field(default_factory=list)


def stations(db: sqlite3.Connection) -> list[Station]:
    """The stations a study records, by name (a station's own study records itself)."""
    return [Station(r[0], tuple(json.loads(r[1])), r[2])
            for r in db.execute("SELECT name, participants, made_at FROM stations ORDER BY name")]


def given_up(db: sqlite3.Connection, name: str) -> dict[str, str]:
    """The participants taken back from station ``name`` (``give_up``) -> when."""
    return dict(db.execute("SELECT participant, given_up_at FROM station_give_ups WHERE station = ?", (name,)))


def _insert_station(db: sqlite3.Connection, station: Station) -> None:
    db.execute("INSERT INTO stations (name, participants, made_at) VALUES (?, ?, ?)",
               (station.name, json.dumps(list(station.participants)), station.made_at))
    ledger.seal(db, "station", station.name)


def _enrolment(db: sqlite3.Connection, participant_id: str) -> sqlite3.Row | None:
    """A participant's enrolment as written (the ledger's ``participant`` fact: id, number, group,
    demographics, order, when)."""
    return db.execute(ledger.FACT["participant"].select_one(), (participant_id,)).fetchone()


# ---------------------------------------------------------------- making a station


def make_station(central: Store, name: str, *, out_dir: str | Path, participants: Sequence[str] = (),
                 say=print) -> Store:
    """A station's study in the new folder ``out_dir`` (module docstring) that may run
    ``participants`` (default: every active participant with no session in the central study and
    given to no station yet; a trainee with sessions is named), with a trainee's earlier sessions;
    recorded in the central study. Returns the station's open store."""
    out_dir = Path(out_dir)
    if central.station is not None:
        raise StoreError(f"{central.dir} is station {central.station}'s study; stations are made from the central "
                         "study")
    if not NAME.fullmatch(name):
        raise StoreError(f"--name {name!r}: 1 to 32 letters, digits, '-' or '_', starting with a letter or digit")
    made = {s.name: s for s in stations(central.db)}
    if name in made:
        raise StoreError(f"station {name} was made from study {central.name!r} on {made[name].made_at}; a station "
                         "name is used once: choose another")
    if out_dir.exists() and (not out_dir.is_dir() or any(out_dir.iterdir())):
        raise FileExistsError(f"{out_dir} exists and is not an empty folder; a station's study is made in a new one")
    given = {pid: s.name for s in made.values() for pid in set(s.participants) - set(given_up(central.db, s.name))}
    if participants:
        chosen = _chosen(central, name, participants)
        for pid in chosen:
            if pid in given:
                say(f"warning: {pid} was given to station {given[pid]} too: run each of their sessions at one station "
                    "only (the merge refuses a session run at two), or take them back from it first: microg study "
                    f"station {central.dir} --name {given[pid]} --give-up --participant {pid}")
    else:
        chosen = [p.id for p in central.participants() if p.status == "active"
                  and central.session_of(p.id) is None and p.id not in given]
        if not chosen:
            raise StoreError(f"study {central.name!r}: no participant is left for a station (every active participant "
                             "has a session or was given to a station); enrol more, or name them with --participant")
    station = Station(name, tuple(chosen), utc_now())
    created = not out_dir.exists()
    store = create_study(out_dir, central.protocol, central.seed, station=name)
    try:
        with store.transaction() as db:
            _insert_station(db, station)
            fact = ledger.FACT["participant"]
            columns = fact.key + fact.columns
            for pid in chosen:
                db.execute(f"INSERT INTO participants ({', '.join(columns)}) VALUES ({', '.join('?' * len(columns))})",
                           tuple(_enrolment(central.db, pid)))
                ledger.seal(db, "participant", pid)
            for pid in chosen:
                for session in central.sessions_of(pid):
                    _carry(db, central, session, name)
            problems = check_integrity(db, out_dir, snapshot=False)
            if problems:
                raise StoreError(f"{out_dir}: station {name}'s study would not be sound, so it was not made:\n"
                                 + "\n".join(f"  - {p}" for p in problems))
        with central.transaction() as db:
            _insert_station(db, station)
    except BaseException:
        store.close()
        _empty(out_dir, remove=created)
        raise
    return store


def _empty(folder: Path, remove: bool) -> None:
    """Take back a station's study that could not be made whole: the folder made for it, or what was
    written into the empty folder given."""
    if remove:
        shutil.rmtree(folder, ignore_errors=True)
        return
    for path in folder.iterdir():
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)


def _chosen(central: Store, name: str, participants: Sequence[str]) -> list[str]:
    """The named participants, by enrolment number, each active with a session left to run: no
    session in the central study, or a trainee whose next session is not under way
    (``schedule.choose_session``)."""
    records = []
    for pid in dict.fromkeys(participants):
        record = central.participant(pid)
        if record.status != "active":
            raise ParticipantError(f"participant {pid} is withdrawn from study {central.name!r}; a station runs active "
                                   "participants only")
        session = central.session_of(pid)
        if session is not None and not central.protocol.program:
            where = "" if _session_station(central.db, session.id)[0] is None else " (merged from a station)"
            raise ParticipantError(f"participant {pid} already has session {session.id} ({session.status}) in study "
                                   f"{central.name!r}{where}; a session is never run twice")
        if session is not None:
            try:
                choose_session(central.protocol, pid, record.group, [s.sitting for s in central.sessions_of(pid)],
                               None)
            except ScheduleError as error:
                raise ParticipantError(f"--participant {pid}: not handed to station {name}: {error} (in study "
                                       f"{central.name!r})") from None
        records.append(record)
    return [r.id for r in sorted(records, key=lambda r: r.number)]


def _carry(db: sqlite3.Connection, central: Store, session, name: str) -> None:
    """Copy a trainee's ended session from the central study into station ``name``'s study ``db``,
    as the central study holds it (its station and merge time too)."""
    try:
        _copy_session(db, central.db, session.id, _session_station(central.db, session.id)[1])
    except framelog.DamagedFramesError as error:
        raise StoreError(f"participant {session.participant_id}'s session {session.name!r} cannot go to station "
                         f"{name}: {error}; nothing was made. See: microg study check {central.dir}") from None


def _session_station(db: sqlite3.Connection, session_id: int) -> tuple[str | None, str | None]:
    """(station, merged_at) of a session: (None, None) for one run in the study itself."""
    return tuple(db.execute("SELECT station, merged_at FROM sessions WHERE id = ?", (session_id,)).fetchone())


# ---------------------------------------------------------------- taking participants back


def give_up(central: Store, name: str, participants: Sequence[str] = (), reason: str | None = None) -> list[str]:
    """Take back from station ``name`` the ``participants`` (default: every one of its participants
    with a session left to run and not taken back before): the central study may run them (or hand
    them to another station), and a merge of the station leaves its new sessions and withdrawals of
    them out, naming them. Sessions merged from the station stay merged; a participant named that
    was not the station's, was taken back before, or whose last session was merged from it with
    none left to run (a trainee's program run through) is refused. Returns the participants taken back."""
    if central.station is not None:
        raise StoreError(f"{central.dir} is station {central.station}'s study; a station is given up in the central "
                         "study that made it")
    made = {s.name: s for s in stations(central.db)}
    if name not in made:
        raise StoreError(f"--name {name!r}: study {central.name!r} made no station {name!r} (its stations: "
                         f"{', '.join(made) or 'none'})")
    station = made[name]
    back = given_up(central.db, name)
    why = {}
    for pid in station.participants:
        sessions = central.sessions_of(pid)
        if not sessions or next_session(central.protocol, central.participant(pid).group,
                                        [s.sitting for s in sessions]) is not None:
            continue
        last = sessions[-1]
        ran_at, merged_at = _session_station(central.db, last.id)
        if ran_at == name:
            which = f" {last.name!r}" if central.protocol.program else ""
            ran = " (the last of their program)" if central.protocol.program else ""
            why[pid] = (f"{pid}'s session{which} was merged from station {name} on {merged_at}{ran}: it stays in the "
                        "study, and no session is left to run")
    why |= {pid: f"{pid} was taken back from station {name} on {back[pid]}" for pid in station.participants
            if pid in back}
    if participants:
        for pid in dict.fromkeys(participants):
            if pid not in station.participants:
                raise ParticipantError(f"--participant {pid}: not one of station {name}'s participants "
                                       f"({', '.join(station.participants)})")
            if pid in why:
                raise StoreError(f"--participant {pid}: {why[pid]}; nothing was given up")
        chosen = list(dict.fromkeys(participants))
    else:
        chosen = [pid for pid in station.participants if pid not in why]
        if not chosen:
            raise StoreError(f"station {name}: nothing to give up: " + "; ".join(why.values()))
    when = utc_now()
    with central.transaction() as db:
        for pid in chosen:
            db.execute("INSERT INTO station_give_ups (station, participant, given_up_at, reason) VALUES (?, ?, ?, ?)",
                       (name, pid, when, reason))
            ledger.seal(db, "give_up", name, pid)
    return chosen


# ---------------------------------------------------------------- merging


def session_content(db: sqlite3.Connection, session_id: int) -> str:
    """SHA-256 of everything a session logged, as it would be in any study that holds it: its row
    (without its id and merge time), its plan, runs, events, answers and frame batches (their blobs),
    runs named by task and run number rather than by id. Two studies hold the same session exactly
    when these agree."""
    digest = hashlib.sha256()

    def add(rows) -> None:
        for row in rows:
            digest.update(json.dumps([v.hex() if isinstance(v, bytes) else v for v in row]).encode())

    add(db.execute("""SELECT s.participant_id, s.name, s.session_index, s.date, s.date_simulated, s.due,
                             s.ignored_schedule, p.sha256, s.seed, s.input, s.simulated, s.clock, s.object_order,
                             s.microg_version, s.python, s.platform, s.status, s.created_at, s.ended_at, s.station
                      FROM sessions s JOIN protocols p ON p.id = s.protocol_id WHERE s.id = ?""", (session_id,)))
    add(db.execute("SELECT task_index, phase, interaction, object, object_code, order_position, task_in_phase, "
                   "difficulty FROM tasks "
                   "WHERE session_id = ? ORDER BY task_index", (session_id,)))
    add(db.execute("SELECT task_index, run, status, reason, source, seed, started_at, ended_at, time_s, attempts, "
                   "frames, started_wall, ended_wall FROM task_runs WHERE session_id = ? ORDER BY id", (session_id,)))
    add(db.execute("""SELECT r.task_index, r.run, e.t, e.wall, e.kind, e.data FROM events e
                      LEFT JOIN task_runs r ON r.id = e.run_id WHERE e.session_id = ? ORDER BY e.id""", (session_id,)))
    add(db.execute("SELECT instrument, administration, interaction, item, value, source, response_time_s, t, wall "
                   "FROM answers WHERE session_id = ? ORDER BY instrument, administration, interaction, item",
                   (session_id,)))
    for task_index, run, first, count, t_first, t_last, blob in db.execute("""
            SELECT r.task_index, r.run, f.first, f.count, f.t_first, f.t_last, f.data FROM frames f
            JOIN task_runs r ON r.id = f.run_id WHERE r.session_id = ? ORDER BY r.id, f.first""", (session_id,)):
        add([(task_index, run, first, count, t_first, t_last, hashlib.sha256(blob).hexdigest())])
    return digest.hexdigest()


@dataclass
class _Plan:
    side: Store
    outcome: StationMerge
    sessions: list[int] = field(default_factory=list)
    """The station's session ids to merge, in order."""


def merge_stations(central: Store, folders: Sequence[str | Path]) -> list[StationMerge]:
    """Merge the stations' studies in ``folders`` into ``central`` (module docstring), in the order
    given; ``MergeConflict`` lists every conflict and merges nothing. Returns what it did per station."""
    if central.station is not None:
        raise StoreError(f"{central.dir} is station {central.station}'s study; stations are merged into the central "
                         "study")
    folders = [Path(f) for f in folders]
    seen: dict[Path, Path] = {}
    for folder in folders:
        if folder.resolve() in seen:
            raise StoreError(f"{folder}: given twice (as {seen[folder.resolve()]}); give each station once")
        if folder.resolve() == central.dir.resolve():
            raise StoreError(f"{folder} is the central study itself; give the stations' folders")
        seen[folder.resolve()] = folder
    with contextlib.ExitStack() as stack:
        sides = []
        for folder in folders:
            try:
                side = stack.enter_context(open_study(folder, readonly=True))
            except StoreError as error:
                raise StoreError(f"{error}\nNothing was merged into {central.dir}.") from None
            if side.damaged_batches:
                raise StoreError(f"{folder}: the station's study is damaged:\n"
                                 + "\n".join(f"  - {p}" for p in side.damaged_batches)
                                 + f"\nNothing was merged into {central.dir}. See: microg study check {folder}")
            sides.append(side)
        planned = ledger.head_of(central.db)
        plans = _plan_or_refuse(central, sides)
        if not any(plan.sessions or plan.outcome.withdrawn for plan in plans):
            return [plan.outcome for plan in plans]
        merged_at = utc_now()
        with central.transaction() as db:
            if ledger.head_of(db) != planned:  # another merge or a session committed meanwhile: plan again, now
                plans = _plan_or_refuse(central, sides)
            for plan in plans:
                for pid in plan.outcome.withdrawn:
                    withdrawn_at, reason = plan.side.db.execute(
                        "SELECT withdrawn_at, withdraw_reason FROM participants WHERE id = ?", (pid,)).fetchone()
                    db.execute("UPDATE participants SET status = 'withdrawn', withdrawn_at = ?, withdraw_reason = ? "
                               "WHERE id = ?", (withdrawn_at, reason, pid))
                    ledger.seal(db, "withdrawal", pid)
                for session_id in plan.sessions:
                    try:
                        _copy_session(db, plan.side.db, session_id, merged_at)
                    except framelog.DamagedFramesError as error:
                        raise StoreError(f"station {plan.side.station} ({plan.side.dir}): {error}; nothing was "
                                         f"merged into {central.dir}. See: microg study check {plan.side.dir}") from None
            problems = check_integrity(db, central.dir, snapshot=False)
            if problems:
                raise StoreError(f"{central.dir}: the merged study would not be sound, so nothing was merged:\n"
                                 + "\n".join(f"  - {p}" for p in problems))
    return [plan.outcome for plan in plans]


def _plan_or_refuse(central: Store, sides: list[Store]) -> list[_Plan]:
    """``_plan``, or ``MergeConflict`` listing its conflicts."""
    plans, conflicts = _plan(central, sides)
    if conflicts:
        raise MergeConflict(central.dir, conflicts)
    return plans


def _plan(central: Store, sides: list[Store]) -> tuple[list[_Plan], list[str]]:
    """What to merge from each station, and every conflict (module docstring)."""
    conflicts: list[str] = []
    plans: list[_Plan] = []
    made = {s.name: s for s in stations(central.db)}
    claimed: dict[tuple[str, str], str] = {}
    """Participant -> the station of this merge that ran them."""
    for side in sides:
        where = f"station {side.station} ({side.dir})"
        if side.station is None:
            conflicts.append(f"{side.dir}: not a station's study (a station's study is made with: microg study "
                             f"station {central.dir} --name NAME --out FOLDER)")
            continue
        if side.protocol.sha256 != central.protocol.sha256:
            conflicts.append(f"{where}: runs another protocol ({side.protocol.name!r}, sha256 "
                             f"{side.protocol.sha256[:12]}) than the central study ({central.protocol.name!r}, sha256 "
                             f"{central.protocol.sha256[:12]})")
            continue
        record = made.get(side.station)
        if record is None or stations(side.db) != [record] or side.seed != central.seed:
            known = f"made station {side.station} on {record.made_at}" if record else f"made no station {side.station}"
            conflicts.append(f"{where}: was not made from this study (study {central.name!r} in {central.dir} {known})")
            continue
        plan = _Plan(side, StationMerge(side.station, side.dir))
        plans.append(plan)
        back = given_up(central.db, side.station)
        for person in side.participants():
            if person.id in back:
                if person.status == "withdrawn":
                    plan.outcome.given_up.append(person.id)
                continue
            enrolled = _enrolment(central.db, person.id)
            if enrolled is None:
                conflicts.append(f"{where}: participant {person.id} is not in the central study's roster")
                continue
            differ = [name for name in enrolled.keys() if enrolled[name] != _enrolment(side.db, person.id)[name]]
            if differ:
                conflicts.append(f"{where}: participant {person.id}'s enrolment differs from the central one in "
                                 f"{', '.join(differ)}")
            elif person.status == "withdrawn" and central.participant(person.id).status == "active":
                plan.outcome.withdrawn.append(person.id)
        for session in (side.session(r[0]) for r in side.db.execute("SELECT id FROM sessions ORDER BY id")):
            pid = session.participant_id
            theirs = central.session_of(pid, session.name)
            ran_here = _session_station(side.db, session.id)[0] == side.station
            if theirs is not None and session.status != "running" and \
                    session_content(central.db, theirs.id) == session_content(side.db, session.id):
                (plan.outcome.already if ran_here else plan.outcome.carried).append(_label(session))
                continue
            if pid in back:
                if pid not in plan.outcome.given_up:
                    plan.outcome.given_up.append(pid)
                continue
            if session.status == "running":
                plan.outcome.running.append(pid)
                continue
            if not ran_here:
                found = "the central study holds no such session" if theirs is None else \
                    f"it differs from the central study's (session {theirs.id})"
                conflicts.append(f"participant {pid}'s session{_named(session)} went to {where} with them from the "
                                 f"central study, but {found}: the station was not made from the central study as it "
                                 "is (put back from another copy?)")
                continue
            if (pid, session.name) in claimed:
                conflicts.append(f"participant {pid}{_named(session)} was run at {claimed[pid, session.name]} and at "
                                 f"{where}: a session is run once")
                continue
            claimed[pid, session.name] = where
            if theirs is None:
                plan.sessions.append(session.id)
                plan.outcome.merged.append(_label(session))
                continue
            station, merged_at = _session_station(central.db, theirs.id)
            if station is None:
                conflicts.append(f"participant {pid} has session {theirs.id}{_named(session)} ({theirs.status}) in "
                                 f"the central study itself and another at {where}: a session is run once")
            elif station != side.station:
                conflicts.append(f"participant {pid}{_named(session)} was run at station {station} (merged "
                                 f"{merged_at}) and at {where}: a session is run once")
            else:
                conflicts.append(f"participant {pid}'s session{_named(session)} at {where} differs from the one merged "
                                 f"from station {station} on {merged_at} (central session {theirs.id}): the station's "
                                 "study was changed or made anew since")
    return plans, conflicts


def _named(session) -> str:
    """`` (session NAME)`` for a training program's session; nothing for a protocol of one session."""
    return "" if session.name == ONE_SESSION else f" (session {session.name!r})"


def _label(session) -> str:
    """A session as a merge's outcome lists it: ``P01``, or ``P01 train1`` in a training program."""
    return session.participant_id if session.name == ONE_SESSION else f"{session.participant_id} {session.name}"


def _copy_session(db: sqlite3.Connection, source: sqlite3.Connection, session_id: int, merged_at: str | None) -> int:
    """Write the session ``session_id`` of another study (its database ``source``: a station's, or
    the central study's for a trainee handed to a station) into ``db`` as it was written there,
    with ``merged_at``, each row sealed in the ledger; returns the new session's id. Rows go in as a
    session writes them (the store's triggers take nothing else): the session and its runs open,
    their frames, events and answers, then the runs' results and the session's end."""
    s = source.execute("SELECT * FROM sessions WHERE id = ?", (session_id,)).fetchone()
    protocol_id = db.execute("SELECT protocol_id FROM study").fetchone()[0]
    new = db.execute("INSERT INTO sessions (participant_id, name, session_index, date, date_simulated, due, "
                     "ignored_schedule, protocol_id, seed, input, simulated, clock, object_order, microg_version, "
                     "python, platform, status, created_at, station, merged_at) "
                     "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'running', ?, ?, ?)",
                     (s["participant_id"], s["name"], s["session_index"], s["date"], s["date_simulated"], s["due"],
                      s["ignored_schedule"], protocol_id, s["seed"], s["input"], s["simulated"], s["clock"],
                      s["object_order"], s["microg_version"], s["python"], s["platform"], s["created_at"],
                      s["station"], merged_at)).lastrowid
    ledger.seal(db, "session", new)
    for t in source.execute("SELECT * FROM tasks WHERE session_id = ? ORDER BY task_index", (session_id,)):
        db.execute("INSERT INTO tasks VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", (new, t["task_index"], t["phase"],
                   t["interaction"], t["object"], t["object_code"], t["order_position"], t["task_in_phase"],
                   t["difficulty"]))
        ledger.seal(db, "task", new, t["task_index"])
    runs = source.execute("SELECT * FROM task_runs WHERE session_id = ? ORDER BY id", (session_id,)).fetchall()
    run_ids = {}
    for r in runs:
        run_ids[r["id"]] = db.execute(
            "INSERT INTO task_runs (session_id, task_index, run, status, source, seed, started_at, started_wall) "
            "VALUES (?, ?, ?, 'running', ?, ?, ?, ?)",
            (new, r["task_index"], r["run"], r["source"], r["seed"], r["started_at"], r["started_wall"])).lastrowid
        ledger.seal(db, "run", run_ids[r["id"]])
    batches = source.cursor()
    batches.row_factory = None
    for row in batches.execute(f"SELECT {framelog.ROW} FROM frames f WHERE run_id IN "
                               "(SELECT id FROM task_runs WHERE session_id = ?) ORDER BY run_id, first", (session_id,)):
        framelog.copy(db, row, run_ids[row[0]], source)
        ledger.seal(db, "frames", run_ids[row[0]], row[1])
    for e in source.execute("SELECT * FROM events WHERE session_id = ? ORDER BY id", (session_id,)):
        event_id = db.execute("INSERT INTO events (session_id, run_id, t, wall, kind, data) VALUES (?, ?, ?, ?, ?, ?)",
                              (new, run_ids.get(e["run_id"]), e["t"], e["wall"], e["kind"], e["data"])).lastrowid
        ledger.seal(db, "event", event_id)
    for a in source.execute("SELECT * FROM answers WHERE session_id = ? ORDER BY rowid", (session_id,)):
        key = (a["instrument"], a["administration"], a["interaction"], a["item"])
        db.execute("INSERT INTO answers (session_id, instrument, administration, interaction, item, value, source, "
                   "response_time_s, t, wall) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                   (new, *key, a["value"], a["source"], a["response_time_s"], a["t"], a["wall"]))
        ledger.seal(db, "answer", new, *key)
    for r in runs:
        if r["status"] != "running":
            db.execute("UPDATE task_runs SET status = ?, reason = ?, ended_at = ?, time_s = ?, attempts = ?, "
                       "frames = ?, ended_wall = ? WHERE id = ?",
                       (r["status"], r["reason"], r["ended_at"], r["time_s"], r["attempts"], r["frames"],
                        r["ended_wall"], run_ids[r["id"]]))
            ledger.seal(db, "result", run_ids[r["id"]])
    db.execute("UPDATE sessions SET status = ?, ended_at = ? WHERE id = ?", (s["status"], s["ended_at"], new))
    ledger.seal(db, "session_end", new)
    return new

