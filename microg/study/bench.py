"""``microg bench store``: what the log's integrity costs per frame, per open and per check.

One simulated participant's session of the paper's protocol is logged first, for frames as a study
holds them. Then, in a scratch study, each of its frame batches is committed again, in turn:
- by ``Store.add_frames``, as a session commits it (encode, checksum, insert, ledger entry, commit);
- by ``framelog.insert`` in a bare transaction: the same without the ledger entry;
and the checksum and the codec's ``encode`` are timed alone on the same batches. The integrity's
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

import shutil
import statistics
import tempfile
import time
from pathlib import Path

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
    """Measure (module docstring), write ``out/store.csv`` and return the table."""
    from microg.paths import protocol_file

    from . import framelog, ledger
    from .assignment import Participant
    from .inputs import open_inputs
    from .protocol import load_protocol
    from .session import SimulationClock, run_session
    from .store import check_integrity, create_study, open_study

    rows = []

    def note(measure: str, value: float, unit: str) -> None:
        rows.append({"measure": measure, "value": value, "unit": unit})
        say(f"{measure}: {value:.4g} {unit}")

    protocol = load_protocol(protocol_file("paper"))
    with tempfile.TemporaryDirectory(prefix="microg-bench-store-") as folder:
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
        note("compressed frame size", sum(map(len, blobs)) / frames, "bytes per frame")
        note("encode (the codec), per frame", 1e6 * _seconds(lambda: [framelog.encode(b) for b in batches]) / frames,
             "us")
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
        note("read: decode, per frame", 1e6 * decode / read_frames, "us")
        note("read: verification share of verify + decode", verify / (verify + decode), "ratio")
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
    table = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "store.csv", index=False)
    return table

