"""``microg bench store``: what a frame costs the log (its codecs' bytes and time), and what the
log's integrity costs per frame, per open and per check.

The codecs (``codecs``), on the frame batches of a study (``--study``, e.g. ``microg demo``'s; else
the two sessions below) as stored: each of ``framelog.CODECS``'s bytes over every batch; on whole
runs taken evenly through the study, its encode and decode CPU time, the codecs in turn within each
round (the fastest of the rounds counts), and a run read back as ``view`` and export read it
(``framelog.read``: fetched, its checksums verified, decoded) from a scratch database of each
codec's blobs; where the bytes go, field by field; and the study's size on disk.

One simulated participant's session of the paper's protocol is logged first, for frames as a study
holds them. Then, in a scratch study, each of its frame batches is committed again, in turn:
- by ``Store.add_frames``, as a session commits it (encode, checksum, insert, ledger entry, commit);
- by ``framelog.insert`` in a bare transaction: the same without the ledger entry;
and the checksum is timed alone on the same batches. The integrity's
cost is the median over batches of (add_frames - bare insert) plus the checksum, in the same run,
with ``synchronous = NORMAL`` (a simulated session) and ``FULL`` (a live one, each commit flushed to
the disk). Reading: the
checksum against decoding, batch by batch. Opening: ``open_study`` and its ledger check, per ledger
entry; the full check of ``microg study check``, per MB of frames (in CPU time: on a shared machine
the wall clock mostly measures the wait for a core).
The check on open of a study opened for writing (``microg.study.integrity``: what every verb that
writes runs first), in CPU and wall time: with nothing new since the last check, with one
participant's session new (the next session's start), and with no record to vouch for the file
(every batch and SQLite's quick check, as after a change outside microg), also per MB of frames
and against a 2 GB study; and SQLite's ``quick_check`` and ``integrity_check`` alone, per MB of the
file. ``study``: the same on a copy of that study too (the demo's: ``microg-demo/study``).
It lives in the study room because ``microg.bench`` may not import the study.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd


def _seconds(action, clock=time.perf_counter) -> float:
    start = clock()
    action()
    return clock() - start


def _cpu_seconds(action) -> float:
    """CPU time of this process: what a check costs, less the wait for a core on a shared machine."""
    return _seconds(action, time.process_time)


def _both(action) -> tuple[float, float]:
    """(CPU, wall) seconds of ``action``."""
    cpu, wall = time.process_time(), time.perf_counter()
    action()
    return time.process_time() - cpu, time.perf_counter() - wall


GIGABYTES_2 = 2 * 1024
"""A large study, in MB: what the check on open must stay cheap for."""
SCALED_FROM_MB = 50
"""A study with fewer MB of frames is not scaled to 2 GB: its fixed costs (opening, the schema) would be scaled too."""


def check_on_open(study_dir: Path, note, label: str, repeats: int, *, one_session: int | None = None) -> None:
    """Time the check on open for writing of the study in ``study_dir`` (a scratch copy: the checks
    write its record): without a record, with one that vouches for everything, and, with
    ``one_session`` (a session id), with one that vouches for all but that session's frames."""
    from . import integrity, ledger
    from .store import DATABASE, open_study

    def opened() -> None:
        open_study(study_dir).close()

    def without_record() -> None:
        (study_dir / integrity.RECORD).unlink(missing_ok=True)
        opened()

    with open_study(study_dir, readonly=True) as store:
        megabytes = store.db.execute("SELECT COALESCE(SUM(length(data)), 0) FROM frames").fetchone()[0] / 1e6
        entries = store.db.execute("SELECT COUNT(*) FROM ledger").fetchone()[0]
        before = None if one_session is None else store.db.execute(
            "SELECT MAX(seq) FROM ledger WHERE seq < (SELECT seq FROM ledger WHERE fact = 'session' AND key = ?)",
            (ledger.key_text((one_session,)),)).fetchone()[0]
        link = None if before is None else store.db.execute("SELECT link FROM ledger WHERE seq = ?",
                                                              (before,)).fetchone()[0].hex()
        size = (study_dir / DATABASE).stat().st_size / 1e6
    note(f"{label}: frames", megabytes, "MB")
    note(f"{label}: ledger entries", entries, "entries")
    scale = GIGABYTES_2 / megabytes  # a study's ledger grows with its frames, as its blobs do
    scratch = [_both(without_record) for _ in range(repeats)]
    cpu, wall = (statistics.median(t) for t in zip(*scratch))
    note(f"{label}: check on open for writing, no record (every batch, quick check), CPU", 1e3 * cpu, "ms")
    note(f"{label}: check on open for writing, no record, wall", 1e3 * wall, "ms")
    if megabytes >= SCALED_FROM_MB:
        note(f"{label}: the same, CPU, scaled to a 2 GB study", cpu * scale, "s")
    opened()  # a record that vouches for everything
    vouched = [_both(opened) for _ in range(repeats)]
    cpu, wall = (statistics.median(t) for t in zip(*vouched))
    note(f"{label}: check on open for writing, nothing new since the last check, CPU", 1e3 * cpu, "ms")
    note(f"{label}: check on open for writing, nothing new since the last check, wall", 1e3 * wall, "ms")
    if megabytes >= SCALED_FROM_MB:
        note(f"{label}: the same, CPU, scaled to a 2 GB study", cpu * scale, "s")
    if before is not None:
        def one_new() -> None:
            integrity.write(study_dir, integrity.Record("bench", "open", True, (), f"{before}:{link}",
                                                        integrity.file_state(study_dir / DATABASE)))
            opened()
        new = [_both(one_new) for _ in range(repeats)]
        cpu, wall = (statistics.median(t) for t in zip(*new))
        note(f"{label}: check on open for writing, one participant's session new (the next session's start), "
             "CPU", 1e3 * cpu, "ms")
        note(f"{label}: the same, wall", 1e3 * wall, "ms")
    with open_study(study_dir, readonly=True) as store:
        quick = _cpu_seconds(lambda: store.db.execute("PRAGMA quick_check").fetchall())
        full = _cpu_seconds(lambda: store.db.execute("PRAGMA integrity_check").fetchall())
    note(f"{label}: SQLite's quick_check alone, CPU per MB of the file", 1e3 * quick / size, "ms")
    note(f"{label}: SQLite's integrity_check alone, CPU per MB of the file", 1e3 * full / size, "ms")


