"""Reading what the view shows from a study's database, while a session may still be writing it.

The view opens the database read-only. Sessions commit frames in batches (``logging.frame_batch``,
64 frames, about 0.6 s) in WAL mode, so a reader in another process sees each committed batch
without ever blocking the session: following a live session is polling for frames after the last
one read (``Track.refresh``, through ``microg.study.framelog``). The view and the session share
nothing but the file. (The participant's own view does not wait for batches: the session pushes
every frame to it.)
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from microg.skeleton import SIDES
from microg.study import framelog
from microg.study.store import SessionRecord, Store, StoreError, open_study
from microg.task import KINDS, PICK_AND_PLACE

from .scene import FrameScene, both_sides, hand_values, place_states, rendered_bones, tracked_bones


def open_readonly(study_dir: str | Path) -> Store:
    """The study in ``study_dir``, opened read-only: the view never writes to a study. A damaged
    study is shown all the same (``Store.problems`` says what is wrong with it)."""
    return open_study(study_dir, readonly=True, accept_damaged=True)


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
    interaction: str
    object: str
    object_code: str
    status: str
    time_s: float | None
    attempts: int | None

    @property
    def title(self) -> str:
        """The task and run, e.g. ``task 2: stage1 long_cuboid (impulse_penetration)``."""
        return (f"task {self.task_index}" + (f" run {self.run}" if self.run > 1 else "")
                + f": {self.phase} {self.object} ({self.interaction})")

    @property
    def label(self) -> str:
        """The title and how the run ended (or ``running``)."""
        return f"{self.title}, {self.status}"


def session_runs(store: Store, session_id: int) -> list[RunInfo]:
    """The session's task runs that have frames or are still running, in the order they ran."""
    rows = store.db.execute("""
        SELECT r.id, r.session_id, s.participant_id, r.task_index, r.run, t.phase, t.interaction, t.object,
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


ATTEMPT_EVENTS = ("drop", "miss")
"""The events that count an attempt: a drop (a send's: a miss)."""


@dataclass
class Track:
    """The frames of one task run read so far, and its attempts; grows with ``refresh``."""

    run: RunInfo
    frames: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=framelog.FRAME))
    """The run's logged frames read so far (``framelog.FRAME`` records)."""
    times: list[float] = field(default_factory=list)
    attempt_times: list[float] = field(default_factory=list)
    """Frame times of the run's attempts (``ATTEMPT_EVENTS``), sorted."""

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
        """Read the frames committed since the last read, the run's status and its attempts; returns
        the number of new frames. The status is read first: a run's last frames commit together
        with its end, so frames read after a final status are all of them."""
        status = store.db.execute("SELECT status, time_s, attempts FROM task_runs WHERE id = ?",
                                  (self.run.id,)).fetchone()
        self.run = replace(self.run, status=status[0], time_s=status[1], attempts=status[2])
        new = framelog.read(store.db, self.run.id, len(self.frames))
        self.frames = np.concatenate([self.frames, new])
        self.times += new["t"].tolist()
        self.attempt_times = sorted(e.data.get("frame_t", e.t) for e in store.events(self.run.session_id, self.run.id)
                            if e.kind in ATTEMPT_EVENTS)
        return len(new)

    def scene(self, index: int, n_places: int) -> FrameScene:
        """What frame ``index`` shows."""
        f = self.frames[index]
        t, place, lit = float(f["t"]), int(f["place"]), bool(f["place_lit"])
        hands = [hand_values(f, side) for side in range(len(SIDES))]
        return FrameScene(
            t=t - self.start, stage=framelog.stage_names()[f["stage"]], place=place, place_lit=lit,
            place_timer=float(f["place_timer"]), held=bool(f["held"]),
            attempts=bisect.bisect_right(self.attempt_times, t + 1e-9), object_position=f["position"].astype(np.float64),
            object_orientation=f["orientation"].astype(np.float64),
            tracked=both_sides([tracked_bones(h) for h in hands]), rendered=both_sides([rendered_bones(h) for h in hands]),
            touching=framelog.touching_slots(f["touching"]), places=place_states(place, lit, n_places))


def read_track(store: Store, run: RunInfo) -> Track:
    """Every frame of ``run`` committed so far."""
    track = Track(run)
    track.refresh(store)
    return track


@dataclass(frozen=True)
class KeyMoment:
    """A frame worth a picture, and what happens there."""

    label: str
    index: int




def key_moments(track: Track, n_places: int, kind: str = PICK_AND_PLACE) -> list[KeyMoment]:
    """The task's key moments, as in the paper's Figs. 7 and 9: the start, the pick-up (the first
    frame held), each place just before it is done (the last frame it is lit), the last release of a
    kind that sends the object off (the first frame after its last hold), and the end (as the
    kind's view labels it: released, caught, at rest ...; timed out or cut off). Moments the run
    never reached are left out."""
    frames = track.frames
    if not len(frames):
        return []
    moments = [KeyMoment("start", 0)]
    held = np.flatnonzero(frames["held"])
    view = KINDS[kind].view
    if len(held):
        moments.append(KeyMoment(view.taken, int(held[0])))
    for k in range(n_places):
        lit = np.flatnonzero((frames["place"] == k) & frames["place_lit"])
        if len(lit):
            moments.append(KeyMoment(f"place {k + 1}", int(lit[-1])))
    if KINDS[kind].play.then == "push" and len(held) and held[-1] + 1 < len(frames):
        moments.append(KeyMoment("let go", int(held[-1]) + 1))
    last = len(frames) - 1
    end = {"completed": view.done, "timeout": "timed out"}.get(framelog.stage_names()[frames["stage"][-1]], "last frame")
    if all(m.index != last for m in moments):
        moments.append(KeyMoment(end, last))
    return moments
