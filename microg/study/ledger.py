"""The ledger: every fact the study's store commits, in a hash chain, so that damage to the log and
changes made behind microg's back are found and named.

A fact is a row as it was written (the study, its protocol, a participant's enrolment, a session,
a planned task, a task run's start, an event, an answer, a frame batch, a station, a participant
taken back from a station) or the final state a row reaches once (a task run's result, a session's
end, a participant's withdrawal): ``FACTS``. The transaction that commits a fact adds its ledger entry (``seal``): the fact's digest, SHA-256 of its
columns as canonical JSON with the fact's name (a frame batch's digest is its checksum,
``framelog.checksum``, which covers its row and its blob), and its link, SHA-256 of the previous
entry's link and the digest. After each commit that starts or ends something (``Store.transaction``)
the store writes the chain's head, the last entry's number and link, into
``<study>/ledger-head.json``, outside the database (``write_head``).

``check`` (on every open, in one snapshot) recomputes every fact's digest from its row and every
link, and compares the head file: about 12 ms of CPU per 1000 entries, some 830 entries per
participant of the paper's protocol (``microg bench store``). A frame batch is compared with its checksum
there; its blob is verified against the checksum when it is read (export, the view,
re-simulation), and all of them by ``microg study check``.

What it finds: damage to any row (a failing disk, a bad copy); a change by another program (a
database browser, a script; with the store's triggers dropped and re-created or not); a row
inserted or deleted behind microg's back; a changed row whose digest was recomputed (its link no
longer follows); a rewritten or cut chain (the head file no longer matches). What it cannot find:
someone who knows this method and rewrites the rows, every link after them and the head file
together. Only a copy of the head kept elsewhere shows that: ``microg study check`` prints the
head, every export records it in its ``export.json``, and ``microg study check --head`` tells
whether the chain still holds a head noted earlier. (A signature would need a key kept off the
study's machine, which the study has nowhere to keep.)
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sqlite3
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

HEAD_FILE = "ledger-head.json"
GENESIS = bytes(32)
"""The link before the first entry."""


@dataclass(frozen=True)
class Fact:
    """One kind of fact: the ``columns`` of a ``table`` row (named by its ``key`` columns). A final
    state has the row's ``status`` while it is open (``open_status``; its other columns are then
    empty), and is a fact once the row has left that state."""

    name: str
    table: str
    key: tuple[str, ...]
    columns: tuple[str, ...]
    open_status: str | None = None
    checksummed: bool = False
    """The last column is the row's own checksum, over the row and its blob: the fact's digest."""

    def select(self) -> str:
        """Every row that is this fact: key columns, then the covered columns."""
        query = f"SELECT {', '.join(self.key + self.columns)} FROM {self.table}"
        if self.open_status is None:
            return query
        still_open = " AND ".join([f"status IS '{self.open_status}'"]
                                  + [f"{c} IS NULL" for c in self.columns if c != "status"])
        return f"{query} WHERE NOT ({still_open})"

    def select_one(self) -> str:
        where = " AND ".join(f"{k} = ?" for k in self.key)
        return self.select() + (" AND " if self.open_status else " WHERE ") + where


FACTS = (
    Fact("study", "study", ("id",), ("name", "seed", "protocol_id", "created_at", "microg_version", "schema_version",
                                     "station")),
    Fact("protocol", "protocols", ("id",), ("name", "sha256", "resolved", "source_text", "added_at")),
    Fact("participant", "participants", ("id",), ("number", "group_code", "gender", "age", "handedness",
                                                  "mr_experience", "order_row", "object_order", "added_at")),
    Fact("withdrawal", "participants", ("id",), ("status", "withdrawn_at", "withdraw_reason"), open_status="active"),
    Fact("session", "sessions", ("id",), ("participant_id", "protocol_id", "seed", "input", "simulated", "clock",
                                          "object_order", "microg_version", "python", "platform", "created_at",
                                          "station", "merged_at", "name", "session_index", "date",
                                          "date_simulated", "due", "ignored_schedule")),
    Fact("session_end", "sessions", ("id",), ("status", "ended_at"), open_status="running"),
    Fact("task", "tasks", ("session_id", "task_index"), ("phase", "interaction", "object", "object_code",
                                                         "order_position", "task_in_phase", "difficulty")),
    Fact("run", "task_runs", ("id",), ("session_id", "task_index", "run", "source", "seed", "started_at",
                                       "started_wall")),
    Fact("result", "task_runs", ("id",), ("status", "reason", "ended_at", "time_s", "attempts", "frames",
                                          "ended_wall"), open_status="running"),
    Fact("event", "events", ("id",), ("session_id", "run_id", "t", "wall", "kind", "data")),
    Fact("answer", "answers", ("session_id", "instrument", "administration", "interaction", "item"),
         ("value", "source", "response_time_s", "t", "wall")),
    Fact("frames", "frames", ("run_id", "first"), ("count", "t_first", "t_last", "checksum"), checksummed=True),
    Fact("station", "stations", ("name",), ("participants", "made_at")),
    Fact("give_up", "station_give_ups", ("station", "participant"), ("given_up_at", "reason")),
)
"""Every fact of the store; together they cover every column of every table (a frame batch's blob
through its checksum)."""
FACT = {fact.name: fact for fact in FACTS}


def _text(values: Sequence) -> str:
    return json.dumps(list(values), separators=(",", ":"))


def key_text(key: Sequence) -> str:
    """A row's key as the ledger writes it: a JSON list (whole numbers spelled out directly, the
    common case, at a tenth of ``json.dumps``'s cost)."""
    if all(type(k) is int for k in key):
        return "[" + ",".join(map(str, key)) + "]"
    return _text(key)


