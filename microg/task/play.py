"""One frame's way, written once: the tracking guard, the window filter (Eq. 1), the physics
(Eqs. 2-20), the task's rules and respawn, as one compiled function over plain records.

    lanes = Lanes(KINDS["catch"], world, 1, guard=GuardConfig(), window=3)
    lanes.load(0, world, rules)
    for moments in play(lanes, source):        # the frames each source frame made (0, 1 or several)
        ...                                    # moments.records: MOMENT records; moments.events

A *lane* is one task in play: its hand tracking (the guard's and the filter's records), its world
(the physics' buffers and numbers), its task (the kind's state and rules records, the object's
start) and what its frames made. ``Lanes`` holds ``size`` of them side by side, for one kind of
task and one compiled step: a session plays one lane, the simulated participants' runner
(``microg.participant.runner``) many. ``frame_path(kind, effects, meshes)`` is the compiled
``take(lanes, b, frame, ending)``: lane ``b``'s source gave ``frame`` (a ``HANDS`` record; with
``ending`` the source has ended and the guard lets go what waits), and each frame the guard
releases goes

    hands  guard.admit      the tracking guard (bad tracking handled; frames may wait for a jump)
    hands  filter.smooth    the window filter (Eq. 1)
    sim    step             the world advanced to the frame (Eqs. 2-20)
    sim    observe          what the world shows of the task's object
    task   kind.judge       the kind's rules
    task   respawn          an object out of the workspace while not held goes back to its start

and is written as a ``MOMENT`` (with ``record``; else only its time). The task's events are
written beside it. Frames after the task ended are not stepped.
"""

from __future__ import annotations

import hashlib
import inspect
import math
import sys
from functools import lru_cache
from typing import Iterator, NamedTuple

import numpy as np
from numba import njit

from microg.hands.filter import filter_dtype, smooth
from microg.hands.guard import GUARD, GuardConfig, admit, finish, new_guard
from microg.sim import World
from microg.sim.compiled import entry_point, specialised
from microg.sim.observe import SNAPSHOT, Snapshot, observe
from microg.sim.state import OBJECT_COUNT, set_motion
from microg.skeleton import HANDS, HandFrame, hand_frame, hands_record

from .kind import COMPLETED, EVENT, MAX_EVENTS, Kind, TaskDisplay, TaskEvent, TaskState, emit
from .observation import Observation

MOMENT = np.dtype([("hands", HANDS), ("after", SNAPSHOT), ("stage", "i8"), ("place", "i8"), ("lit", "u1"),
                   ("timer", "f8"), ("held", "u1"), ("attempts", "i8"), ("started", "f8"), ("n_events", "i8")],
                  align=True)
"""One frame of a task: the frame the guard admitted (the tracked hand, as logged), what the world
showed of the object after it (after a respawn: where it was put back; ``touching`` and
``grasped_by`` as judged), the task's stage, place, whether it is lit and for how long, whether the
object is held, the attempts, when the task started, and how many events the frame made."""


@njit(cache=True)
def lost(rules, held, position):
    """Whether an object at ``position`` is lost: out of the workspace (``rules``' ``workspace_min``
    .. ``workspace_max``) while not held."""
    if held:
        return False
    for i in range(3):
        if not rules.workspace_min[i] <= position[i] <= rules.workspace_max[i]:
            return True
    return False


@njit(cache=True)
def copy_hands(source, target):
    target.t = source.t
    target.present[:] = source.present
    target.track_id[:] = source.track_id
    target.points[:] = source.points
    target.widths[:] = source.widths
    target.orientation[:] = source.orientation


@njit(cache=True)
def note(moment, task, after_t, n):
    """The task's part of a ``MOMENT``."""
    moment.stage, moment.place, moment.held, moment.attempts = task.stage, task.place, task.held, task.attempts
    moment.lit = not math.isnan(task.lit_since)
    moment.timer = after_t - task.lit_since if moment.lit else 0.0
    moment.started, moment.n_events = task.started, n


