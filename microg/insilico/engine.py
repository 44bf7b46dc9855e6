"""Tasks played by simulated participants, many at once, in compiled code.

A session plays a task frame by frame from Python (``microg.study.session.run_task``): the
participant's frame, hand tracking (the guard, the window filter), the physics, the task's rules,
respawn, and the log. An in-silico study logs no frames, so ``play_tasks`` runs the same steps for
many tasks together: the tasks of one object and interaction model share one physics model, so
their worlds are stepped as one batch (``sim`` ``step_worlds``, as ``step_batch``), and one compiled
loop (``_runner``) plays the batch frame after frame until a task ends: ``_track`` (each
participant's frame, the guard's checks, Eq. 1), the physics step, and ``_judge`` (what each world
shows, the task's rules, respawn). Each calls the code a session runs:
``participant.step_participant``, ``filter.window_mean``, ``stages.judge``, ``respawn.lost``, the
physics' ``step_worlds``. Python sees the batch once per task's end, where the next task of its
scene takes the finished one's place.

The tracking guard passes a simulated participant's frames unchanged (its timestamps increase by
less than ``max_gap``, every joint is known, no point moves ``jump_distance`` in a frame, its
track never changes); ``_track`` checks each frame for exactly that and refuses to go on otherwise,
so a task played here sees what it would see in a session. The outcome of each task is what a
session's run records (status, completion time, attempts) and every frame's time, from which the
session clock is rebuilt exactly as a session advances it (``frame_times``).
"""

from __future__ import annotations

import math
import multiprocessing
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit, typeof
from numba.typed import List

from microg.hands.filter import window_mean
from microg.participant.actions import PLAYER, SEEN, STATE
from microg.participant.anatomy import WIDTHS
from microg.participant.grasp import GRASP, KEYS
from microg.participant.participant import perceive, start, step_participant
from microg.participant.plan import TaskPlan
from microg.participant.skill import SkillProfile
from microg.sim import make_world
from microg.sim.pipeline import specialise
from microg.sim.observe import _snapshot, seen_object
from microg.sim.state import POINTS, layout
from microg.skeleton import N_BONES, N_DIGITS, SIDES
from microg.study.protocol import Protocol
from microg.task.respawn import lost
from microg.task.rules import PICK_AND_PLACE, TaskRules
from microg.task.stages import EVENT, MAX_EVENTS, STAGES, TASK, judge, rules_record

BATCH = 32
"""Tasks stepped together at most (per object and interaction model)."""
SHARES_PER_WORKER = 32
"""Shares of the tasks per worker process (``play_tasks``): small enough that the workers finish
close together (a 30-participant paper study of 26 CPU seconds on 2 workers: 15.2 s with 4 shares
each, 14.2 with 8, 13.2 with 32, no better with 64 or 120; it cannot take less than 13)."""
FRAMES_PER_SECOND = 130
"""More frames a second than a simulated participant gives (115 Hz with jitter): sizes each task's
record of frame times."""
_COMPLETED = STAGES.index("completed")


@dataclass(frozen=True)
class TaskUnit:
    """One task for a simulated participant: its plan, its skill, its seed, its clock's limit."""

    plan: TaskPlan
    skill: SkillProfile
    seed: int
    time_limit_s: float
    interaction: str
    object_name: str


@dataclass(frozen=True)
class Outcome:
    """How a task played out: ``completed``, ``timeout`` or ``aborted`` (the participant gave no
    more frames), its completion time and attempts (as the task's rules count them), and the time
    of every frame (s, the participant's clock)."""

    status: str
    time_s: float | None
    attempts: int
    frame_times: np.ndarray


def unplayable(protocol: Protocol) -> str | None:
    """Why an in-silico study cannot play ``protocol`` (a phase, or the training, of a task kind other
    than the pick-and-place), naming the file and the phase; None when it can."""
    phases = (["training"] if protocol.training is not None else []) + [p.name for p in protocol.phases]
    other = next((name for name in phases if protocol.kind(name) != PICK_AND_PLACE), None)
    if other is None:
        return None
    return (f"{protocol.where}: phase {other!r} runs {protocol.kind(other)} tasks: in-silico studies play only "
            f"{PICK_AND_PLACE} tasks; run this protocol's sessions with --input simulated (microg demo does)")


