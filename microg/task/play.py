"""One task played out, frame by frame: hand in, physics, rules, respawn. Written once.

``play`` is the loop every task runs, whoever plays it: a study session (which logs each
``Moment``), the simulated participant's bench, a test. Each frame the hand source looks at the
last ``Observation`` (with what the task displays), gives a frame, the frame goes through
``smooth`` (the window filter, ``microg.hands.filter``) into the physics, the task's rules
(``stages.advance``) judge the outcome and a lost object is put back (``respawn``).
"""

from __future__ import annotations

from typing import Callable, Iterator, NamedTuple

from microg.sim import HandFrame, Snapshot, World, snapshot, step

from .observation import Observation, observe, seen_in
from .respawn import respawn
from .rules import TaskRules
from .stages import TaskEvent, TaskState, advance, shown


class Moment(NamedTuple):
    """One frame of a task: the frame as the source gave it, and what the world and task made of it."""

    frame: HandFrame
    world: World
    after: Snapshot
    """What ``world`` shows of the task's object (``microg.sim.snapshot``)."""
    state: TaskState
    observation: Observation
    """What the task judged (the world before a respawn), with what it now displays."""
    events: tuple[TaskEvent, ...]


def play(world: World, source, rules: TaskRules,
         smooth: Callable[[HandFrame], HandFrame] = lambda frame: frame) -> Iterator[Moment]:
    """Run the task on ``world`` with frames from ``source`` until it is finished or the source
    ends; yields every frame's ``Moment``. The source's ``next_frame`` gets the last observation."""
    state = TaskState()
    start = (world.data.position[0].copy(), world.data.orientation[0].copy())
    seen = observe(world, display=shown(state, world.time))
    while not state.finished:
        frame = source.next_frame(seen)
        if frame is None:
            return
        world = step(world, smooth(frame))
        after = snapshot(world)
        state, events = advance(state, seen_in(after), rules)
        world, put_back = respawn(world, rules, state, start, after.position)
        judged = seen_in(after, shown(state, frame.timestamp))
        if put_back:
            after = snapshot(world)
        seen = seen_in(after, judged.display) if put_back else judged
        yield Moment(frame, world, after, state, judged, tuple(events + put_back))