_FRAME_PATH = """
def {name}(lanes, b, frame, ending):
    (config, guards, pending, decided, filters, period, params, ints, reals, flags, counts, tasks, rules, starts,
     admitted, smoothed, seen, moments, events, times, n_frames, record) = lanes
    if ending:
        released = finish(guards[b], pending[b], decided[b], admitted[b])
    else:
        released = admit(config, guards[b], pending[b], decided[b], frame, admitted[b])
    for r in range(released):
        if tasks[b].stage >= {final}:
            break
        smooth(filters[b], period, admitted[b, r], smoothed[b])
        {step}(params[b], ints[b], reals[b], flags[b], counts[b], smoothed[b])
        n_objects, i = ints[b, {object_count}], n_frames[b]
        written = events[b, i if record else 0]  # (without a record, only the last frame's events)
        observe(reals[b], flags[b], counts[b], n_objects, 0, seen[b], False)
        n = {judge}(tasks[b], rules[b], seen[b], written)
        if lost(rules[b], tasks[b].held, seen[b].position):
            n = emit(written, n, {respawn}, seen[b].t, seen[b].position[0], seen[b].position[1],
                     seen[b].position[2])
            set_motion(reals[b], flags[b], counts[b], n_objects, 0, starts[b])
            observe(reals[b], flags[b], counts[b], n_objects, 0, seen[b], False)
        times[b, i] = seen[b].t
        if record:
            copy_hands(admitted[b, r], moments[b, i].hands)
            observe(reals[b], flags[b], counts[b], n_objects, 0, moments[b, i].after, True)
            note(moments[b, i], tasks[b], seen[b].t, n)
        n_frames[b] = i + 1
    return released
"""


@lru_cache(maxsize=None)
def frame_path(kind: Kind, effects: frozenset[str], meshes: bool):
    """The compiled ``take(lanes, b, frame, ending)`` of a kind's task on a world of ``effects`` (module
    docstring); returns how many frames the guard released. Lanes that ``record`` write every frame
    whole (``MOMENT``), others its time only (what an in-silico study keeps)."""
    from microg.sim.pipeline import specialise

    name = "take_" + _key(kind, effects, meshes)
    return specialised(_FRAME_PATH.replace("{final}", str(kind.index(COMPLETED)))
                       .replace("{respawn}", str(len(kind.events))).replace("{object_count}", str(OBJECT_COUNT)),
                       name, {"step": specialise(effects, meshes), "judge": kind.judge}, __file__, globals())


def _key(kind: Kind, effects: frozenset[str], meshes: bool) -> str:
    """A name part that tells apart every composition: the kind (with a hash of its module's source
    when it is not microg's own: numba checks a cached function against its own file only), the
    effects, the meshes."""
    name = kind.name
    if not kind.module.startswith("microg."):
        source = inspect.getsource(sys.modules[kind.module])
        name += "_" + hashlib.sha256(source.encode()).hexdigest()[:12]
    return "_".join([name, *sorted(effects)]) + ("_meshes" if meshes else "")


