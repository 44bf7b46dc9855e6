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
from microg.sim.tracking.source import HandSource

from .protocol import Protocol
from .store import PlannedTask


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


def participant_plan(protocol: Protocol, task: PlannedTask) -> ParticipantPlan:
    rules = protocol.task
    start, start_orientation = protocol.start_pose(task.object)
    return ParticipantPlan(object=task.object, spec=protocol.object(task.object).spec, start=start,
                           start_orientation=start_orientation, places=rules.places,
                           place_radius=rules.place_radius, hold_s=rules.hold_s, timeout_s=rules.timeout_s,
                           gravity=protocol.gravity, table_height=protocol.table_height, system=task.system,
                           phase=task.phase,
                           tracking_rate=float(protocol.scene_options.get("tracking_rate", 110.0)))


class Inputs(Interface):
    spec: str
    """As given on the command line; stored with the session."""
    simulated: bool
    """Frames from a simulated participant: the tables mark its data as simulated."""
    clock: str
    """``wall`` for live input, ``simulation`` otherwise."""

    def open(self, plan: ParticipantPlan, seed: int) -> HandSource: ...

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

    def open(self, plan: ParticipantPlan, seed: int) -> HandSource:
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

    def open(self, plan: ParticipantPlan, seed: int) -> HandSource:
        return _open_tracking(self.spec)

    def close(self) -> None:
        pass


class SimulatedInputs:
    clock = "simulation"
    simulated = True

    def __init__(self, spec: str, profile: str):
        self.spec, self.profile = spec, profile

    def open(self, plan: ParticipantPlan, seed: int) -> HandSource:
        participant = _participant_module(f"--input {self.spec}", "simulated_participant")
        return participant.simulated_participant(plan, profile=self.profile, seed=seed)

    def close(self) -> None:
        pass


class ScriptedInputs:
    """Any function ``(plan, seed) -> HandSource`` as a session's input (tests, custom drivers)."""

    def __init__(self, make: Callable[[ParticipantPlan, int], HandSource], spec: str = "scripted",
                 simulated: bool = True, clock: str = "simulation"):
        self.make, self.spec, self.simulated, self.clock = make, spec, simulated, clock

    def open(self, plan: ParticipantPlan, seed: int) -> HandSource:
        return self.make(plan, seed)

    def close(self) -> None:
        pass


def _participant_module(spec: str, needs: str):
    """``microg.sim.participant``, checked for the function ``needs`` before any session starts."""
    try:
        from microg.sim import participant
    except ImportError as error:
        raise InputError(f"{spec}: the simulated participant (microg.sim.participant) is not available: "
                         f"{error}") from None
    if not hasattr(participant, needs):
        raise InputError(f"{spec}: microg.sim.participant has no {needs}() yet")
    return participant


def _open_tracking(spec: str) -> HandSource:
    try:
        from microg.sim.tracking import open_source

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
        profile = argument or group_profile
        if not profile:
            raise InputError(f"--input {spec!r}: give a skill profile, as simulated:veteran or simulated:beginner")
        _participant_module(f"--input {spec}", "simulated_participant")
        return SimulatedInputs(f"simulated:{profile}", profile)
    source = _open_tracking(spec)  # the device answers, the recording reads: before any session starts
    if kind == "leap":
        return LiveInputs(spec, source)
    source.close()
    return ReplayInputs(spec)


def open_model_rater(profile: str, seed: int, results: Callable[[str], list[dict]]):
    """Questionnaire answers from the simulated participant's rating model, which is called as
    ``rate(item=..., system=..., profile=..., results=[{object, completed, time_s, attempts}, ...],
    scale=(low, high), seed=...)`` with this participant's own results in that system."""
    from .questionnaire import ModelRater

    module = _participant_module("--questionnaire model (use ask or skip without it)", "rate")
    return ModelRater(lambda item, stage, q: module.rate(
        item=item.name, system=stage.system, profile=profile, results=results(stage.system),
        scale=(q.scale_min, q.scale_max), seed=seed))


def check_model_rater() -> None:
    """Fail now, before a session starts, when there is no rating model."""
    _participant_module("--questionnaire model (use ask or skip without it)", "rate")
