"""Reading what the view shows from a study's database, while a session may still be writing it.

The view opens the database read-only. Sessions commit frames in batches (``logging.frame_batch``,
64 frames, about 0.6 s) in WAL mode, so a reader in another process sees each committed batch
without ever blocking the session: following a live session is polling for rows after the last
one read (``Track.refresh``). The view and the session share nothing but the file.
"""

from __future__ import annotations

import bisect
import sqlite3
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from microg.study.store import DATABASE, SessionRecord, Store, StoreError, hand_values

from .scene import FrameScene, both_sides, place_states, rendered_bones, split_hand, touching_slots, tracked_bones

_FRAME_QUERY = ("SELECT frame, t, stage, place, place_lit, place_timer, grasped, held, touching, px, py, pz, "
                "qw, qx, qy, qz, left, right FROM frames WHERE run_id = ? AND frame > ? ORDER BY frame")


def open_readonly(study_dir: str | Path) -> Store:
    """The study in ``study_dir``, opened read-only: the view never writes to a study."""
    study_dir = Path(study_dir)
    path = study_dir / DATABASE
    if not path.exists():
        raise StoreError(f"no study in {study_dir} (no {DATABASE}); create one with: microg study init {study_dir}")
    connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, isolation_level=None,
                                 timeout=30.0, check_same_thread=False)
    connection.row_factory = sqlite3.Row
    return Store(study_dir, connection)


def _sessions(store: Store) -> list[SessionRecord]:
    return [store.session(r[0]) for r in store.db.execute("SELECT id FROM sessions ORDER BY id")]


def _has_frames(store: Store, session_id: int) -> bool:
    return store.db.execute("SELECT 1 FROM frames f JOIN task_runs r ON r.id = f.run_id WHERE r.session_id = ? "
                            "LIMIT 1", (session_id,)).fetchone() is not None


def find_session(store: Store, spec: str | None) -> SessionRecord | None:
    """The session ``spec`` names: a participant id (their session) or a session number. Without a
    spec: the latest running session, else the latest session with frames. None when the session
    is still to come (a participant without a session yet, or a study without sessions): the
    view then waits for it."""
    sessions = _sessions(store)
    if spec is None:
        running = [s for s in sessions if s.status == "running"]
        logged = [s for s in sessions if _has_frames(store, s.id)]
        return (running or logged or [None])[-1]
    if store.db.execute("SELECT 1 FROM participants WHERE id = ?", (spec,)).fetchone():
        return store.session_of(spec)
    if spec.isdigit() and any(s.id == int(spec) for s in sessions):
        return store.session(int(spec))
    known = ", ".join(f"{s.id} ({s.participant_id}, {s.status})" for s in sessions) or "none yet"
    raise StoreError(f"--session {spec}: no participant or session {spec!r} in study {store.name!r} "
                     f"({store.dir}); sessions: {known}")


@dataclass(frozen=True)
class RunInfo:
    """One run of a task, with what names it."""

    id: int
    session_id: int
    participant: str
    task_index: int
    run: int
    phase: str
    system: str
    object: str
    object_code: str
    status: str
    time_s: float | None
    attempts: int | None

    @property
    def title(self) -> str:
        """The task and run, e.g. ``task 2: stage1 long_cuboid (impulse_penetration)``."""
        return (f"task {self.task_index}" + (f" run {self.run}" if self.run > 1 else "")
                + f": {self.phase} {self.object} ({self.system})")

    @property
    def label(self) -> str:
        """The title and how the run ended (or ``running``)."""
        return f"{self.title}, {self.status}"


def session_runs(store: Store, session_id: int) -> list[RunInfo]:
    """The session's task runs that have frames or are still running, in the order they ran."""
    rows = store.db.execute("""
        SELECT r.id, r.session_id, s.participant_id, r.task_index, r.run, t.phase, t.system, t.object,
               t.object_code, r.status, r.time_s, r.attempts
        FROM task_runs r JOIN tasks t ON t.session_id = r.session_id AND t.task_index = r.task_index
        JOIN sessions s ON s.id = r.session_id
        WHERE r.session_id = ? AND (r.status = 'running' OR EXISTS (SELECT 1 FROM frames f WHERE f.run_id = r.id))
        ORDER BY r.id""", (session_id,)).fetchall()
    return [RunInfo(*tuple(r)) for r in rows]