def play_tasks(protocol: Protocol, units: list[TaskUnit], progress=None, workers: int = 1) -> list[Outcome]:
    """Play every task of ``units`` (a task's world is the protocol's scene of its object and
    interaction model); the outcomes in the order of ``units``. ``progress(done)`` is told the
    number of tasks finished as they finish. With ``workers`` > 1 the tasks are dealt out in
    turn into ``SHARES_PER_WORKER`` shares per worker, each with a like share of every scene, which
    as many processes take as they come free (each task's outcome depends on its own seed only;
    a task's length is not known before it is played, so shares even out the load). Only
    pick-and-place tasks play here (the compiled rules are ``microg.task.stages``'): a protocol with
    another kind raises ValueError (``unplayable``)."""
    why = unplayable(protocol)
    if why is not None:
        raise ValueError(why)
    outcomes: list[Outcome | None] = [None] * len(units)
    if workers > 1 and len(units) > 1:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        if multiprocessing.get_start_method() == "fork":
            _load_compiled(protocol, units)
        parts = min(SHARES_PER_WORKER * workers, len(units))
        shares = [list(range(len(units)))[w::parts] for w in range(parts)]  # a like share of every scene in each
        with ProcessPoolExecutor(min(workers, parts)) as pool:
            futures = {pool.submit(play_tasks, protocol, [units[i] for i in share]): share for share in shares}
            done = 0
            for future in as_completed(futures):
                for i, outcome in zip(futures[future], future.result()):
                    outcomes[i] = outcome
                done += len(futures[future])
                if progress is not None:
                    progress(done)
        return outcomes
    scenes: dict[tuple[str, str, TaskRules], list[int]] = {}
    for i, unit in enumerate(units):
        scenes.setdefault(_batch_key(unit), []).append(i)
    done = 0
    for (name, interaction, _), indices in scenes.items():
        for i, outcome in _play_scene(protocol, protocol.scene(name, interaction), [units[i] for i in indices]):
            outcomes[indices[i]] = outcome
            done += 1
            if progress is not None:
                progress(done)
    return outcomes


def _batch_key(unit: TaskUnit) -> tuple[str, str, TaskRules]:
    """What the tasks stepped together share: the scene (object and interaction model) and the rules
    (a training may have a time limit of its own)."""
    return unit.object_name, unit.interaction, unit.plan.rules


def _play_scene(protocol: Protocol, scene, units: list[TaskUnit]):
    """The tasks of one scene and rules, ``BATCH`` at a time; yields (index in ``units``, outcome) as each ends."""
    size = min(BATCH, len(units))
    data, batch, frames_until_an_end, arguments = _scene_batch(protocol, scene, units, size)
    queue = list(range(len(units)))
    slots = [-1] * size
    for slot in range(size):
        slots[slot] = queue.pop(0)
        batch.load(slot, units[slots[slot]], data)
    while any(index >= 0 for index in slots):
        ended = frames_until_an_end(*arguments())
        if np.isfinite(batch.refused).any():
            slot = int(np.flatnonzero(np.isfinite(batch.refused))[0])
            unit, value = units[slots[slot]], float(batch.refused[slot])
            raise RuntimeError(
                f"in-silico task {unit.plan.phase} {unit.object_name} ({unit.interaction}) of participant "
                f"{unit.plan.participant or '?'}, seed {unit.seed}: at t = {batch.frame_times[slot, batch.frames[slot] - 1]:.3f} s "
                f"the simulated hand's frame is one the tracking guard would change "
                + (f"(a point moved {value:.3f} m in one frame)" if value >= 0 else f"(an interval of {-value:g} s)")
                + "; a session would run it, an in-silico study cannot")
        for slot in np.flatnonzero(ended):
            yield slots[slot], batch.outcome(slot)
            if queue:
                slots[slot] = queue.pop(0)
                batch.load(slot, units[slots[slot]], data)
            else:
                slots[slot] = -1
                batch.active[slot] = False


