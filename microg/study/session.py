"""The session runner: a state machine over the protocol's timeline and each task's stages.

``run_session`` walks the participant's timeline (orientation, instructions, training for the
groups that train, the stages, the questionnaire) and carries on from wherever the session stands:
phases already ended, tasks already finished and questions already answered are not repeated, so
the same call starts a session and resumes it. ``resume_session`` first marks runs cut off by a
crash as interrupted (their frames stay), then runs the session on: an interrupted task runs
again from its start.

Each task gets its own world holding only the task's object at its start pose, under the
protocol's gravity and the stage's interaction model; with a ``table_height`` the object stands
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

import numpy as np
from tqdm import tqdm

from microg.sim import HandFrame, PlacedObject, Scene, TableParameters, World, compose_scene, grasped, make_world, \
    rendered_phalanges, step, touching
from microg.hands.filter import HandFilter
from microg.sim.hand import BONES_PER_HAND, SIDES
from microg.participant import TaskDisplay

from .inputs import Inputs, participant_plan
from microg.task.rules import TaskRules

from .protocol import FILTER_WINDOW, Phase, Protocol
from .questionnaire import Rater
from microg.task.stages import COMPLETED, Observation, TaskState, advance
from .store import Event, PlannedTask, Store, derived_seed

Markers = Callable[[str, dict], None]
"""Receives task and stage events as they happen (e.g. an LSL marker outlet)."""


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


class Unattended:
    """No researcher at the keyboard (replayed and simulated sessions): run everything."""

    def show(self, phase: Phase) -> None:
        pass

    def ready(self, task: PlannedTask) -> bool:
        return True


@dataclass(frozen=True)
class TaskResult:
    status: str
    """completed, timeout, aborted (the hand source ended) or skipped."""
    time_s: float | None
    attempts: int | None
    frames: int


# ---------------------------------------------------------------- one task


def task_world(protocol: Protocol, task: PlannedTask) -> World:
    """The task's object alone at its start pose (on the table, if there is one), under the stage's
    interaction model."""
    position, orientation = protocol.start_pose(task.object)
    placed = PlacedObject(protocol.object(task.object).spec, position, orientation)
    table = None if protocol.table_height is None else TableParameters(height=protocol.table_height)
    return make_world(compose_scene([placed], task.system, protocol.gravity, table=table, **protocol.scene_options))


def put_back(world: World, rules: TaskRules, state: TaskState, start) -> tuple[World, list[Event]]:
    """Bring an object that left the workspace while not held back to its start pose, at rest."""
    position = world.data.position[0]
    inside = all(lo <= p <= hi for lo, p, hi in zip(rules.workspace_min, position, rules.workspace_max))
    if inside or state.held:
        return world, []
    data = world.data.copy()
    data.position[0], data.orientation[0] = start
    data.velocity[0] = 0.0
    data.angular_velocity[0] = 0.0
    return World(world.model, data), [Event(world.time, "respawn", {"position": [float(v) for v in position]})]


@dataclass
class TaskBoard:
    """What the task shows the participant right now: the stage, the current place, whether its
    mark is lit and its timer. The runner updates it every frame; a simulated participant reads it."""

    display: TaskDisplay = field(default_factory=TaskDisplay)

    def read(self) -> TaskDisplay:
        return self.display

    def show(self, state: TaskState, t: float) -> None:
        self.display = TaskDisplay(state.stage, state.place, state.lit_since is not None, state.place_timer(t))


def _hand_blob(frame: HandFrame, rendered: np.ndarray, side: int) -> bytes | None:
    hand = frame.hand(SIDES[side])
    if hand is None:
        return None
    slots = slice(side * BONES_PER_HAND, (side + 1) * BONES_PER_HAND)
    values = np.concatenate([hand.joints.ravel(), hand.widths.ravel(), hand.palm_position, hand.palm_orientation,
                             rendered[slots].ravel()])
    return values.astype("<f8").tobytes()


def frame_row(run_id: int, index: int, frame: HandFrame, world: World, state: TaskState, is_grasped: bool) -> tuple:
    """One row of the ``frames`` table (layout in ``microg.study.store``)."""
    d = world.data
    rendered = rendered_phalanges(world)
    mask = sum(1 << int(k) for k in np.flatnonzero(touching(world)[:, 0]))
    t = frame.timestamp
    return (run_id, index, t, state.stage, state.place, int(state.lit_since is not None), state.place_timer(t),
            int(is_grasped), int(state.held), mask, *map(float, d.position[0]), *map(float, d.orientation[0]),
            *map(float, d.velocity[0]), *map(float, d.angular_velocity[0]),
            _hand_blob(frame, rendered, 0), _hand_blob(frame, rendered, 1))


def guarded(source, scene: Scene):
    """``source`` behind the tracking guard (``microg.hands.guard``), which drops incomplete
    hands and stale frames and bridges tracking glitches before the physics sees them; it expects
    the scene's frame rate and detects jumps as the scene's physics does."""
    from microg.hands.guard import GuardConfig, TrackingGuard

    return TrackingGuard(source, GuardConfig(nominal_rate=float(scene.tracking_rate),
                                             jump_distance=float(scene.jump_distance)))


def run_task(store: Store, session_id: int, run_id: int, world: World, source, rules: TaskRules, clock: Clock,
             markers: Markers | None = None, batch: int = 64, on_frame: Callable[[int], None] | None = None,
             board: TaskBoard | None = None, filter_window: int = FILTER_WINDOW) -> TaskResult:
    """Drive one task from ``source`` until it completes, times out or the source ends; log it all.

    An exception (or Ctrl-C) ends the run as interrupted, with every frame so far, and goes on up.
    """
    state = TaskState()
    smooth = HandFilter(filter_window, 1.0 / world.model.scene.tracking_rate)
    start = (world.data.position[0].copy(), world.data.orientation[0].copy())
    buffer: list[tuple] = []
    index, last_t = 0, None
    try:
        while not state.finished:
            frame = source.next_frame(world)
            if frame is None:
                break
            world = step(world, smooth(frame))
            is_grasped = bool(grasped(world)[0])
            clock.elapse(0.0 if last_t is None else frame.timestamp - last_t)
            last_t = frame.timestamp
            state, task_events = advance(state, Observation(frame.timestamp, is_grasped,
                                                            tuple(world.data.position[0])), rules)
            if board is not None:
                board.show(state, frame.timestamp)
            world, support_events = put_back(world, rules, state, start)
            events = [Event(clock.now(), e.kind, dict(e.data, frame_t=e.t)) for e in task_events] + \
                     [Event(clock.now(), e.kind, dict(e.data, frame_t=frame.timestamp)) for e in support_events]
            if events:
                store.log(session_id, events, run_id)
                if markers:
                    for event in events:
                        markers(event.kind, event.data)
            buffer.append(frame_row(run_id, index, frame, world, state, is_grasped))
            index += 1
            if len(buffer) >= batch:
                store.add_frames(buffer)
                buffer = []
            if on_frame:
                on_frame(index)
    except BaseException as error:
        store.end_run(run_id, "interrupted", clock.now(), attempts=state.drops, frames=buffer,
                      reason=f"{type(error).__name__}: {error}" if str(error) else type(error).__name__)
        raise
    finally:
        source.close()
    if state.finished:
        status = state.stage if state.stage == COMPLETED else "timeout"
        result = TaskResult(status, state.completion_time, state.drops, index)
        reason = None if status == COMPLETED else f"not completed within task.timeout_s = {rules.timeout_s:g} s"
    else:
        result = TaskResult("aborted", None, state.drops, index)
        reason = f"the hand source ({source.description}) ended before the task did"
    counts = getattr(source, "counts", None)
    store.end_run(run_id, result.status, clock.now(), time_s=result.time_s, attempts=result.attempts,
                  reason=reason, frames=buffer,
                  events=[Event(clock.now(), "tracking_guard", counts.as_dict())] if counts is not None else [])
    if markers:
        markers("task_end", {"status": result.status, "time_s": result.time_s, "attempts": result.attempts})
    return result


# ---------------------------------------------------------------- the session


def run_session(store: Store, session_id: int, inputs: Inputs, *, clock: Clock, operator: Operator | None = None,
                rater: Rater | None = None, markers: Markers | None = None, progress: bool = True) -> str:
    """Run (or carry on) a session to its end; returns the session's status."""
    operator = operator or Unattended()
    protocol = store.protocol
    session = store.session(session_id)
    if session.status != "running":
        raise ValueError(f"session {session_id} is {session.status}; only a running session can go on")
    participant = store.participant(session.participant_id)
    tasks = store.tasks(session_id)
    stages = {s.name: s for s in protocol.stages}
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
                store.log(session_id, [Event(clock.now(), "phase_start", {"phase": phase.name})])
                if markers:
                    markers("phase_start", {"phase": phase.name})
            if phase.name == "questionnaire":
                _questionnaire(store, session_id, rater, clock, protocol)
            elif phase.name == "training" or phase.name in stages:
                for task in tasks:
                    if task.phase == phase.name and task.index not in finished:
                        _run_planned(store, session, task, inputs, clock, operator, markers, bar)
                        finished.add(task.index)
                        bar.update(1)
            else:
                operator.show(phase)
            store.log(session_id, [Event(clock.now(), "phase_end", {"phase": phase.name})])
            if markers:
                markers("phase_end", {"phase": phase.name})
    finally:
        bar.close()
    store.end_session(session_id, "completed", clock.now())
    return "completed"