def run(out: Path, quick: bool = False, say=print, study: Path | None = None) -> pd.DataFrame:
    """Measure (module docstring), write ``out/store.csv`` and return the table. ``study``: measure
    the codecs and the check on open on that study too."""
    from microg.paths import protocol_file

    from . import framelog, ledger
    from .assignment import Participant
    from .inputs import open_inputs
    from .protocol import load_protocol
    from .session import SimulationClock, run_session
    from .store import DATABASE, check_integrity, create_study, open_study

    rows = []

    def note(measure: str, value: float, unit: str) -> None:
        rows.append({"measure": measure, "value": value, "unit": unit})
        say(f"{measure}: {value:.4g} {unit}")

    note("load average (1 min) at the start", os.getloadavg()[0], "processes")
    protocol = load_protocol(protocol_file("paper"))
    with tempfile.TemporaryDirectory(prefix="microg-bench-store-") as folder:
        if study is not None:
            with open_study(study, readonly=True) as measured:
                size = (Path(study) / DATABASE).stat().st_size
                frames = measured.db.execute("SELECT COALESCE(SUM(count), 0) FROM frames").fetchone()[0]
                note(f"{study}: study.db", size / 1e6, "MB")
                note(f"{study}: study.db per frame (every table and index)", size / max(frames, 1), "bytes")
                codecs(measured.db, Path(folder), note, rounds=1 if quick else 3, timed_batches=40 if quick else 1500)
        logged = create_study(Path(folder) / "logged", protocol, seed=1)
        walls = []
        for participant in ("P01", "P02"):  # the first compiles (or loads) the kernels; the second is timed
            logged.add_participant(Participant(participant, "female", 24, "right", True))
            session = logged.create_session(participant, input_spec="simulated:practice", simulated=True,
                                            clock="simulation")
            walls.append(_seconds(lambda: run_session(logged, session.id, open_inputs("simulated:practice"),
                                                      clock=SimulationClock())))
        timed = logged.db.execute("SELECT SUM(f.count) FROM frames f JOIN task_runs r ON r.id = f.run_id "
                                  "WHERE r.session_id = ?", (session.id,)).fetchone()[0]
        size = protocol.frame_batch
        batches = [frames[i:i + size] for (run_id,) in logged.db.execute("SELECT id FROM task_runs ORDER BY id")
                   for frames in [framelog.read(logged.db, run_id)] for i in range(0, len(frames), size)]
        frames = sum(len(b) for b in batches)
        note("frames logged by two simulated participants (paper protocol)", frames, "frames")
        note("a simulated session, wall time per frame (physics, participant, task, logging)",
             1e6 * walls[1] / timed, "us")
        batches = batches[:40] if quick else batches
        frames = sum(len(b) for b in batches)
        blobs = [framelog.encode(b) for b in batches]
        checksum = _seconds(lambda: [framelog.checksum(1, first=0, count=len(b), t_first=0.0, t_last=1.0, blob=blob)
                                     for b, blob in zip(batches, blobs)]) / frames
        note("checksum (SHA-256 of the batch), per frame", 1e6 * checksum, "us")

        scratch = create_study(Path(folder) / "scratch", protocol, seed=2)
        scratch.add_participant(Participant("P01", "female", 24, "right", True))
        plan = scratch.create_session("P01", input_spec="bench", simulated=True, clock="simulation")
        sealed, bare = (scratch.begin_run(plan.id, task=task, source="bench", seed=0, t=0.0)
                        for task in scratch.tasks(plan.id)[:2])
        first = 0
        for simulated in (True, False):
            scratch.commit_for(simulated)
            paired = []  # per batch: (add_frames, bare insert) seconds per frame, one right after the other
            for batch in batches * (1 if quick or not simulated else 3):
                whole = _seconds(lambda: scratch.add_frames(sealed, first, batch))

                def insert_bare():
                    scratch.db.execute("BEGIN IMMEDIATE")
                    framelog.insert(scratch.db, bare, first, batch)
                    scratch.db.execute("COMMIT")

                paired.append((whole / len(batch), _seconds(insert_bare) / len(batch)))
                first += len(batch)
            mode = "NORMAL (simulated session)" if simulated else "FULL (live session)"
            total = statistics.median(w for w, _ in paired)
            integrity = statistics.median(w - b for w, b in paired) + checksum
            note(f"add_frames, synchronous {mode}, per frame (median over batches)", 1e6 * total, "us")
            note(f"of which the integrity (checksum and ledger entry), {mode}, per frame", 1e6 * integrity, "us")
            note(f"integrity share of add_frames, {mode}", integrity / total, "ratio")
        scratch.close()

        rows_read = logged.db.execute("SELECT run_id, first, count, t_first, t_last, checksum, data FROM frames"
                                      ).fetchall()
        verify = _seconds(lambda: [framelog.sound(row) for row in rows_read])
        decode = _seconds(lambda: [framelog.decode(row[6], row[2]) for row in rows_read])
        read_frames = sum(row[2] for row in rows_read)
        note("read: checksum verified, per frame", 1e6 * verify / read_frames, "us")
        note("read: verification share of verify + decode", verify / (verify + decode), "ratio")
        if study is None:
            codecs(logged.db, Path(folder), note, rounds=1 if quick else 3, timed_batches=40 if quick else 1500)
        logged.close()

        study_dir = Path(folder) / "logged"
        opens = [_cpu_seconds(lambda: open_study(study_dir, readonly=True).close()) for _ in range(3 if quick else 7)]
        with open_study(study_dir, readonly=True) as store:
            entries = store.db.execute("SELECT COUNT(*) FROM ledger").fetchone()[0]

            def ledger_check():
                store.db.execute("BEGIN")
                ledger.check(store.db, [])
                store.db.execute("COMMIT")

            checks = [_cpu_seconds(ledger_check) for _ in range(3 if quick else 7)]
            full = _cpu_seconds(lambda: check_integrity(store.db, study_dir, full=True))
            megabytes = store.db.execute("SELECT SUM(length(data)) FROM frames").fetchone()[0] / 1e6
        note("ledger entries of the two participants' sessions", entries, "entries")
        note("open_study (read only, the whole check on open), CPU time, median", 1e3 * statistics.median(opens),
             "ms")
        note("of which the ledger check", statistics.median(checks) / statistics.median(opens), "ratio")
        note("the ledger check, CPU time per 1000 entries", 1e3 * statistics.median(checks) / entries * 1000, "ms")
        note("full check (study check), CPU time per MB of frames", 1e3 * full / megabytes, "ms")
        check_on_open(study_dir, note, "the two participants' study", 3 if quick else 7, one_session=session.id)
        if study is not None:
            copy = Path(folder) / "given"
            shutil.copytree(study, copy, ignore=shutil.ignore_patterns("locks", "export*", "resimulated"))
            check_on_open(copy, note, "the study given (--study)", 1 if quick else 3)
    note("load average (1 min) at the end", os.getloadavg()[0], "processes")
    table = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "store.csv", index=False)
    return table