def _scene_batch(protocol: Protocol, scene, units: list[TaskUnit], size: int):
    """A batch of ``size`` tasks of ``scene`` (none loaded yet): the world's data, the ``_Batch``, the
    compiled loop over frames and a function giving its arguments."""
    world = make_world(scene)
    model, data = world.model, world.data
    places, _ = layout(model.n_objects)
    offsets = np.array([places[name][1] for name in ("position", "orientation", "velocity", "angular_velocity")])
    rules = rules_record(units[0].plan.rules)
    limit = max(int(u.time_limit_s * FRAMES_PER_SECOND) + 2 for u in units)
    batch = _Batch(size, data, protocol.filter_window, limit)
    tracking = (1.0 / protocol.tracking_rate, protocol.guard.jump_distance, protocol.guard.max_gap)
    return data, batch, _runner(scene.effects, scene.has_meshes), lambda: (
        model.params, model.ints, batch.arrays(), *tracking, rules, model.n_objects, offsets)


def _load_compiled(protocol: Protocol, units: list[TaskUnit]) -> None:
    """Load the compiled code of ``units``' scenes into this process (compiled, or read from numba's
    cache, for the argument types of a batch): worker processes forked after it inherit it instead
    of each reading it again (about 3 s a process, on every multi-process study, before this)."""
    firsts: dict[tuple[str, str], TaskUnit] = {}
    for unit in units:
        firsts.setdefault((unit.object_name, unit.interaction), unit)  # the rules do not change the code
    for (name, interaction), unit in firsts.items():
        data, batch, frames_until_an_end, arguments = _scene_batch(protocol, protocol.scene(name, interaction),
                                                                   [unit], 1)
        batch.load(0, unit, data)
        frames_until_an_end.compile(tuple(typeof(value) for value in arguments()))


_RUNNER = """
def {name}(params, ints, arrays, period, jump_distance, max_gap, rules, n_objects, offsets):
    (players, states, seens, streams, grasps, tasks, events, reals, flags, counts, start, timestamp, present,
     track, points, widths, samples, times, count, newest, guard, observed, position, orientation, touching,
     grasped, active, refused, frame_times, frames) = arrays
    while True:
        ended = _track(players, states, seens, streams, grasps, tasks, observed, position, orientation, touching,
                       grasped, active, timestamp, present, track, points, widths, samples, times, count, newest,
                       period, guard, jump_distance, max_gap, frame_times, frames, refused)
        for b in range(len(active)):
            if not math.isnan(refused[b]):
                return ended
        {step}(params, ints, reals, flags, counts, timestamp, present, track, points, widths)
        _judge(reals, flags, counts, n_objects, tasks, rules, events, active, observed, position, orientation,
               touching, grasped, start, offsets)
        any_ended = False
        for b in range(len(active)):
            if active[b] and tasks[b].stage >= _COMPLETED:
                ended[b] = True
            any_ended = any_ended or ended[b]
        if any_ended:
            return ended
"""


@lru_cache(maxsize=None)
def _runner(effects: frozenset[str], meshes: bool):
    """The compiled loop over frames for worlds of these effects: each frame ``_track``, the physics
    step (``sim.pipeline.specialise(effects, meshes)``), ``_judge``, for every active task of the
    batch, until one of them ends (completed, out of time, no more frames) or a frame is refused.
    Returns which tasks ended. One call per task's end, not per frame: a call from Python costs more
    than a frame of a task. The loop is made from ``_RUNNER`` with the step as a global of its own
    name (numba's disk cache cannot key a function that closes over a compiled one: it would compile
    afresh in every process)."""
    key = "_".join(sorted(effects)) + ("_meshes" if meshes else "")
    name, step = f"frames_until_an_end_{key}", f"_step_{key}"
    globals()[step] = specialise(effects, meshes)
    namespace = {}
    exec(compile(_RUNNER.format(name=name, step=step), __file__, "exec"), globals(), namespace)
    return njit(cache=True)(namespace[name])


