"""The session runner: a state machine over the protocol's timeline and each task's stages.

``run_session`` walks the participant's timeline (orientation, instructions, training for the
groups that train, the phases of tasks, the questionnaire) and carries on from wherever the session stands:
phases already ended, tasks already finished and questions already answered are not repeated, so
the same call starts a session and resumes it. ``resume_session`` first marks runs cut off by a
crash as interrupted (their frames stay), then runs the session on: an interrupted task runs
again from its start.

Each task gets its own world holding only the task's object at its start pose (moving as the
phase's task kind starts it: a catch's launch, a stop of a spin's spin), under the protocol's
gravity and the phase's interaction model, and is judged by its kind's rules; with a
``table_height`` the object stands
on a table (the physics' ``table`` effect) and falls back onto it when dropped. One frame goes
one way (``run_task``), as in the paper's Fig. 2: the task's hand source, the tracking guard and
the window filter (``microg.hands.tracking``), the physics (``microg.sim.step``), the task's rules
and respawn (``microg.task.play``), then what the frame feeds, each a ``FrameSink``: the run's log
(events committed as their frames arrive, frames every ``frame_batch``), the participant's page, LSL's
MoCap stream, the progress bar. Every event the session logs goes through one call
(``EventLog``): committed, then sent as an LSL marker stamped with its own time.

Clocks are injected: ``WallClock`` for live sessions, ``SimulationClock`` (which advances with
the frames' timestamps) otherwise. Task times always come from the frames' timestamps.
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time
import typing
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from tqdm import tqdm

from microg.participant.plan import TaskPlan
from microg.participant.runner import Players, run
from microg.sim import World, make_world
from microg.task import COMPLETED, KINDS, MOMENT, Lanes, Moments, TaskResult, TaskRules, play
from microg.task.rules import timeout_reason

from . import framelog
from .inputs import Inputs, participant_plan
from .protocol import Phase, Protocol
from .questionnaire import Rater, questions
from .simulated_rater import HANDLING, HANDLING_KEYS, handling
from .progression import FinishedTask, Progress, next_difficulty, progress
from .store import Event, PlannedTask, Store, criterion_first_index, criterion_task, derived_seed


class Clock(typing.Protocol):
    name: str

    def now(self) -> float: ...

    def elapse(self, seconds: float) -> None:
        """Simulated time passed (a wall clock ignores it)."""

    def elapse_each(self, intervals: np.ndarray) -> np.ndarray:
        """``elapse`` each of ``intervals`` in turn (a frame's, the runner's); the clock's reading after each."""


@dataclass
class WallClock:
    """Seconds on the wall clock since the session started (carried on across a resume)."""

    offset: float = 0.0
    name: str = "wall"
    _start: float = field(default_factory=time.monotonic)

    def now(self) -> float:
        return self.offset + time.monotonic() - self._start

    def monotonic(self, t: float) -> float:
        """The ``time.monotonic`` reading at which this clock read ``t``."""
        return t - self.offset + self._start

    def elapse(self, seconds: float) -> None:
        pass

    def elapse_each(self, intervals: np.ndarray) -> np.ndarray:
        return np.full(len(intervals), self.now())


@dataclass
class SimulationClock:
    """Simulated seconds since the session started: advances only with the frames."""

    t: float = 0.0
    name: str = "simulation"

    def now(self) -> float:
        return self.t

    def elapse(self, seconds: float) -> None:
        self.t += seconds

    def elapse_each(self, intervals: np.ndarray) -> np.ndarray:
        """Each interval added in turn, as frame after frame (numpy's accumulate adds left to right)."""
        readings = np.add.accumulate(np.concatenate(([self.t], intervals)))[1:]
        if len(readings):
            self.t = float(readings[-1])
        return readings


STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))
"""What stops a long-running command (a session, the view): Ctrl-C, a process manager (SIGTERM), a
closed terminal (SIGHUP)."""