def _run_planned(store: Store, session, task: PlannedTask, inputs: Inputs, clock: Clock, operator: Operator,
                 markers: Markers | None, bar) -> TaskResult:
    protocol = store.protocol
    seed = derived_seed(session.seed, task.index)
    label = f"{task.phase} {task.object_code} ({task.system})"
    if not operator.ready(task):
        run_id = store.begin_run(session.id, task, "skipped by the operator", seed, clock.now())
        store.end_run(run_id, "skipped", clock.now(), reason="skipped by the operator")
        return TaskResult("skipped", None, None, 0)
    hand = "left" if store.participant(session.participant_id).participant.handedness == "left" else "right"
    board = TaskBoard()
    world = task_world(protocol, task)
    source = guarded(inputs.open(participant_plan(protocol, task, hand), seed, board.read), world.model.scene)
    run_id = store.begin_run(session.id, task, source.description, seed, clock.now())
    if markers:
        markers("task_start", {"task": task.index, "phase": task.phase, "system": task.system, "object": task.object})
    started = time.monotonic()

    def show(frames: int) -> None:
        if frames % 110 == 0:
            bar.set_postfix_str(f"{label}: {frames} frames, {frames / max(time.monotonic() - started, 1e-9):.0f} fps")

    return run_task(store, session.id, run_id, world, source, protocol.task, clock, markers, protocol.frame_batch,
                    show, board, protocol.filter_window)


def _questionnaire(store: Store, session_id: int, rater: Rater | None, clock: Clock, protocol: Protocol) -> None:
    questionnaire = protocol.questionnaire
    if rater is None:
        store.log(session_id, [Event(clock.now(), "questionnaire_skipped", {"reason": "no rater for this session"})])
        return
    answered = store.answers(session_id)
    for stage in protocol.stages:
        for item in questionnaire.items:
            if (stage.system, item.name) not in answered:
                rating = rater.rate(item, stage, questionnaire)
                store.save_answer(session_id, stage.system, item.name, rating, rater.source, clock.now())


def resume_session(store: Store, session_id: int, inputs: Inputs, **options) -> str:
    """Mark runs cut off by a crash as interrupted, log the resume with its provenance, run on."""
    from microg import __version__

    clock = options["clock"]
    interrupted = store.interrupt_open_runs(session_id, clock.now())
    store.log(session_id, [Event(clock.now(), "session_resume", {
        "interrupted_runs": interrupted, "input": inputs.spec, "microg_version": __version__})])
    return run_session(store, session_id, inputs, **options)