class Lanes:
    """``size`` tasks of one kind in play side by side on worlds of one model's compiled step
    (module docstring), each frame written whole (a session) or its time only (``record`` False);
    ``capacity``: the most frames a lane keeps before its owner takes them (``taken``)."""

    def __init__(self, kind: Kind, world: World, size: int, *, guard: GuardConfig, window: int,
                 capacity: int = 0, record: bool = True, params_size: int | None = None):
        model, data = world.model, world.data
        self.kind, self.size, self.record = kind, size, record
        self.effects, self.meshes = model.effects, model.scene.has_meshes
        capacity = max(capacity, guard.pending_frames)
        pending = guard.pending_frames
        params_size = max(params_size or 0, len(model.params))
        self.config, self.period = guard.record(), 1.0 / guard.nominal_rate
        self.guards = np.zeros(size, GUARD)
        self.pending, self.decided = np.zeros((size, pending), HANDS), np.zeros((size, pending, 2), dtype=np.bool_)
        self.filters = np.zeros(size, filter_dtype(window))
        self.params, self.ints = np.zeros((size, params_size)), np.zeros((size, len(model.ints)), dtype=np.int64)
        self.reals = np.zeros((size, len(data.reals)))
        self.flags = np.zeros((size, len(data.flags)), dtype=np.bool_)
        self.counts = np.zeros((size, len(data.counts)), dtype=np.int64)
        self.tasks, self.rules = np.zeros(size, kind.task_dtype), np.zeros(size, kind.rules_dtype)
        self.starts = np.zeros((size, 13))
        self.admitted, self.smoothed = np.zeros((size, pending), HANDS), np.zeros(size, HANDS)
        self.seen = np.zeros(size, SNAPSHOT)
        self.moments = np.zeros((size, capacity if record else 1), MOMENT)
        self.events = np.zeros((size, capacity if record else 1, MAX_EVENTS), EVENT)
        self.times, self.n_frames = np.zeros((size, capacity)), np.zeros(size, dtype=np.int64)
        self._take = None

    def arrays(self) -> tuple:
        """The lanes' records and arrays, in the order the compiled frame path takes them."""
        return (self.config, self.guards, self.pending, self.decided, self.filters, self.period, self.params,
                self.ints, self.reals, self.flags, self.counts, self.tasks, self.rules, self.starts, self.admitted,
                self.smoothed, self.seen, self.moments, self.events, self.times, self.n_frames, self.record)

    def take(self, b: int, frame, ending: bool = False) -> int:
        """Lane ``b``'s source gave ``frame`` (a ``HANDS`` record; with ``ending``, it has ended): the
        compiled frame path (``frame_path``); how many frames the guard released."""
        args = (self.arrays(), b, frame, ending)
        if self._take is None:
            self._take = entry_point(frame_path(self.kind, self.effects, self.meshes), args)
        return self._take(*args)

    def load(self, b: int, world: World, rules) -> None:
        """Put a task in lane ``b``: ``world`` (its object at its start, moving as the task starts it)
        judged by ``rules`` (a ``TaskRules``), no frame seen yet."""
        model, data = world.model, world.data
        if model.effects != self.effects or len(data.reals) != self.reals.shape[1]:
            raise ValueError(f"lane {b}: a world of effects {sorted(model.effects)} cannot join lanes of "
                             f"{sorted(self.effects)}")
        self.guards[b] = new_guard()
        self.pending[b], self.decided[b] = np.zeros(1, HANDS)[0], False
        self.filters[b] = np.zeros(1, self.filters.dtype)[0]
        self.params[b, :len(model.params)], self.ints[b] = model.params, model.ints
        self.reals[b], self.flags[b], self.counts[b] = data.reals, data.flags, data.counts
        self.tasks[b], self.rules[b] = self.kind.new_task(), self.kind.rules_record(rules)
        self.starts[b] = np.concatenate([data.position[0], data.orientation[0], data.velocity[0],
                                         data.angular_velocity[0]])
        self.seen[b] = np.zeros(1, SNAPSHOT)[0]
        self.n_frames[b] = 0
        self._observe(b)

    def _observe(self, b: int) -> None:
        _observe_world(self.reals[b], self.flags[b], self.counts[b], int(self.ints[b, OBJECT_COUNT]), self.seen[b])

    def taken(self, b: int) -> Moments:
        """Lane ``b``'s frames since the last call (``Moments``), and forget them."""
        n = int(self.n_frames[b])
        self.n_frames[b] = 0
        return Moments(self.kind, self.moments[b, :n].copy(), self.events[b, :n].copy())

    def state(self, b: int) -> TaskState:
        """Lane ``b``'s task state now (a copy)."""
        return TaskState(self.kind, self.tasks[b].copy())

    def observation(self, b: int) -> Observation:
        """What lane ``b``'s world shows now, with what the task displays (for a closed-loop source)."""
        seen = self.seen[b]
        display = self.state(b).displayed(float(seen["t"]))
        return Observation(float(seen["t"]), bool(seen["grasped_by"].any()), seen["position"].copy(),
                           seen["orientation"].copy(), seen["touching"].astype(bool), display,
                           seen["velocity"].copy(), seen["angular_velocity"].copy(), seen["grasped_by"].astype(bool))

    def result(self, b: int, frames: int, frame_times: np.ndarray | None = None) -> TaskResult:
        """How lane ``b``'s task ended after ``frames`` frames (``TaskResult``)."""
        state = self.state(b)
        if not frames or not state.finished:
            return TaskResult("aborted", None, state.attempts, frames, {}, frame_times)
        status = COMPLETED if state.stage == COMPLETED else "timeout"
        return TaskResult(status, state.completion_time, state.attempts, frames, self.kind.measured(state.record),
                          frame_times)

    def counts_of(self, b: int):
        """What lane ``b``'s tracking guard did (``microg.hands.GuardCounts``)."""
        from microg.hands.guard import GuardCounts

        return GuardCounts.of(self.guards[b]["counts"])