class _Batch:
    """The arrays of ``size`` tasks of one world model stepped together (see ``_track``, ``_judge``)."""

    def __init__(self, size: int, data, window: int, limit: int):
        self.players, self.states = np.zeros(size, PLAYER), np.zeros(size, STATE)
        self.seens, self.tasks = np.zeros(size, SEEN), np.zeros(size, TASK)
        self.events = np.zeros((size, MAX_EVENTS), EVENT)
        self.grasps = np.zeros((size, KEYS), GRASP)
        self.streams = List([List([np.random.default_rng(0) for _ in range(4)]) for _ in range(size)])
        self.reals = np.repeat(data.reals[None], size, axis=0)
        self.flags = np.repeat(data.flags[None], size, axis=0)
        self.counts = np.repeat(data.counts[None], size, axis=0)
        self.start = np.concatenate([data.position[0], data.orientation[0]])
        self.timestamp = np.zeros(size)
        self.present = np.zeros((size, 2), dtype=np.bool_)
        self.track = np.zeros((size, 2), dtype=np.int64)
        self.points = np.full((size, 2, POINTS, 3), np.nan)
        self.widths = np.full((size, 2, N_DIGITS, N_BONES), np.nan)
        self.samples = np.zeros((size, window, N_DIGITS, N_BONES + 1, 3))
        self.times, self.count, self.newest = np.zeros((size, window)), np.zeros(size, np.int64), np.zeros(size, np.int64)
        self.guard = np.zeros((size, POINTS, 3))
        self.observed = np.zeros(size)
        self.position, self.orientation = np.zeros((size, 3)), np.zeros((size, 4))
        self.touching, self.grasped = np.zeros((size, 40), dtype=np.bool_), np.zeros(size, dtype=np.bool_)
        self.active = np.zeros(size, dtype=np.bool_)
        self.refused = np.full(size, np.nan)
        self.frame_times, self.frames = np.zeros((size, limit)), np.zeros(size, np.int64)
        self.initial = (data.reals.copy(), data.flags.copy(), data.counts.copy())

    def arrays(self) -> tuple:
        """The batch's arrays in the order ``_runner``'s loop takes them."""
        return (self.players, self.states, self.seens, self.streams, self.grasps, self.tasks, self.events, self.reals,
                self.flags, self.counts, self.start, self.timestamp, self.present, self.track, self.points,
                self.widths, self.samples, self.times, self.count, self.newest, self.guard, self.observed,
                self.position, self.orientation, self.touching, self.grasped, self.active, self.refused,
                self.frame_times, self.frames)

    def load(self, slot: int, unit: TaskUnit, data) -> None:
        """Put ``unit`` in ``slot``: its participant before its first frame, its world at rest."""
        self.players[slot], self.states[slot] = np.zeros(1, PLAYER)[0], np.zeros(1, STATE)[0]
        _, _, streams, grasps = start(unit.plan, unit.skill, unit.seed, time_limit_s=unit.time_limit_s,
                                      player=self.players[slot], state=self.states[slot])
        self.streams[slot] = streams
        self.grasps[slot] = grasps
        self.tasks[slot] = (0, math.nan, math.nan, 0, math.nan, False, math.nan, math.nan, 0)
        self.reals[slot], self.flags[slot], self.counts[slot] = self.initial
        side = SIDES.index(unit.plan.hand)
        self.present[slot] = [s == side for s in range(2)]
        self.track[slot] = 0
        self.track[slot, side] = 1
        self.points[slot] = np.nan
        self.widths[slot] = np.nan
        self.widths[slot, side] = WIDTHS
        self.count[slot], self.newest[slot] = 0, -1
        t, values, touching, grasped_by = _snapshot(*self.initial, data.n_objects, 0)
        self.observed[slot], self.position[slot], self.orientation[slot] = t, values[0:3], values[3:7]
        self.touching[slot], self.grasped[slot] = touching, grasped_by.any()
        self.frames[slot] = 0
        self.active[slot] = True

    def outcome(self, slot: int) -> Outcome:
        task = self.tasks[slot]
        frame_times = self.frame_times[slot, :self.frames[slot]].copy()
        if task["stage"] == _COMPLETED:
            return Outcome("completed", float(task["ended"] - task["started"]), int(task["attempts"]), frame_times)
        if task["stage"] > _COMPLETED:
            return Outcome("timeout", None, int(task["attempts"]), frame_times)
        return Outcome("aborted", None, int(task["attempts"]), frame_times)


