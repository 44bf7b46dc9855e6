"""Where a session's hand frames come from: ``--input leap | replay:FILE | simulated[:PROFILE]``.

``open_inputs(spec)`` gives an ``Inputs``: it opens one ``HandSource`` per task (a live tracker
stays open across tasks; a recording replays from its start; a simulated participant gets the
task's plan and seed). The hand-input and participant modules are imported only when used.
``participant_plan`` is the one place that turns a protocol task into what a simulated
participant needs to know.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol as Interface

from microg.sim import HandFrame, ObjectSpec, World
from microg.participant import TaskDisplay
from microg.hands.source import HandSource

from .protocol import Protocol
from .store import PlannedTask


PRACTICE = "practice"
"""The simulated profile whose skill grows with the tasks done (see ``SimulatedInputs``)."""


Display = Callable[[], TaskDisplay]
"""What the task shows right now (the place marks, the stage): a simulated participant watches it."""


class InputError(ValueError):
    """An ``--input`` that cannot be opened; the message says what is missing."""


@dataclass(frozen=True)
class ParticipantPlan:
    """One task as a simulated participant sees it (positions in metres, tracker frame)."""

    object: str
    spec: ObjectSpec
    start: tuple[float, float, float]
    start_orientation: tuple[float, float, float, float]
    places: tuple[tuple[float, float, float], ...]
    place_radius: float
    hold_s: float
    timeout_s: float
    gravity: tuple[float, float, float]
    table_height: float | None
    """The table the object starts on (m), or None (microgravity)."""
    system: str
    phase: str
    tracking_rate: float
    hand: str = "right"
    """The hand the participant uses (their dominant one)."""
    tasks_done: int = 0
    """Tasks this participant did before this one in the session (training included)."""


def participant_plan(protocol: Protocol, task: PlannedTask, hand: str = "right") -> ParticipantPlan:
    rules = protocol.task
    start, start_orientation = protocol.start_pose(task.object)
    return ParticipantPlan(object=task.object, spec=protocol.object(task.object).spec, start=start,
                           start_orientation=start_orientation, places=rules.places,
                           place_radius=rules.place_radius, hold_s=rules.hold_s, timeout_s=rules.timeout_s,
                           gravity=protocol.gravity, table_height=protocol.table_height, system=task.system,
                           phase=task.phase, tracking_rate=protocol.tracking_rate,
                           hand=hand, tasks_done=task.index)


class Inputs(Interface):
    spec: str
    """As given on the command line; stored with the session."""
    simulated: bool
    """Frames from a simulated participant: the tables mark its data as simulated."""
    clock: str
    """``wall`` for live input, ``simulation`` otherwise."""

    def open(self, plan: ParticipantPlan, seed: int, display: Display | None = None) -> HandSource:
        """The hand source for one task; ``display`` shows the task's marks to a simulated participant."""

    def close(self) -> None: ...


class _Borrowed:
    """A view of a source that stays open after the task (the live tracker serves every task)."""

    def __init__(self, source: HandSource):
        self._source = source
        self.description = source.description

    def next_frame(self, world: World | None = None) -> HandFrame | None:
        return self._source.next_frame(world)

    def close(self) -> None:
        pass


class LiveInputs:
    clock = "wall"
    simulated = False

    def __init__(self, spec: str, source: HandSource):
        self.spec = spec
        self._source: HandSource | None = source

    def open(self, plan: ParticipantPlan, seed: int, display: Display | None = None) -> HandSource:
        if self._source is None:
            self._source = _open_tracking(self.spec)
        return _Borrowed(self._source)

    def close(self) -> None:
        if self._source is not None:
            self._source.close()
            self._source = None


class ReplayInputs:
    clock = "simulation"
    simulated = False

    def __init__(self, spec: str):
        self.spec = spec

    def open(self, plan: ParticipantPlan, seed: int, display: Display | None = None) -> HandSource:
        return _open_tracking(self.spec)

    def close(self) -> None:
        pass


class SimulatedInputs:
    """A simulated participant (``microg.participant``) plays each task. Profile ``practice``
    starts every participant new to the system and lets each task done (training included) improve
    the skill by the power law of practice; ``veteran`` and ``beginner`` are fixed skills."""

    clock = "simulation"
    simulated = True

    def __init__(self, spec: str, profile: str):
        self.spec, self.profile = spec, profile

    def open(self, plan: ParticipantPlan, seed: int, display: Display | None = None) -> HandSource:
        from microg.participant import PickPlacePlan, SimulatedParticipant

        skill = f"practised:{plan.tasks_done}" if self.profile == PRACTICE else self.profile
        task = PickPlacePlan(object_name=plan.object, places=plan.places, hold_s=plan.hold_s,
                             place_radius=plan.place_radius, side=plan.hand)
        return SimulatedParticipant(task, skill, seed, time_limit_s=plan.timeout_s + 10.0, display=display)

    def close(self) -> None:
        pass


class ScriptedInputs:
    """Any function ``(plan, seed) -> HandSource`` as a session's input (tests, custom drivers)."""

    def __init__(self, make: Callable[[ParticipantPlan, int], HandSource], spec: str = "scripted",
                 simulated: bool = True, clock: str = "simulation"):
        self.make, self.spec, self.simulated, self.clock = make, spec, simulated, clock

    def open(self, plan: ParticipantPlan, seed: int, display: Display | None = None) -> HandSource:
        return self.make(plan, seed)

    def close(self) -> None:
        pass


def _open_tracking(spec: str) -> HandSource:
    try:
        from microg.hands import open_source

        return open_source(spec)
    except (ValueError, OSError, ImportError, RuntimeError) as error:
        raise InputError(f"--input {spec}: {error}") from None


def parse_input(spec: str) -> tuple[str, str]:
    """(kind, argument) of an ``--input``: ``leap``, ``replay:FILE`` or ``simulated[:PROFILE]``."""
    kind, _, argument = spec.partition(":")
    if spec == "leap" or kind == "simulated" or (kind == "replay" and argument):
        return kind, argument
    if kind == "replay":
        raise InputError(f"--input {spec!r}: give the recording, as replay:FILE")
    raise InputError(f"--input {spec!r}: must be leap, replay:FILE or simulated[:PROFILE]")


def open_inputs(spec: str, group_profile: str | None = None) -> Inputs:
    """Parse ``--input`` and check that what it needs is installed; ``simulated`` without a
    profile plays ``group_profile``."""
    kind, argument = parse_input(spec)
    if kind == "simulated":
        from microg.participant import skill_profile

        profile = argument or group_profile
        if not profile:
            raise InputError(f"--input {spec!r}: give a skill profile, as simulated:practice, simulated:veteran "
                             f"or simulated:beginner")
        if profile != PRACTICE:
            try:
                skill_profile(profile)
            except ValueError as error:
                raise InputError(f"--input {spec!r}: {error}; or {PRACTICE}") from None
        return SimulatedInputs(f"simulated:{profile}", profile)
    source = _open_tracking(spec)  # the device answers, the recording reads: before any session starts
    if kind == "leap":
        return LiveInputs(spec, source)
    source.close()
    return ReplayInputs(spec)