@njit(cache=True)
def _observe_world(reals, flags, counts, n, out):
    observe(reals, flags, counts, n, 0, out, False)


class TaskResult(NamedTuple):
    """How a task ended, as its run records it: ``completed``, ``timeout``, ``aborted`` (its hand
    source ended first) or ``skipped`` (by the operator), its completion time and attempts (as its
    kind's rules count them), its kind's own measures (of a finished task), its frames, and their
    times where the player keeps them (an in-silico study, to rebuild the session's clock)."""

    status: str
    time_s: float | None
    attempts: int | None
    frames: int
    measures: dict = {}
    frame_times: np.ndarray | None = None


class Moments(NamedTuple):
    """The frames a task's play made (``MOMENT`` records) and their events (``EVENT``, ``MAX_EVENTS``
    a frame), what the session's sinks take."""

    kind: Kind
    records: np.ndarray
    events: np.ndarray

    def __len__(self) -> int:
        return len(self.records)

    def task_events(self, i: int) -> list[TaskEvent]:
        """Frame ``i``'s events."""
        return [self.kind.event(e) for e in self.events[i, :int(self.records[i]["n_events"])]]

    def frame(self, i: int) -> HandFrame:
        """Frame ``i``'s tracked hand, as admitted."""
        return hand_frame(self.records[i]["hands"])

    def after(self, i: int) -> Snapshot:
        """What frame ``i`` showed of the object."""
        a = self.records[i]["after"]
        return Snapshot(float(a["t"]), a["position"].copy(), a["orientation"].copy(), a["velocity"].copy(),
                        a["angular_velocity"].copy(), a["touching"].astype(bool), a["grasped_by"].astype(bool),
                        a["rendered"].copy())

    def display(self, i: int) -> TaskDisplay:
        """What the task showed at frame ``i``."""
        r = self.records[i]
        return TaskDisplay(self.kind.stage_names[int(r["stage"])], int(r["place"]), bool(r["lit"]), float(r["timer"]))


def play(lanes: Lanes, source, b: int = 0) -> Iterator[Moments]:
    """Play lane ``b``'s task with frames from ``source`` (a ``microg.hands.HandSource``: its
    ``next_frame`` gets the last observation) until the task is finished or the frames end; yields
    the ``Moments`` of each source frame (none when the guard holds it back)."""
    frame = np.zeros(1, HANDS)[0]
    finished = lanes.kind.index(COMPLETED)
    ending = False
    while not ending and lanes.tasks[b]["stage"] < finished:
        given = source.next_frame(lanes.observation(b))
        ending = given is None
        if not ending:
            hands_record(given, frame)
        lanes.take(b, frame, ending)
        if lanes.n_frames[b]:
            yield lanes.taken(b)
