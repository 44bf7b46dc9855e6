"""One task played out, frame by frame: a tracked hand in, the physics, the rules, respawn. Written once.

``play`` is the loop every task runs, whoever plays it: a study session (which passes each
``Moment`` to what the frame feeds: the log, the participant's page, LSL), the simulated
participant's bench, a test. Each frame hand tracking (``microg.hands.tracking``: the hand source,
the tracking guard, the window filter) looks at the last ``Observation`` (with what the task
displays) and gives a frame; the physics steps to its smoothed hand (``microg.sim.step``), the
task's rules (its kind's ``advance``: ``stages``, ``catch``, ``stop_spin``) judge the outcome and a
lost object is put back (``respawn``).
"""

from __future__ import annotations

from typing import Iterator, NamedTuple

from microg.sim import Snapshot, World, snapshot, step
from microg.skeleton import HandFrame

from .kinds import KIND
from .observation import Observation, observe, seen_in
from .respawn import respawn
from .rules import TaskRules
from .stages import TaskEvent, TaskState


class Moment(NamedTuple):
    """One frame of a task: the tracked hand, and what the world and the task made of it."""

    frame: HandFrame
    """The frame hand tracking admitted (before the window filter): the tracked hand, as logged."""
    world: World
    after: Snapshot
    """What ``world`` shows of the task's object (``microg.sim.snapshot``)."""
    state: TaskState
    """The task's state (of its kind: ``microg.task.kinds``)."""
    observation: Observation
    """What the task judged (the world before a respawn), with what it now displays."""
    events: tuple[TaskEvent, ...]


def play(world: World, tracked, rules: TaskRules) -> Iterator[Moment]:
    """Run the task on ``world`` with frames from ``tracked`` (``microg.hands.tracking.Tracking``:
    its ``next_frame`` gets the last observation and gives a ``TrackedFrame``) until the task is
    finished or the frames end, judged by the rules of ``rules.kind``; yields every frame's ``Moment``."""
    kind = KIND[rules.kind]
    advance, displayed = kind.advance, kind.displayed
    state = kind.state()
    data = world.data
    start = (data.position[0].copy(), data.orientation[0].copy(), data.velocity[0].copy(),
             data.angular_velocity[0].copy())
    seen = observe(world, display=displayed(state, world.time))
    while not state.finished:
        frame = tracked.next_frame(seen)
        if frame is None:
            return
        world = step(world, frame.smoothed)
        after = snapshot(world)
        state, events = advance(state, seen_in(after), rules)
        world, put_back = respawn(world, rules, state, start, after.position)
        judged = seen_in(after, displayed(state, frame.admitted.timestamp))
        if put_back:
            after = snapshot(world)
        seen = seen_in(after, judged.display) if put_back else judged
        yield Moment(frame.admitted, world, after, state, judged, tuple(events + put_back))
