"""The frame batches' check on open, and the record of the last check beside the study (``integrity.json``).

Every open of a study checks its ledger (``store.check_integrity``): every row's digest, every link.
That reads every row but not the frame batches' blobs, most of the file (a 2 GB study is nearly all
blobs); each blob is covered by its batch's checksum, and verifying all of them costs about 1.4 us
per frame (some 3 s for 2 GB). So the check on open (``verify_frames``) verifies the batches sealed
since the last check that verified them, when the record of that check can vouch for the file:

- it found the study sound,
- the ledger still holds the entry it names, with the same link (the chain was not rewritten), and
- the database file and its write-ahead log are as microg last left them (``file_state``: size,
  inode, modification and change times). Any program that writes into the file changes them; the
  record is written only once the file system's clock has passed the file's last change
  (``write``), so even a write right after it shows.

Otherwise it verifies every batch and runs SQLite's ``PRAGMA quick_check`` (every page's structure:
b-trees, overflow chains), as for a study without a record. What it cannot see: bytes that change
on the disk without any write (a failing disk's silent damage to batches verified before):
``microg study check`` verifies everything, every time (``check = "full"`` in the record).

The record is also the mark of the last check for whoever reads it without opening the database
(the dashboard): when it ran (``checked_at``), which check (``open``: the check on open, ``full``:
``microg study check``), whether the study was ``sound``, what was wrong (``problems``), the ledger
entry through which every batch was verified (``verified``), and the file as microg left it
(``file``). It is a file beside the database, not a table in it: it must be readable when the
database is not (a damaged file may not open at all); it is rewritten at each check, while the
database is append-only and sealed in the ledger; and a write into the database would change the
file it vouches for. Losing it costs one check of every batch, nothing else: it is a cache of what
was verified, never evidence (a record claiming more than was verified hides damage from the check
on open only, never from ``study check``).
"""

from __future__ import annotations

import contextlib
import json
import os
import sqlite3
import threading
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from . import framelog, ledger

RECORD = "integrity.json"
TICK_WAIT_S = 0.05
"""How long ``write`` waits at most for the file system's clock to pass the database's last change
(one tick of a coarse clock is 1-10 ms); beyond it, the record does not vouch for the file."""


@dataclass(frozen=True)
class Record:
    """The last check of a study (module docstring)."""

    checked_at: str
    check: str
    """``open`` (the check on open) or ``full`` (``microg study check``)."""
    sound: bool
    problems: tuple[str, ...] = ()
    verified: str | None = None
    """``ENTRY:LINK``: every frame batch sealed up to this ledger entry was verified against its checksum."""
    file: dict | None = None
    """``file_state`` of the database as microg left it; None: the record does not vouch for the file."""


@dataclass(frozen=True)
class FrameCheck:
    """What ``verify_frames`` found: damaged batches, SQLite's findings (``quick_check``, only when
    every batch was verified), and the entry through which every batch is now verified."""

    batches: list[str]
    pages: list[str]
    verified: ledger.Head | None
    everything: bool
    """Every batch was verified (the record could not vouch for the file)."""


def file_state(database: Path) -> dict:
    """The database file and its write-ahead log (a log without commits counts as none): size,
    inode, modification and change times in ns."""
    state = {}
    for path in (database, database.with_name(database.name + "-wal")):
        try:
            stat = os.stat(path)
        except FileNotFoundError:
            state[path.name] = None
            continue
        state[path.name] = None if path != database and not stat.st_size else \
            [stat.st_size, stat.st_ino, stat.st_mtime_ns, stat.st_ctime_ns]
    return state


