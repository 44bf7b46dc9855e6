"""The session runner: a state machine over the protocol's timeline and each task's stages.

``run_session`` walks the participant's timeline (orientation, instructions, training for the
groups that train, the phases of tasks, the questionnaire) and carries on from wherever the session stands:
phases already ended, tasks already finished and questions already answered are not repeated, so
the same call starts a session and resumes it. ``resume_session`` first marks runs cut off by a
crash as interrupted (their frames stay), then runs the session on: an interrupted task runs
again from its start.

Each task gets its own world holding only the task's object at its start pose, under the
protocol's gravity and the phase's interaction model; with a ``table_height`` the object stands
on a table (the physics' ``table`` effect) and falls back onto it when dropped. Frames come from
the task's hand source; each one steps the physics, then the task's state machine
(``microg.task.stages``); an object that leaves the workspace while not held (drifting away in
microgravity, or off the table) goes back to its start, as the researcher would put it back.
Events are committed as they happen, frames every ``frame_batch``.

Clocks are injected: ``WallClock`` for live sessions, ``SimulationClock`` (which advances with
the frames' timestamps) otherwise. Task times always come from the frames' timestamps.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Protocol as Interface

from tqdm import tqdm

from microg.hands.filter import FILTER_WINDOW, HandFilter
from microg.sim import Scene, World, make_world
from microg.task import COMPLETED, Moment, TaskRules, TaskState, play

from . import framelog
from .inputs import Inputs, participant_plan
from .protocol import Phase, Protocol
from .questionnaire import Rater
from .store import Event, PlannedTask, Store, derived_seed

Markers = Callable[[str, dict], None]
"""Receives task and stage events as they happen (e.g. an LSL marker outlet): called right when the
session's clock is read for the event, before the event is committed, so that a marker's own time
(LSL's) is the event's and not the disk's."""


class Clock(Interface):
    name: str

    def now(self) -> float: ...

    def elapse(self, seconds: float) -> None:
        """Simulated time passed (the runner calls this per frame; a wall clock ignores it)."""


@dataclass
class WallClock:
    """Seconds on the wall clock since the session started (carried on across a resume)."""

    offset: float = 0.0
    name: str = "wall"
    _start: float = field(default_factory=time.monotonic)

    def now(self) -> float:
        return self.offset + time.monotonic() - self._start

    def elapse(self, seconds: float) -> None:
        pass


@dataclass
class SimulationClock:
    """Simulated seconds since the session started: advances only with the frames."""

    t: float = 0.0
    name: str = "simulation"

    def now(self) -> float:
        return self.t

    def elapse(self, seconds: float) -> None:
        self.t += seconds


def make_clock(kind: str, start: float = 0.0) -> Clock:
    return WallClock(offset=start) if kind == "wall" else SimulationClock(t=start)


class Operator(Interface):
    """The researcher's side of a session."""

    def show(self, phase: Phase) -> None:
        """Present an orientation or instructions phase (returns when it is over)."""

    def ready(self, task: PlannedTask) -> bool:
        """Before a task: True to run it, False to skip it (recorded as skipped)."""

    def finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        """After a task (completed, timeout, aborted or skipped)."""


class Unattended:
    """No researcher at the keyboard (replayed and simulated sessions): run everything."""

    def show(self, phase: Phase) -> None:
        pass

    def ready(self, task: PlannedTask) -> bool:
        return True

    def finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        pass


@dataclass(frozen=True)
class TaskResult:
    status: str
    """completed, timeout, aborted (the hand source ended) or skipped."""
    time_s: float | None
    attempts: int | None
    frames: int


# ---------------------------------------------------------------- one task


def task_world(protocol: Protocol, task: PlannedTask) -> World:
    """The task's object alone at its start pose (on the table, if there is one), under the phase's
    interaction model."""
    return make_world(protocol.scene(task.object, task.interaction))


def guarded(source, scene: Scene):
    """``source`` behind the tracking guard (``microg.hands.guard``), which drops incomplete
    hands and stale frames and bridges tracking glitches before the physics sees them; it expects
    the scene's frame rate and detects jumps as the scene's physics does."""
    from microg.hands.guard import GuardConfig, TrackingGuard

    return TrackingGuard(source, GuardConfig(nominal_rate=float(scene.tracking_rate),
                                             jump_distance=float(scene.jump_distance)))


def run_task(store: Store, session_id: int, run_id: int, world: World, source, rules: TaskRules, clock: Clock,
             markers: Markers | None = None, batch: int = 64, on_moment: Callable[[Moment], None] | None = None,
             filter_window: int = FILTER_WINDOW) -> TaskResult:
    """Play one task (``microg.task.play``) from ``source`` until it completes, times out or the
    source ends; log every frame and event. ``on_moment`` sees each frame's outcome as it happens
    (the participant's display, a progress bar).

    An exception (or Ctrl-C) ends the run as interrupted, with every frame so far, and goes on up.
    """
    state, logged, last_t = TaskState(), 0, None
    pending: list[Moment] = []
    smooth = HandFilter(filter_window, 1.0 / world.model.scene.tracking_rate)
    try:
        for moment in play(world, source, rules, smooth):
            state, t = moment.state, moment.frame.timestamp
            clock.elapse(0.0 if last_t is None else t - last_t)
            last_t = t
            events = [Event(clock.now(), e.kind, dict(e.data, frame_t=e.t)) for e in moment.events]
            if events:
                if markers:
                    for event in events:
                        markers(event.kind, event.data)
                store.log(session_id, events, run_id)
            pending.append(moment)
            if len(pending) == batch:
                store.add_frames(run_id, logged, framelog.frames_of(pending))
                logged, pending = logged + batch, []
            if on_moment:
                on_moment(moment)
    except BaseException as error:
        store.end_run(run_id, "interrupted", clock.now(), attempts=state.drops,
                      frames=(logged, framelog.frames_of(pending)),
                      reason=f"{type(error).__name__}: {error}" if str(error) else type(error).__name__)
        raise
    finally:
        source.close()
    frames = logged + len(pending)
    if state.finished:
        status = state.stage if state.stage == COMPLETED else "timeout"
        result = TaskResult(status, state.completion_time, state.drops, frames)
        reason = None if status == COMPLETED else f"not completed within task.timeout_s = {rules.timeout_s:g} s"
    else:
        result = TaskResult("aborted", None, state.drops, frames)
        reason = f"the hand source ({source.description}) ended before the task did"
    counts = getattr(source, "counts", None)
    ended = clock.now()
    if markers:
        markers("task_end", {"status": result.status, "time_s": result.time_s, "attempts": result.attempts})
    store.end_run(run_id, result.status, ended, time_s=result.time_s, attempts=result.attempts,
                  reason=reason, frames=(logged, framelog.frames_of(pending)),
                  events=[Event(ended, "tracking_guard", counts.as_dict())] if counts is not None else [])
    return result


# ---------------------------------------------------------------- the session


def run_session(store: Store, session_id: int, inputs: Inputs, *, clock: Clock, operator: Operator | None = None,
                rater: Rater | None = None, markers: Markers | None = None, progress: bool = True,
                on_moment: Callable[[Moment], None] | None = None) -> str:
    """Run (or carry on) a session to its end; returns the session's status (``completed``, or
    ``incomplete`` when a task was aborted or skipped: ``Store.finish_session``). ``on_moment``
    sees every frame's outcome as the physics computes it (the participant's display)."""
    operator = operator or Unattended()
    protocol = store.protocol
    session = store.session(session_id)
    if session.status != "running":
        raise ValueError(f"session {session_id} is {session.status}; only a running session can go on")
    store.commit_for(session.simulated)
    participant = store.participant(session.participant_id)
    tasks = store.tasks(session_id)
    task_phases = {p.name for p in protocol.phases}
    started_phases = {e.data["phase"] for e in store.events(session_id) if e.kind == "phase_start"}
    ended_phases = {e.data["phase"] for e in store.events(session_id) if e.kind == "phase_end"}
    finished = store.finished_tasks(session_id)
    bar = tqdm(total=len(tasks), initial=len(finished), unit="task", desc=f"{participant.id} ({participant.group})",
               disable=not progress, leave=True)
    try:
        for phase in protocol.phases_for(participant.group):
            if phase.name in ended_phases:
                continue
            if phase.name not in started_phases:
                now = clock.now()
                if markers:
                    markers("phase_start", {"phase": phase.name})
                store.log(session_id, [Event(now, "phase_start", {"phase": phase.name})])
            if phase.name == "questionnaire":
                _questionnaire(store, session_id, rater, clock, protocol)
            elif phase.name == "training" or phase.name in task_phases:
                for task in tasks:
                    if task.phase == phase.name and task.index not in finished:
                        _run_planned(store, session, task, inputs, clock, operator, markers, bar, on_moment)
                        finished.add(task.index)
                        bar.update(1)
            else:
                operator.show(phase)
            now = clock.now()
            if markers:
                markers("phase_end", {"phase": phase.name})
            store.log(session_id, [Event(now, "phase_end", {"phase": phase.name})])
    finally:
        bar.close()
    return store.finish_session(session_id, clock.now())


def _run_planned(store: Store, session, task: PlannedTask, inputs: Inputs, clock: Clock, operator: Operator,
                 markers: Markers | None, bar, on_moment: Callable[[Moment], None] | None) -> TaskResult:
    protocol = store.protocol
    seed = derived_seed(session.seed, task.index)
    label = f"{task.phase} {task.object_code} ({task.interaction})"
    if not operator.ready(task):
        run_id = store.begin_run(session.id, task, "skipped by the operator", seed, clock.now())
        store.end_run(run_id, "skipped", clock.now(), reason="skipped by the operator")
        operator.finished(task, "skipped", None)
        return TaskResult("skipped", None, None, 0)
    hand = "left" if store.participant(session.participant_id).participant.handedness == "left" else "right"
    world = task_world(protocol, task)
    source = guarded(inputs.open(participant_plan(protocol, task, hand, session.participant_id), seed),
                     world.model.scene)
    now = clock.now()
    if markers:
        markers("task_start", {"task": task.index, "phase": task.phase, "interaction": task.interaction,
                               "object": task.object})
    run_id = store.begin_run(session.id, task, source.description, seed, now)
    started = time.monotonic()

    frames = 0

    def show(moment: Moment) -> None:
        nonlocal frames
        frames += 1
        if frames % 110 == 0:
            bar.set_postfix_str(f"{label}: {frames} frames, {frames / max(time.monotonic() - started, 1e-9):.0f} fps")
        if on_moment:
            on_moment(moment)

    result = run_task(store, session.id, run_id, world, source, protocol.task, clock, markers, protocol.frame_batch,
                      show, protocol.filter_window)
    operator.finished(task, result.status, result.time_s)
    return result


def _questionnaire(store: Store, session_id: int, rater: Rater | None, clock: Clock, protocol: Protocol) -> None:
    questionnaire = protocol.questionnaire
    if rater is None:
        store.log(session_id, [Event(clock.now(), "questionnaire_skipped", {"reason": "no rater for this session"})])
        return
    answered = store.answers(session_id)
    for phase in protocol.phases:
        for item in questionnaire.items:
            if (phase.interaction, item.name) not in answered:
                rating = rater.rate(item, phase, questionnaire)
                store.save_answer(session_id, phase.interaction, item.name, rating, rater.source, clock.now())


def resume_session(store: Store, session_id: int, inputs: Inputs, **options) -> str:
    """Mark runs cut off by a crash as interrupted, log the resume with its provenance, run on."""
    from microg import __version__

    clock = options["clock"]
    interrupted = store.interrupt_open_runs(session_id, clock.now())
    if options.get("markers"):  # where the markers' clock line breaks (``microg.study.xdf``)
        options["markers"]("session_resume", {"interrupted_runs": interrupted})
    store.log(session_id, [Event(clock.now(), "session_resume", {
        "interrupted_runs": interrupted, "input": inputs.spec, "microg_version": __version__})])
    return run_session(store, session_id, inputs, **options)

