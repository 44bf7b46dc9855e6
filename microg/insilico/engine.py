"""Tasks played by simulated participants, many at once: batching and scheduling, nothing else.

A session plays a task through the one frame path (``microg.task.play``: the tracking guard, the
window filter, the physics, the kind's rules, respawn), its simulated participant in compiled code
(``microg.participant.runner``), and logs every frame. An in-silico study logs no frames, so
``play_tasks`` plays many tasks side by side through the same code: the tasks of one kind on worlds
of one compiled step (one interaction model, with or without meshes) are lanes of one ``Lanes``,
``BATCH`` at a time, each frame keeping only its time. Python sees the batch once per task's end,
where the next task takes the finished one's lane. The result of each task is what a session's
run records (``microg.task.TaskResult``: status, completion time, attempts, the kind's measures) with
every frame's time, from which the session clock is rebuilt exactly as a session advances it.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Generator
from dataclasses import dataclass

import numpy as np

from microg.participant.plan import TaskPlan
from microg.participant.runner import Players, run
from microg.participant.skill import SkillProfile
from microg.sim import make_world
from microg.study.protocol import Protocol
from microg.task import KINDS, Lanes, TaskResult

BATCH = 32
"""Tasks played side by side at most (per kind and compiled step)."""
SHARES_PER_WORKER = 32
"""Shares of the tasks per worker process (``play_tasks``): small enough that the workers finish
close together (docs/simulated-participant.md, "Speed")."""
FRAMES_PER_SECOND = 130
"""More frames a second than a simulated participant gives (115 Hz with jitter): sizes each task's
record of frame times."""


@dataclass(frozen=True)
class TaskUnit:
    """One task for a simulated participant: its plan, its skill, its seed, its clock's limit."""

    plan: TaskPlan
    skill: SkillProfile
    seed: int
    time_limit_s: float
    interaction: str
    object_name: str


def play_tasks(protocol: Protocol, units: list[TaskUnit], progress=None, workers: int = 1) -> list[TaskResult]:
    """Play every task of ``units`` (a task's world is the protocol's scene of its object, interaction
    model and kind); the results in the order of ``units``. ``progress(done)`` is told the number of
    tasks finished as they finish. With ``workers`` > 1 the tasks are dealt out in turn into
    ``SHARES_PER_WORKER`` shares per worker, each with a like share of every batch, which as many
    processes take as they come free (each task's result depends on its own seed only; a task's
    length is not known before it is played, so shares even out the load)."""
    results: list[TaskResult | None] = [None] * len(units)
    if workers > 1 and len(units) > 1:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        if multiprocessing.get_start_method() == "fork":
            _load_compiled(protocol, units)
        parts = min(SHARES_PER_WORKER * workers, len(units))
        shares = [list(range(len(units)))[w::parts] for w in range(parts)]  # a like share of every batch in each
        with ProcessPoolExecutor(min(workers, parts)) as pool:
            futures = {pool.submit(play_tasks, protocol, [units[i] for i in share]): share for share in shares}
            done = 0
            for future in as_completed(futures):
                for i, result in zip(futures[future], future.result()):
                    results[i] = result
                done += len(futures[future])
                if progress is not None:
                    progress(done)
        return results
    done = 0

    def one(i: int, unit: TaskUnit) -> Stream:
        nonlocal done
        results[i] = yield unit
        done += 1
        if progress is not None:
            progress(done)

    play_streams(protocol, [one(i, unit) for i, unit in enumerate(units)])
    return results


Stream = Generator[TaskUnit, TaskResult, None]
"""A participant's tasks one after the other: it yields a task, is sent its result, and yields the
next (which may depend on the results so far, as a phase trained to a criterion does), until it
returns."""


def play_streams(protocol: Protocol, streams: list[Stream]) -> None:
    """Play every stream's tasks to its end, side by side: the tasks of one kind and compiled step
    share a batch of ``BATCH`` lanes; a lane whose task ended takes the next task waiting for that
    batch, the next task of the stream whose task ended among them."""
    waiting: dict[tuple, list[tuple[Stream, TaskUnit]]] = {}

    def wait(stream: Stream, unit: TaskUnit | None) -> None:
        if unit is not None:
            waiting.setdefault(_batch_key(protocol, unit), []).append((stream, unit))

    for stream in streams:
        wait(stream, next(stream, None))
    while any(waiting.values()):
        key = next(key for key, queue in waiting.items() if queue)
        _play_batch(protocol, waiting[key], wait)