@njit(cache=True)
def _track(players, states, seens, streams, grasps, tasks, observed, position, orientation, touching, grasped, active,
           timestamp, present, track, points, widths, samples, times, count, newest, period, guard, jump_distance,
           max_gap, frame_times, frames, refused):
    """Every active task's next frame: the participant looks at what its world showed and moves its
    hand (``step_participant``); the frame passes the tracking guard's checks unchanged and the
    window filter (Eq. 1) smooths its joints into the batch's hand frames. Returns, per task,
    whether its participant gave no more frames (it is done, or out of time). A frame the guard would
    not pass unchanged stops it: ``refused`` then holds how far the hand moved (m), or minus the
    interval (s)."""
    ended = np.zeros(len(active), dtype=np.bool_)
    joints, palm, palm_orientation = np.empty((N_DIGITS, N_BONES + 1, 3)), np.empty(3), np.empty(4)
    for b in range(len(active)):
        if not active[b]:
            continue
        task, p = tasks[b], players[b]
        perceive(p, seens[b], 0.0, 0.0, position[b], orientation[b], touching[b], grasped[b], True, task.stage,
                 task.place, not math.isnan(task.lit_since))
        t = step_participant(p, states[b], seens[b], streams[b], grasps[b], joints, palm, palm_orientation)
        if math.isnan(t):
            ended[b], active[b] = True, False
            continue
        side = 0 if p.mirror < 0 else 1
        n = frames[b]
        if n > 0:
            interval = t - frame_times[b, n - 1]
            moved = _moved(guard[b], palm, joints)
            if not 0 < interval <= max_gap or moved >= jump_distance:
                refused[b] = moved if 0 < interval <= max_gap else -interval
                return ended
        frame_times[b, n], frames[b] = t, n + 1
        guard[b, 0] = palm
        guard[b, 1:] = joints.reshape((-1, 3))
        newest[b] = (newest[b] + 1) % samples.shape[1]
        samples[b, newest[b]] = joints
        times[b, newest[b]] = t
        count[b] = min(count[b] + 1, samples.shape[1])
        smoothed = window_mean(samples[b], times[b], count[b], newest[b], period)
        timestamp[b] = t
        points[b, side, 0] = palm
        points[b, side, 1:] = smoothed.reshape((-1, 3))
    return ended


@njit(cache=True)
def _moved(last, palm, joints):
    """The largest distance (m) the palm or a joint moved since ``last`` (the jump rule's measure)."""
    largest = math.sqrt((palm[0] - last[0, 0]) ** 2 + (palm[1] - last[0, 1]) ** 2 + (palm[2] - last[0, 2]) ** 2)
    flat = joints.reshape((-1, 3))
    for i in range(flat.shape[0]):
        d = math.sqrt((flat[i, 0] - last[i + 1, 0]) ** 2 + (flat[i, 1] - last[i + 1, 1]) ** 2
                      + (flat[i, 2] - last[i + 1, 2]) ** 2)
        largest = max(largest, d)
    return largest


@njit(cache=True)
def _judge(reals, flags, counts, n_objects, tasks, rules, events, active, observed, position, orientation, touching,
           grasped, start, offsets):
    """Every active task after its world's step: what the world shows of the object
    (``_snapshot``), the task's rules (``stages.judge``), a lost object put back at its start
    (``respawn.lost``), and what the participant sees next."""
    for b in range(len(active)):
        if not active[b]:
            continue
        t, held = seen_object(reals[b], flags[b], counts[b], n_objects, 0, position[b], orientation[b], touching[b])
        judge(tasks[b], rules, t, held, position[b], events[b])
        if lost(rules, tasks[b].held, position[b]):
            for i in range(3):
                reals[b, offsets[0] + i] = start[i]
                reals[b, offsets[2] + i] = 0.0
                reals[b, offsets[3] + i] = 0.0
            for i in range(4):
                reals[b, offsets[1] + i] = start[3 + i]
            t, held = seen_object(reals[b], flags[b], counts[b], n_objects, 0, position[b], orientation[b],
                                  touching[b])
        observed[b], grasped[b] = t, held