def codecs(db: sqlite3.Connection, folder: Path, note, rounds: int, timed_batches: int) -> None:
    """The codecs measured on the frame batches of the study database ``db`` as they are stored:
    their bytes over every batch (one batch at a time); on whole runs taken evenly through the study
    up to ``timed_batches`` batches, encode and decode CPU time per frame, each codec in turn within
    each of ``rounds`` rounds (the fastest round counts), and reading those runs back through
    ``framelog.read`` from a scratch database in ``folder`` of each codec's blobs; where the bytes
    go, field by field, on the first of those batches."""
    from . import framelog

    frames, as_stored, size = 0, 0, dict.fromkeys(framelog.CODECS, 0)
    stored = dict(size)
    for count, blob in db.execute("SELECT count, data FROM frames"):
        batch = framelog.decode(blob, count)
        frames, as_stored = frames + count, as_stored + len(blob)
        stored[framelog.codec_of(blob)] += count
        for codec in framelog.CODECS:
            size[codec] += len(framelog.encode(batch, codec))
    note("frames of the study", frames, "frames")
    note("the study's frame blobs as stored, per frame", as_stored / frames, "bytes")
    for codec in framelog.CODECS:
        note(f"frames stored with {codec}", stored[codec], "frames")
        note(f"{codec}: bytes per frame, every batch of the study", size[codec] / frames, "bytes")
    for older in (codec for codec in framelog.CODECS if codec != framelog.CODEC):
        note(f"{framelog.CODEC} against {older}: bytes", size[framelog.CODEC] / size[older], "ratio")

    runs = [run_id for (run_id,) in db.execute("SELECT DISTINCT run_id FROM frames ORDER BY run_id")]
    total = db.execute("SELECT COUNT(*) FROM frames").fetchone()[0]
    runs = runs[::max(1, -(-total // timed_batches))]
    sample = []
    for run_id in runs:
        sample += db.execute("SELECT run_id, first, count, t_first, t_last, data FROM frames WHERE run_id = ? "
                             "ORDER BY first", (run_id,)).fetchall()
        if len(sample) >= timed_batches:
            break
    batches = [framelog.decode(row[5], row[2]) for row in sample]
    timed = sum(len(b) for b in batches)
    note("frames timed (whole runs through the study)", timed, "frames")
    blobs = {codec: [framelog.encode(b, codec) for b in batches] for codec in framelog.CODECS}
    encode = dict.fromkeys(framelog.CODECS, np.inf)
    decode = dict(encode)
    for _ in range(rounds):
        for codec in framelog.CODECS:
            encode[codec] = min(encode[codec], _cpu_seconds(lambda: [framelog.encode(b, codec) for b in batches]))
            decode[codec] = min(decode[codec], _cpu_seconds(
                lambda: [framelog.decode(blob, len(b)) for blob, b in zip(blobs[codec], batches)]))
    read = {}
    for codec in framelog.CODECS:
        scratch = sqlite3.connect(folder / f"codec-{codec}.db", isolation_level=None)
        scratch.execute("CREATE TABLE frames (run_id INTEGER, first INTEGER, count INTEGER, t_first REAL, "
                        "t_last REAL, checksum BLOB, data BLOB, PRIMARY KEY (run_id, first))")
        scratch.executemany(f"INSERT INTO frames ({framelog.ROW}) VALUES (?, ?, ?, ?, ?, ?, ?)", [
            (run_id, first, n, t_first, t_last,
             framelog.checksum(run_id, first=first, count=n, t_first=t_first, t_last=t_last, blob=blob), blob)
            for (run_id, first, n, t_first, t_last, _), blob in zip(sample, blobs[codec])])
        read_runs = sorted({row[0] for row in sample})
        read[codec] = min(_cpu_seconds(lambda: [framelog.read(scratch, run_id) for run_id in read_runs])
                          for _ in range(rounds))
        scratch.close()
    for codec in framelog.CODECS:
        note(f"{codec}: encode, CPU per frame", 1e6 * encode[codec] / timed, "us")
        note(f"{codec}: decode, CPU per frame", 1e6 * decode[codec] / timed, "us")
        note(f"{codec}: read a run (fetch, verify, decode), CPU per frame", 1e6 * read[codec] / timed, "us")
    new = framelog.CODEC
    for old in (codec for codec in framelog.CODECS if codec != new):
        note(f"{new} against {old}: encode", encode[new] / encode[old], "ratio")
        note(f"{new} against {old}: decode", decode[new] / decode[old], "ratio")
        note(f"{new} against {old}: read a run", read[new] / read[old], "ratio")
    where = batches[:400]  # where the bytes go: each field as logged, the rest as in an empty record
    counted = sum(len(b) for b in where)
    for codec in framelog.CODECS:
        bare = [_bare(b) for b in where]
        base = sum(len(framelog.encode(b, codec)) for b in bare)
        note(f"{codec}: the batch with every field empty (tracked kept), per frame", base / counted, "bytes")
        for name in framelog.FRAME.names:
            if name == "tracked":
                continue
            grown = 0
            for b, empty in zip(where, bare):
                kept = empty[name].copy()
                empty[name] = b[name]
                grown += len(framelog.encode(empty, codec))
                empty[name] = kept
            note(f"{codec}: {name}, per frame", (grown - base) / counted, "bytes")


def _bare(frames: np.ndarray) -> np.ndarray:
    """The frames emptied as ``frames_of`` starts them (zero, NaN hands), but which hands were tracked."""
    from .framelog import FRAME, UNTRACKED

    bare = np.broadcast_to(UNTRACKED, (len(frames), FRAME.itemsize)).copy().view(FRAME).reshape(len(frames))
    bare["tracked"] = frames["tracked"]
    return bare