@contextlib.contextmanager
def handling_stop_signals(handler):
    """While inside, ``STOP_SIGNALS`` call ``handler(number, frame)``; the handlers before come back
    after. Only the main thread may handle signals: elsewhere nothing is installed."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {number: signal.signal(number, handler) for number in STOP_SIGNALS}
    try:
        yield
    finally:
        for number, before in previous.items():
            signal.signal(number, before)


def make_clock(kind: str, start: float = 0.0) -> Clock:
    return WallClock(offset=start) if kind == "wall" else SimulationClock(t=start)


class Operator(typing.Protocol):
    """The researcher's side of a session."""

    def present(self, phase: Phase) -> None:
        """Present an orientation or instructions phase (returns when it is over)."""

    def ready(self, task: PlannedTask) -> bool:
        """Before a task: True to run it, False to skip it (recorded as skipped)."""

    def finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        """After a task (completed, timeout, aborted or skipped)."""

    def progressed(self, text: str) -> None:
        """After a task of a phase trained to a criterion: how far the participant is."""


class Unattended:
    """No researcher at the keyboard (replayed and simulated sessions): run everything."""

    def present(self, phase: Phase) -> None:
        pass

    def ready(self, task: PlannedTask) -> bool:
        return True

    def finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        pass

    def progressed(self, text: str) -> None:
        pass


class FrameSink(typing.Protocol):
    """What a frame feeds (the run's log, the participant's page, LSL's MoCap stream, a progress
    bar): it takes the frames the physics and the task's rules made (``microg.task.Moments``: one
    source frame's, or a simulated participant's batch), in order."""

    def take(self, moments: Moments) -> None: ...


class Markers(typing.Protocol):
    """Receives every event the session logs, once it is committed (an LSL marker outlet,
    ``microg.study.lsl.MarkerOutlet``, which stamps the marker with the event's own time)."""

    def mark(self, event: Event) -> None: ...


@dataclass(frozen=True)
class Outputs:
    """What a session feeds besides its log: every frame's moment to ``sinks`` (the participant's
    page, LSL's MoCap stream), every event to ``markers``, and a progress bar when ``progress``."""

    sinks: tuple[FrameSink, ...] = ()
    markers: Markers | None = None
    progress: bool = False


@dataclass(frozen=True)
class EventLog:
    """The one way a session logs an event: committed to the store, then sent as a marker."""

    store: Store
    session_id: int
    clock: Clock
    markers: Markers | None = None

    def emit(self, kind: str, data: dict, run_id: int | None = None) -> None:
        """Log one event now."""
        self.commit([Event(self.clock.now(), kind, data)], run_id)

    def commit(self, events: list[Event], run_id: int | None = None) -> None:
        """Log events in one transaction."""
        if events:
            self.store.log(self.session_id, events, run_id)
            self.mark(events)

    def mark(self, events: Sequence[Event]) -> None:
        """Send events the store committed itself (a run's start and end) as markers."""
        if self.markers:
            for event in events:
                self.markers.mark(event)


# ---------------------------------------------------------------- one task


def task_world(protocol: Protocol, task: PlannedTask, rules: TaskRules | None = None) -> World:
    """The task's object alone at its start pose (on the table, if there is one), moving as the
    phase's task kind starts it by ``rules`` (default: the phase's), under the phase's interaction model."""
    return make_world(protocol.scene(task.object, task.interaction, protocol.kind(task.phase), rules))