def read(study_dir: Path) -> Record | None:
    """The record beside the study; None without one, or when it cannot be read (a check of everything follows)."""
    try:
        data = json.loads((study_dir / RECORD).read_text())
        return Record(data["checked_at"], data["check"], bool(data["sound"]), tuple(data.get("problems") or ()),
                      data.get("verified"), data.get("file"))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def write(study_dir: Path, record: Record) -> None:
    """Write ``record`` beside the study (whole or not at all; a folder that cannot be written, an
    archive, keeps none). When it vouches for the file, it is written once the file system's clock has
    passed the file's last change, so that a later write into the file gets other times; if that
    takes longer than ``TICK_WAIT_S`` (a file system with a coarse clock), it vouches for nothing."""
    target = study_dir / RECORD
    scratch = study_dir / f".{RECORD}.{os.getpid()}.{threading.get_ident()}"
    last_change = max((t for part in (record.file or {}).values() if part for t in part[2:]), default=0)
    deadline = time.monotonic() + TICK_WAIT_S
    try:
        while True:
            scratch.write_text(json.dumps(asdict(record), indent=1) + "\n")
            if record.file is None or scratch.stat().st_mtime_ns > last_change:
                break
            if time.monotonic() > deadline:
                record = replace(record, file=None)
                continue
            time.sleep(0.001)
        os.replace(scratch, target)
    except OSError:
        with contextlib.suppress(OSError):
            scratch.unlink(missing_ok=True)


def vouched(db: sqlite3.Connection, record: Record | None, state: dict) -> int | None:
    """The ledger entry through which ``record`` vouches that every batch was verified, for a
    database in ``state``; None when it cannot vouch (module docstring)."""
    if record is None or not record.sound or record.verified is None or record.file != state:
        return None
    try:
        head = ledger.parse_head(record.verified)
    except ValueError:
        return None
    row = db.execute("SELECT link FROM ledger WHERE seq = ?", (head.entry,)).fetchone()
    return head.entry if row is not None and bytes(row[0]).hex() == head.link else None


def verify_frames(db: sqlite3.Connection, since: int | None) -> FrameCheck:
    """Verify the frame batches sealed after ledger entry ``since`` against their checksums, or
    with ``since`` None every batch and SQLite's ``quick_check``; in one snapshot."""
    db.execute("BEGIN")
    try:
        head = ledger.head_of(db)
        rows = db.cursor()
        rows.row_factory = None
        if since is None:
            pages = [f"SQLite's quick check: {r[0]}" for r in rows.execute("PRAGMA quick_check") if r[0] != "ok"]
            batches = rows.execute(f"SELECT {framelog.ROW} FROM frames")
        else:
            pages = []
            batches = rows.execute(  # read in the file's order: a gigabyte in 0.2 s, 1.7 s in the ledger's
                "SELECT f.run_id, f.first, f.count, f.t_first, f.t_last, f.checksum, f.data FROM frames f "
                "WHERE f.rowid IN (SELECT n.rowid FROM ledger l JOIN frames n ON n.run_id = json_extract(l.key, '$[0]') "
                "AND n.first = json_extract(l.key, '$[1]') WHERE l.fact = 'frames' AND l.seq > ?) ORDER BY f.rowid",
                (since,))
        damaged = [framelog.damage(db, row) for row in _unsound(batches)]  # rows as framelog.ROW
    finally:
        db.execute("COMMIT")
    return FrameCheck(damaged, pages, head, since is None)


VERIFY_ROWS = 64
"""Frame batches read at a time while the ones before are checked."""


def _unsound(batches: sqlite3.Cursor) -> list:
    """The rows of ``batches`` that do not match their checksums. One thread checks a chunk of rows
    while this one reads the next (SQLite and SHA-256 both let go of the interpreter's lock, so the
    two overlap: 0.7 s for the demo's 1 GB of frames, 1.0 s one after the other)."""
    from concurrent.futures import ThreadPoolExecutor

    def check(rows: list) -> list:
        return [row for row in rows if not framelog.sound(row)]

    unsound, pending = [], None
    with ThreadPoolExecutor(1) as pool:
        while rows := batches.fetchmany(VERIFY_ROWS):
            if pending is not None:
                unsound += pending.result()
            pending = pool.submit(check, rows)
        if pending is not None:
            unsound += pending.result()
    return unsound