def digest(fact: Fact, row: Sequence) -> bytes:
    """SHA-256 of a fact's row (its key and covered columns, as ``Fact.select`` reads them), or the
    row's own checksum."""
    if fact.checksummed:
        return row[-1]
    return hashlib.sha256(_text([fact.name, *row]).encode()).digest()


def link(previous: bytes, fact_digest: bytes) -> bytes:
    """The chain's next link: SHA-256 of the previous link and the fact's digest (which binds the
    fact's row: its JSON holds the fact's name and key, a batch's checksum its run and frames)."""
    return hashlib.sha256(previous + fact_digest).digest()


def seal(db: sqlite3.Connection, fact_name: str, *key) -> None:
    """Add the ledger entry of the fact ``fact_name`` of the row ``key``, as the row now stands (in
    the transaction that wrote it, so the entry commits with the row or not at all)."""
    fact = FACT[fact_name]
    row = db.execute(fact.select_one(), key).fetchone()
    if row is None:
        raise ValueError(f"seal({fact_name!r}, {key}): no such row is the fact {fact_name!r}")
    text = key_text(key)
    fact_digest = digest(fact, tuple(row))
    last = db.execute("SELECT link FROM ledger ORDER BY seq DESC LIMIT 1").fetchone()
    db.execute("INSERT INTO ledger (fact, key, digest, link) VALUES (?, ?, ?, ?)",
               (fact_name, text, fact_digest, link(last[0] if last else GENESIS, fact_digest)))


# ---------------------------------------------------------------- the head, outside the database


@dataclass(frozen=True)
class Head:
    """The chain's head: the last entry's number and its link (hexadecimal), written ``ENTRY:LINK``."""

    entry: int
    link: str

    def __str__(self) -> str:
        return f"{self.entry}:{self.link}"


def parse_head(text: str) -> Head:
    """A head written ``ENTRY:LINK`` (as ``str(Head)``, ``microg study check`` and ``export.json`` give it)."""
    match = re.fullmatch(r"\s*(\d+):([0-9a-fA-F]{64})\s*", text)
    if match is None:
        raise ValueError(f"{text!r} is not a ledger head: give ENTRY:LINK, the entry's number and its 64 hexadecimal "
                         "digits, as microg study check prints it")
    return Head(int(match.group(1)), match.group(2).lower())


def head_of(db: sqlite3.Connection) -> Head | None:
    """The ledger's last entry as a head (None for an empty ledger)."""
    row = db.execute("SELECT seq, link FROM ledger ORDER BY seq DESC LIMIT 1").fetchone()
    return None if row is None else Head(row[0], row[1].hex())


def write_head(study_dir: Path, db: sqlite3.Connection) -> None:
    """Write the head of the committed ledger into ``<study>/ledger-head.json`` (whole or not at all).

    Writers run one at a time but write their head after their commit, so a slower writer may put
    back an earlier head: every head written is one the ledger holds, which is all the check asks.
    A head that cannot be written (a full disk) leaves the earlier one, true as well; the next
    commit writes it again."""
    head = head_of(db)
    if head is None:
        return
    target = study_dir / HEAD_FILE
    scratch = study_dir / f".{HEAD_FILE}.{os.getpid()}.{threading.get_ident()}"
    try:
        scratch.write_text(json.dumps({"entry": head.entry, "link": head.link}) + "\n")
        os.replace(scratch, target)
    except OSError:
        with contextlib.suppress(OSError):
            scratch.unlink(missing_ok=True)


def read_head(study_dir: Path) -> Head | None:
    """The head in ``<study>/ledger-head.json`` (None when there is no such file); ValueError naming
    the file when it cannot be read."""
    path = study_dir / HEAD_FILE
    try:
        data = json.loads(path.read_text())
        return Head(int(data["entry"]), parse_head(f"{data['entry']}:{data['link']}").link)
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ValueError(f"{path}: not a readable ledger head ({error}); the chain cannot be checked against it. If a "
                         f"power cut or a full disk cut it off, move it away: the chain is then checked within the "
                         "database only") from None


# ---------------------------------------------------------------- the check