def find_run(store: Store, session: SessionRecord, task_index: int, run: int | None = None) -> RunInfo:
    """The run of task ``task_index`` (its last run with frames, or run number ``run``)."""
    runs = session_runs(store, session.id)
    chosen = [r for r in runs if r.task_index == task_index and (run is None or r.run == run)]
    if not chosen:
        known = "; ".join(r.label for r in runs) or "none"
        what = f"task {task_index}" + (f" run {run}" if run is not None else "")
        raise StoreError(f"session {session.id} ({session.participant_id}) has no logged {what}; "
                         f"its runs: {known}")
    return chosen[-1]


@dataclass
class Track:
    """The frames of one task run read so far, and its drops; grows with ``refresh``."""

    run: RunInfo
    rows: list[tuple] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    drops: list[float] = field(default_factory=list)
    """Frame times of the run's drops (``drop`` events), sorted."""

    @property
    def start(self) -> float:
        return self.times[0] if self.times else 0.0

    @property
    def duration(self) -> float:
        """Seconds from the first frame read to the last."""
        return self.times[-1] - self.times[0] if self.times else 0.0

    def index_at(self, seconds: float) -> int:
        """The last frame at or before ``seconds`` after the first one."""
        return max(0, bisect.bisect_right(self.times, self.start + seconds + 1e-9) - 1)

    def refresh(self, store: Store) -> int:
        """Read the frames committed since the last read, the run's status and its drops; returns
        the number of new frames. The status is read first: a run's last frames commit together
        with its end, so frames read after a final status are all of them."""
        status = store.db.execute("SELECT status, time_s, attempts FROM task_runs WHERE id = ?",
                                  (self.run.id,)).fetchone()
        self.run = replace(self.run, status=status[0], time_s=status[1], attempts=status[2])
        last = self.rows[-1][0] if self.rows else -1
        new = [tuple(r) for r in store.db.execute(_FRAME_QUERY, (self.run.id, last))]
        self.rows += new
        self.times += [r[1] for r in new]
        self.drops = sorted(e.data.get("frame_t", e.t) for e in store.events(self.run.session_id, self.run.id)
                            if e.kind == "drop")
        return len(new)

    def scene(self, index: int, n_places: int) -> FrameScene:
        """What frame ``index`` shows."""
        row = self.rows[index]
        _frame, t, stage, place, lit, timer, _grasped, held, mask = row[:9]
        hands = [split_hand(hand_values(blob)) for blob in row[16:18]]
        return FrameScene(
            t=t - self.start, stage=stage, place=place, place_lit=bool(lit), place_timer=timer, held=bool(held),
            attempts=bisect.bisect_right(self.drops, t + 1e-9), object_position=np.array(row[9:12]),
            object_orientation=np.array(row[12:16]), tracked=both_sides([tracked_bones(h) for h in hands]),
            rendered=both_sides([rendered_bones(h) for h in hands]), touching=touching_slots(mask),
            places=place_states(place, bool(lit), n_places))


def read_track(store: Store, run: RunInfo) -> Track:
    """Every frame of ``run`` committed so far."""
    track = Track(run)
    track.refresh(store)
    return track


@dataclass(frozen=True)
class Moment:
    """A frame worth a picture, and what happens there."""

    label: str
    index: int


def key_moments(track: Track, n_places: int) -> list[Moment]:
    """The task's key moments, as in the paper's Figs. 7 and 9: the start, the pick-up (the first
    frame held), each place just before it is done (the last frame it is lit), and the end
    (released, timed out or cut off). Moments the run never reached are left out."""
    if not track.rows:
        return []
    moments = [Moment("start", 0)]
    held = [i for i, r in enumerate(track.rows) if r[7]]
    if held:
        moments.append(Moment("picked up", held[0]))
    for k in range(n_places):
        lit = [i for i, r in enumerate(track.rows) if r[3] == k and r[4]]
        if lit:
            moments.append(Moment(f"place {k + 1}", lit[-1]))
    last = len(track.rows) - 1
    end = {"completed": "released", "timeout": "timed out"}.get(track.rows[-1][2], "last frame")
    if all(m.index != last for m in moments):
        moments.append(Moment(end, last))
    return moments