class RunLog:
    """A ``FrameSink``: what a run logs of its frames. The session's clock moves on by each frame's
    interval, the task's events are committed as their frames arrive (a live source's as they
    happen, a compiled simulated participant's a batch at once), and the frames every ``batch``
    (``framelog``), so a crash loses at most one batch of frames and no event of a frame stored."""

    def __init__(self, log: EventLog, run_id: int, batch: int):
        self.log, self.run_id, self.batch = log, run_id, batch
        self.logged, self.pending, self.last_t = 0, [], None
        self.frames, self.kind = 0, None
        self.handled, self.last_frame = np.zeros(len(HANDLING_KEYS)), None

    def take(self, moments: Moments) -> None:
        times = moments.records["hands"]["t"]
        previous = times[0] if self.last_t is None else self.last_t
        now = self.log.clock.elapse_each(np.diff(np.concatenate(([previous], times))))
        self.last_t = float(times[-1])
        self.log.commit([Event(float(now[i]), e.kind, dict(e.data, frame_t=e.t))
                         for i in np.flatnonzero(moments.records["n_events"]) for e in moments.task_events(int(i))],
                        self.run_id)
        self.kind = moments.kind
        self.pending.append(moments.records)
        self.frames += len(moments)
        if self.frames - self.logged >= self.batch:
            waiting = np.concatenate(self.pending)
            whole = (len(waiting) // self.batch) * self.batch
            for first in range(0, whole, self.batch):
                self.log.store.add_frames(self.run_id, self.logged, self._frames(waiting[first:first + self.batch]))
                self.logged += self.batch
            self.pending = [waiting[whole:]]

    def _frames(self, records: np.ndarray) -> np.ndarray:
        """``records`` (``MOMENT``) as the frame log keeps them, added to the run's ``handling``."""
        frames = framelog.frames_of(Moments(self.kind, records, None))
        if len(frames):
            self.handled += handling(frames, self.last_frame)
            self.last_frame = frames[-1:]
        return frames

    def end(self, status: str, *, time_s: float | None, attempts: int | None, reason: str | None,
            events: list[Event] = ()) -> None:
        """Close the run with its last frames, its result and ``events`` (then the end event). A run
        cut off (Ctrl-C, SIGTERM) just as a batch was committed has that batch stored already: only
        what the store does not hold goes in."""
        stored = framelog.count(self.log.store.db, self.run_id)
        waiting = np.concatenate(self.pending) if self.pending else np.zeros(0, MOMENT)
        rest = self._frames(waiting[stored - self.logged:]) if self.kind else np.zeros(0, framelog.FRAME)
        if stored == self.logged:  # every frame went through _frames: the run's handling is whole
            events = [*events, Event(self.log.clock.now(), HANDLING, dict(zip(HANDLING_KEYS, self.handled.tolist())))]
        self.log.mark(self.log.store.end_run(self.run_id, status, self.log.clock.now(), time_s=time_s,
                                             attempts=attempts, reason=reason, events=list(events),
                                             frames=(stored, rest)))


class TaskProgress:
    """A ``FrameSink``: the task's frame count and rate on the session's progress bar."""

    def __init__(self, bar, label: str):
        self.bar, self.label, self.frames, self.started, self.shown = bar, label, 0, time.monotonic(), 0

    def take(self, moments: Moments) -> None:
        self.frames += len(moments)
        if self.frames - self.shown >= 110:
            self.shown = self.frames
            rate = self.frames / max(time.monotonic() - self.started, 1e-9)
            self.bar.set_postfix_str(f"{self.label}: {self.frames} frames, {rate:.0f} fps")


COMPILED_BATCH = 1024
"""Frames a simulated participant playing in compiled code (unwatched: a watched one is paced,
frame by frame) plays between two looks from Python, and its run logs in one batch: a crash
loses at most this many frames of a run the participant's seed plays again exactly, and each
batch's fixed costs (the checksum, the commit, the codec's setup) are paid sixteen times less
often than at the default ``logging.frame_batch``."""


def run_task(*, log: EventLog, run_id: int, world: World, source, protocol: Protocol,
             rules: TaskRules | None = None, sinks: Sequence[FrameSink] = ()) -> TaskResult:
    """Play one task from ``source`` until it completes, times out or the source ends; log every
    frame and event, and feed every frame to ``sinks``. ``rules``: the protocol's task unless given
    (a phase's: ``Protocol.rules``). A simulated participant that can play in compiled code
    (``load_into``) plays there, its frames taken ``COMPILED_BATCH`` at a time. A finished task of a kind with
    measures of its own logs them as its run's last event but the guard's (``measures``: the kind
    and each measure).

    An exception (or Ctrl-C) ends the run as interrupted, with every frame so far, and goes on up.
    """
    rules = rules or protocol.task
    kind = KINDS[rules.kind]
    compiled = hasattr(source, "load_into")
    batch = max(protocol.frame_batch, COMPILED_BATCH) if compiled else protocol.frame_batch
    lanes = Lanes(kind, world, 1, guard=protocol.guard, window=protocol.filter_window, capacity=batch)
    lanes.load(0, world, rules)
    run_log = RunLog(log, run_id, batch)
    frames = _played(lanes, source, batch) if compiled else play(lanes, source)
    try:
        for moments in frames:              # hands: guard, Eq. 1; sim: step (Eqs. 2-20); task: the rules, respawn
            run_log.take(moments)           # study: the run's events and frames
            for sink in sinks:              # view: the participant's page; LSL; progress
                sink.take(moments)
    except BaseException as error:
        run_log.end("interrupted", time_s=None, attempts=int(lanes.tasks[0]["attempts"]),
                    reason=f"{type(error).__name__}: {error}" if str(error) else type(error).__name__)
        raise
    finally:
        source.close()
    result = lanes.result(0, run_log.frames)
    reason = {COMPLETED: None, "timeout": timeout_reason(rules),
              "aborted": f"the hand source ({source.description}) ended before the task did"}[result.status]
    ending = [Event(log.clock.now(), "measures", {"kind": rules.kind, **result.measures})] if result.measures else []
    run_log.end(result.status, time_s=result.time_s, attempts=result.attempts, reason=reason,
                events=ending + [Event(log.clock.now(), "tracking_guard", lanes.counts_of(0).as_dict())])
    return result


def _played(lanes: Lanes, source, batch: int):
    """The frames of a simulated participant playing lane 0 in compiled code (``microg.participant.runner``),
    a batch at a time (the session commits the batch's events together, then its frames)."""
    players = Players(lanes.kind, 1)
    source.load_into(players, 0)
    while not players.ended[0]:
        run(lanes, players, batch)
        if lanes.n_frames[0]:
            yield lanes.taken(0)


# ---------------------------------------------------------------- the session


def run_session(store: Store, session_id: int, inputs: Inputs, *, clock: Clock, operator: Operator | None = None,
                rater: Rater | None = None, outputs: Outputs = Outputs()) -> str:
    """Run (or carry on) a session to its end; returns the session's status (``completed``, or
    ``incomplete`` when a task was aborted or skipped: ``Store.finish_session``)."""
    operator = operator or Unattended()
    protocol = store.protocol
    session = store.session(session_id)
    if session.status != "running":
        raise ValueError(f"session {session_id} is {session.status}; only a running session can go on")
    store.commit_for(session.simulated)
    log = EventLog(store, session_id, clock, outputs.markers)
    participant = store.participant(session.participant_id)
    started_phases = {e.data["phase"] for e in store.events(session_id) if e.kind == "phase_start"}
    ended_phases = {e.data["phase"] for e in store.events(session_id) if e.kind == "phase_end"}
    finished = store.finished_tasks(session_id)
    earlier = earlier_sessions(store, session)
    bar = tqdm(total=len(store.tasks(session_id)), initial=len(finished), unit="task",
               desc=f"{participant.id} ({participant.group})", disable=not outputs.progress, leave=True)
    try:
        for phase in protocol.phases_for(participant.group, session.name):
            if phase.name in ended_phases:
                continue
            if phase.name not in started_phases:
                log.emit("phase_start", {"phase": phase.name})
            if phase.instruments:
                _questionnaire(store, session_id, rater=rater, clock=clock, protocol=protocol, phase=phase)
            elif protocol.runs_tasks(phase) and _trained_to_criterion(protocol, phase.name):
                _train(log, session, participant, phase, inputs, earlier=earlier, operator=operator,
                       sinks=outputs.sinks, bar=bar)
            elif protocol.runs_tasks(phase):
                for task, plan, seed in planned_runs(protocol, session, participant=participant,
                                                     tasks=store.tasks(session_id), phase=phase, earlier=earlier):
                    if task.index not in finished:
                        _run_planned(log, session, task, inputs, plan=plan, seed=seed, operator=operator,
                                     sinks=outputs.sinks, bar=bar)
                        finished.add(task.index)
                        bar.update(1)
            else:
                operator.present(phase)
            log.emit("phase_end", {"phase": phase.name})
    finally:
        bar.close()
    return store.finish_session(session_id, clock.now())


def planned_runs(protocol: Protocol, session, *, participant, tasks: list[PlannedTask], phase: Phase,
                 earlier: tuple[tuple[float, int], ...] = ()) -> list[tuple[PlannedTask, TaskPlan, int]]:
    """The tasks of a task ``phase`` of a session, in the order it runs them, each with what its
    player knows of it and the run's seed (``planned_run``)."""
    return [planned_run(protocol, session, participant=participant, tasks=tasks, task=task, earlier=earlier)
            for task in tasks if task.phase == phase.name]


def planned_run(protocol: Protocol, session, *, participant, tasks: list[PlannedTask], task: PlannedTask,
                earlier: tuple[tuple[float, int], ...] = ()) -> tuple[PlannedTask, TaskPlan, int]:
    """``task`` with what its player knows of it (``participant_plan``: the participant's hand and
    own seed, the tasks of the session before it, whether none of them had the object, the rules of
    its difficulty, the ``earlier`` sessions' practice) and the run's seed."""
    hand = "left" if participant.participant.handedness == "left" else "right"
    before = [t for t in tasks if t.index < task.index]
    plan = participant_plan(protocol, task, hand, session.participant_id, participant_seed=participant.seed,
                            first_with_object=all(t.object != task.object for t in before), tasks_done=len(before),
                            earlier_sessions=earlier)
    return task, plan, derived_seed(session.seed, task.index)


def earlier_sessions(store: Store, session) -> tuple[tuple[float, int], ...]:
    """The participant's sessions before ``session``, oldest first, as the simulated participant's
    practice reads them (``TaskPlan.earlier_sessions``): the days from each to this one and the
    tasks done in it (tasks whose last run measured the participant: completed or timed out)."""
    done = []
    for before in store.sessions_of(session.participant_id)[:session.index - 1]:
        counts = store.task_counts(before.id)
        done.append((float((session.date - before.date).days), counts["completed"] + counts["timeout"]))
    return tuple(done)


def _trained_to_criterion(protocol: Protocol, phase: str) -> bool:
    task_phase = protocol.phase(phase)
    return task_phase is not None and task_phase.until is not None


def _train(log: EventLog, session, participant, phase: Phase, inputs: Inputs, *,
           earlier: tuple[tuple[float, int], ...], operator: Operator, sinks: Sequence[FrameSink], bar) -> None:
    """A phase trained to a criterion: its task again, the protocol's objects in turn (each at the
    staircase's next value, if it has one), until the criterion is met or ``max_tasks`` ran; after
    each task the participant hears how far they are (``Operator.progressed``), and the end logs
    ``criterion_met`` or ``criterion_bound``. A resumed session carries on from its finished tasks."""
    store = log.store
    while (task := next_criterion_task(store, session, participant, phase.name)) is not None:
        tasks = store.tasks(session.id)
        bar.total = max(bar.total, len(tasks))  # a task planned now
        _, plan, seed = planned_run(store.protocol, session, participant=participant, tasks=tasks, task=task,
                                    earlier=earlier)
        _run_planned(log, session, task, inputs, plan=plan, seed=seed, operator=operator, sinks=sinks, bar=bar)
        bar.update(1)
        reached = criterion_progress(store, session.id, phase.name)
        log.emit("criterion_progress", {"phase": phase.name, "task_in_phase": reached.tasks,
                                        "in_a_row": reached.in_a_row, "consecutive": reached.needed})
        operator.progressed(reached.describe())
    ended = criterion_end(store, session.id, phase.name)
    if ended is not None:
        log.emit(*ended)


def next_criterion_task(store: Store, session, participant, phase: str) -> PlannedTask | None:
    """The next task of a phase trained to a criterion (None: the criterion is met or the bound ran):
    one planned before and not yet finished (a resumed session), or one planned now at the
    staircase's next value and added to the session. Logged sessions and in-silico studies both
    take their criterion phases' tasks from here."""
    protocol = store.protocol
    trained = protocol.phase(phase)
    done = finished_tasks_of(store, session.id, phase)
    reached = progress(trained.until, done)
    if reached.met or reached.tasks >= trained.max_tasks:
        return None
    number = reached.tasks + 1
    task = next((t for t in store.tasks(session.id) if t.phase == phase and t.task_in_phase == number), None)
    if task is None:
        harder = KINDS[trained.kind].difficulty[trained.staircase.parameter].harder if trained.staircase else 1
        difficulty = None if trained.staircase is None else \
            next_difficulty(trained.staircase, trained.until, done, harder)
        first = criterion_first_index(protocol, participant.group, participant.object_order, session.name, phase)
        task = criterion_task(protocol, phase, first, number, difficulty)
        store.add_task(session.id, task)
    return task


def criterion_progress(store: Store, session_id: int, phase: str) -> Progress:
    """Where a phase trained to a criterion stands after the session's finished tasks of it."""
    return progress(store.protocol.phase(phase).until, finished_tasks_of(store, session_id, phase))


def criterion_end(store: Store, session_id: int, phase: str) -> tuple[str, dict] | None:
    """The event that ends a phase trained to a criterion (``criterion_met`` or ``criterion_bound``,
    with its data), or None when the session logged it already (a resumed session)."""
    reached = criterion_progress(store, session_id, phase)
    ended = "criterion_met" if reached.met else "criterion_bound"
    if any(e.kind == ended and e.data["phase"] == phase for e in store.events(session_id)):
        return None
    return ended, {"phase": phase, "tasks": reached.tasks, "task_in_phase": reached.met_at}


def finished_tasks_of(store: Store, session_id: int, phase: str) -> list[FinishedTask]:
    """The finished tasks of ``phase`` in a session, in order, by their last run (as progression reads them)."""
    rows = store.db.execute("""
        SELECT t.object_code, t.difficulty, r.status, r.time_s, r.attempts FROM tasks t
        JOIN task_runs r ON r.session_id = t.session_id AND r.task_index = t.task_index
        WHERE t.session_id = ? AND t.phase = ? AND r.status IN ('completed', 'timeout', 'aborted', 'skipped')
          AND r.run = (SELECT MAX(run) FROM task_runs x WHERE x.session_id = t.session_id
                       AND x.task_index = t.task_index)
        ORDER BY t.task_index""", (session_id, phase))
    return [FinishedTask(r["object_code"], r["status"] == "completed", r["time_s"], r["attempts"], r["difficulty"])
            for r in rows]


def _run_planned(log: EventLog, session, task: PlannedTask, inputs: Inputs, *, plan: TaskPlan, seed: int,
                 operator: Operator, sinks: Sequence[FrameSink], bar) -> TaskResult:
    store, clock = log.store, log.clock
    protocol = store.protocol
    if not operator.ready(task):
        run_id = store.begin_run(session.id, task=task, source="skipped by the operator", seed=seed, t=clock.now())
        log.mark(store.events(session.id, run_id))
        log.mark(store.end_run(run_id, "skipped", clock.now(), reason="skipped by the operator"))
        operator.finished(task, "skipped", None)
        return TaskResult("skipped", None, None, 0)
    world = task_world(protocol, task, plan.rules)
    source = inputs.open(plan, seed)
    run_id = store.begin_run(session.id, task=task, source=source.description, seed=seed, t=clock.now())
    log.mark(store.events(session.id, run_id))
    progress = TaskProgress(bar, f"{task.phase} {task.object_code} ({task.interaction})")
    result = run_task(log=log, run_id=run_id, world=world, source=source, protocol=protocol,
                      rules=plan.rules, sinks=(progress, *sinks))
    operator.finished(task, result.status, result.time_s)
    return result


def _questionnaire(store: Store, session_id: int, *, rater: Rater | None, clock: Clock, protocol: Protocol,
                   phase: Phase) -> None:
    """Ask a questionnaire phase's items that are not answered yet (a resumed session carries on at the
    first unanswered one), each committed as it is given, then confirmed to the rater."""
    if rater is None:
        store.log(session_id, [Event(clock.now(), "questionnaire_skipped", {"reason": "no rater for this session"})])
        return
    answered = store.answers(session_id)
    for question in questions(protocol, phase):
        if question.key not in answered:
            answer = rater.answer(question)
            store.save_answer(session_id, key=question.key, value=answer.value, source=rater.source, t=clock.now(),
                              response_time_s=answer.response_time_s)
            rater.saved(question)


def resume_session(store: Store, session_id: int, inputs: Inputs, *, clock: Clock, operator: Operator | None = None,
                   rater: Rater | None = None, outputs: Outputs = Outputs()) -> str:
    """Mark runs cut off by a crash as interrupted, log the resume with its provenance (its marker
    is where the markers' clock line breaks: ``microg.study.xdf``), run on."""
    from microg import __version__

    interrupted = store.interrupt_open_runs(session_id, clock.now())
    EventLog(store, session_id, clock, outputs.markers).emit("session_resume", {
        "interrupted_runs": interrupted, "input": inputs.spec, "microg_version": __version__})
    return run_session(store, session_id, inputs, clock=clock, operator=operator, rater=rater, outputs=outputs)