def check(db: sqlite3.Connection, heads: Sequence[tuple[Head, str]] = ()) -> list[str]:
    """What the ledger finds wrong with the log (empty: every fact as committed), each problem
    naming the row (participant, session, task, run, batch) and what happened to it.

    Every link must follow from the entries before it; every row of every fact must have its entry
    and match its digest, and every entry its row; each of ``heads`` (a head and where it comes
    from, e.g. the head file) must be in the chain. Run it inside one read transaction; a database
    SQLite cannot read raises ``sqlite3.Error``."""
    problems: list[str] = []
    entries: dict[tuple[str, str], tuple[int, bytes]] = {}
    wanted: dict[int, list[tuple[Head, str]]] = {}
    for head, source in heads:
        wanted.setdefault(head.entry, []).append((head, source))
    rows = db.cursor()
    rows.row_factory = None  # plain tuples: the check reads every row of the log
    previous, last = GENESIS, 0
    for seq, fact, key, fact_digest, stored in rows.execute("SELECT seq, fact, key, digest, link FROM ledger "
                                                            "ORDER BY seq"):
        if previous is not None and link(previous, fact_digest) != stored:
            problems.append(f"ledger entry {seq} ({fact} {key}): its link does not follow from the entries before "
                            "it: the ledger was changed at or before this entry")
            previous = None  # one broken link says it; the entries after it cannot be trusted either
        elif previous is not None:
            previous = stored
        for head, source in wanted.get(seq, ()):
            if stored.hex() != head.link:
                problems.append(f"{source} names ledger entry {seq} with link {head.link[:16]}..., but the ledger's "
                                f"entry {seq} links {stored.hex()[:16]}...: the ledger was rewritten after that "
                                "entry was committed")
        entries[(fact, key)] = (seq, fact_digest)
        last = seq
    for head, source in heads:
        if head.entry > last:
            problems.append(f"{source} names ledger entry {head.entry}, but the ledger ends at entry {last}: entries "
                            "were removed after it was written, or study.db was put back from an older copy (a power "
                            "cut during a simulated session can lose its last commits too)")
    for fact in FACTS:
        for row in rows.execute(fact.select()).fetchall():
            key = row[:len(fact.key)]
            entry = entries.pop((fact.name, key_text(key)), None)
            if entry is None:
                problems.append(f"{describe(db, fact, key)}: not in the ledger (written behind microg's back)")
            elif digest(fact, row) != entry[1]:
                problems.append(f"{describe(db, fact, key)}: changed after it was written (it no longer matches "
                                f"ledger entry {entry[0]})")
    for (fact_name, key), (seq, _) in sorted(entries.items(), key=lambda item: item[1][0]):
        fact = FACT.get(fact_name)
        what = f"{fact_name} {key}" if fact is None else describe(db, fact, tuple(json.loads(key)))
        problems.append(f"ledger entry {seq}: {what} is gone from the database (deleted, or set back to an earlier "
                        "state)")
    return problems


def run_name(db: sqlite3.Connection, run_id: int) -> str:
    """``participant P01's session 1, task 2 (stage1, cube), run 1``: what a task run is, for messages."""
    try:
        row = db.execute("""
            SELECT s.participant_id, r.session_id, r.task_index, r.run, t.phase, t.object
            FROM task_runs r LEFT JOIN sessions s ON s.id = r.session_id
            LEFT JOIN tasks t ON t.session_id = r.session_id AND t.task_index = r.task_index
            WHERE r.id = ?""", (run_id,)).fetchone()
    except sqlite3.Error:
        row = None
    if row is None:
        return f"task run {run_id}"
    participant, session, task, run, phase, obj = tuple(row)
    return f"participant {participant}'s session {session}, task {task} ({phase}, {obj}), run {run} (task run {run_id})"


def describe(db: sqlite3.Connection, fact: Fact, key: tuple) -> str:
    """The row a fact is about, as a message names it."""
    first = key[0] if key else None
    names = {
        "study": lambda: "the study row",
        "protocol": lambda: f"protocols row {first}",
        "participant": lambda: f"the enrolment of participant {first}",
        "withdrawal": lambda: f"the withdrawal of participant {first}",
        "session": lambda: f"session {first}",
        "session_end": lambda: f"the end of session {first}",
        "task": lambda: f"the plan of session {first}, task {key[1]}",
        "run": lambda: f"the start of {run_name(db, first)}",
        "result": lambda: f"the result of {run_name(db, first)}",
        "event": lambda: _event_name(db, first),
        "answer": lambda: f"the answer of session {first} to {key[1]} item {key[4]} ({key[2]}"
                          + (f", about {key[3]})" if key[3] else ")"),
        "frames": lambda: f"frames of {run_name(db, first)}, the batch from frame {key[1]}",
        "station": lambda: f"station {first}",
        "give_up": lambda: f"participant {key[1]} taken back from station {first}",
    }
    try:
        return names[fact.name]()
    except (IndexError, KeyError):
        return f"{fact.table} row {_text(key)}"


def _event_name(db: sqlite3.Connection, event_id: int) -> str:
    try:
        row = db.execute("SELECT session_id, run_id, kind FROM events WHERE id = ?", (event_id,)).fetchone()
    except sqlite3.Error:
        row = None
    if row is None:
        return f"event {event_id}"
    session, run, kind = tuple(row)
    return f"event {event_id} ({kind} of " + (run_name(db, run) if run is not None else f"session {session}") + ")"