def advance(stream: Stream, result: TaskResult) -> TaskUnit | None:
    """The stream's next task after ``result`` (None: it has no more)."""
    try:
        return stream.send(result)
    except StopIteration:
        return None


def _batch_key(protocol: Protocol, unit: TaskUnit) -> tuple:
    """What tasks played side by side share: their kind and their compiled step."""
    model = _world(protocol, unit).model
    return unit.plan.rules.kind, model.effects, model.scene.has_meshes


def _world(protocol: Protocol, unit: TaskUnit):
    """The world a task starts in, as its kind starts it by the task's rules (a staircase's difficulty
    may move the start): made once per protocol, object, interaction model and rules."""
    rules = unit.plan.rules
    key = (id(protocol), unit.object_name, unit.interaction, rules)
    cached = _WORLDS.get(key)
    if cached is None or cached[0] is not protocol:
        cached = _WORLDS[key] = (protocol, make_world(protocol.scene(unit.object_name, unit.interaction, rules.kind,
                                                                     rules)))
    return cached[1]


_WORLDS: dict[tuple, tuple] = {}


def _lanes(protocol: Protocol, units: list[TaskUnit], size: int) -> tuple[Lanes, Players]:
    kind = KINDS[units[0].plan.rules.kind]
    worlds = [_world(protocol, u) for u in units]
    lanes = Lanes(kind, worlds[0], size, guard=protocol.guard, window=protocol.filter_window,
                  capacity=max(_frames(u) for u in units),
                  record=False, params_size=max(len(w.model.params) for w in worlds))
    return lanes, Players(kind, size)


def _frames(unit: TaskUnit) -> int:
    """The frames a task's record holds at most."""
    return int(unit.time_limit_s * FRAMES_PER_SECOND) + 2


def _load(lanes: Lanes, players: Players, lane: int, protocol: Protocol, unit: TaskUnit) -> None:
    lanes.load(lane, _world(protocol, unit), unit.plan.rules)
    players.load(lane, unit.plan, unit.skill, unit.seed, time_limit_s=unit.time_limit_s)


def _play_batch(protocol: Protocol, queue: list[tuple[Stream, TaskUnit]], wait) -> None:
    """The tasks of ``queue`` (one kind and compiled step), ``BATCH`` at a time, each ended task's
    result sent to its stream and the stream's next task handed to ``wait`` (which queues it here
    when it shares the batch); returns when no lane plays and no task in ``queue`` fits the lanes
    (one with a longer clock or more parameters than the lanes were made for waits for the next batch)."""
    size = min(BATCH, len(queue))
    lanes, players = _lanes(protocol, [unit for _, unit in queue[:size]], size)
    capacity = lanes.times.shape[1]

    def take(lane: int) -> Stream | None:
        fits = next((i for i, (_, unit) in enumerate(queue)
                     if _frames(unit) <= capacity and len(_world(protocol, unit).model.params) <= lanes.params.shape[1]),
                    None)
        if fits is None:
            return None
        stream, unit = queue.pop(fits)
        _load(lanes, players, lane, protocol, unit)
        return stream

    playing = [take(lane) for lane in range(size)]  # the stream each lane plays (None: none)
    while any(stream is not None for stream in playing):
        run(lanes, players, capacity)
        for lane in np.flatnonzero(players.ended):
            n = int(lanes.n_frames[lane])
            players.ended[lane] = False
            wait(playing[lane], advance(playing[lane], lanes.result(lane, n, lanes.times[lane, :n].copy())))
            playing[lane] = take(lane)


def _load_compiled(protocol: Protocol, units: list[TaskUnit]) -> None:
    """Load the compiled code of ``units``' batches into this process (compiled, or read from numba's
    cache): worker processes forked after it inherit it instead of each reading it again (about 3 s
    a process, on every multi-process study, before this)."""
    firsts: dict[tuple, TaskUnit] = {}
    for unit in units:
        firsts.setdefault(_batch_key(protocol, unit), unit)
    for unit in firsts.values():
        lanes, players = _lanes(protocol, [unit], 1)
        _load(lanes, players, 0, protocol, unit)
        from microg.participant.runner import runner

        runner(lanes.kind, lanes.effects, lanes.meshes).compile(
            _signature(lanes.arrays(), players.arrays()))


def _signature(lane_arrays: tuple, player_arrays: tuple) -> tuple:
    from numba import typeof

    return typeof(lane_arrays), typeof(player_arrays), typeof(1)
