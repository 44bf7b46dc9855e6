"""Where a session's hand frames come from: ``--input leap | replay:FILE | simulated[:PROFILE]``.

``open_inputs(spec)`` gives an ``Inputs``: it opens one ``HandSource`` per task (a live tracker
stays open across tasks; a recording replays from its start; a simulated participant gets the
task's plan and seed). The hand-input and participant modules are imported only when used.
``participant_plan`` is the one place that turns a protocol task into what its player knows.
"""

from __future__ import annotations

import typing
from pathlib import Path
from typing import Callable

from microg.hands.source import Borrowed, HandSource
from microg.participant.plan import TaskPlan

from microg.participant import Population, PopulationError, SkillProfile

from .protocol import PRACTICE, Group, Protocol, profile_names, simulated_player
from .store import PlannedTask


class InputError(ValueError):
    """An ``--input`` that cannot be opened; the message says what is missing."""


def participant_plan(protocol: Protocol, task: PlannedTask, hand: str = "right", participant: str = "", *,
                     participant_seed: int = 0, first_with_object: bool = True,
                     tasks_done: int | None = None, earlier_sessions: tuple[tuple[float, int], ...] = ()) -> TaskPlan:
    """The one place that turns a protocol's task into what its player knows of it: its phase's
    rules at the task's difficulty; ``tasks_done`` the session's tasks before it (default: its index);
    ``earlier_sessions`` the participant's sessions before this one (``TaskPlan.earlier_sessions``)."""
    start, _ = protocol.start_pose(task.object)
    return TaskPlan(object=protocol.object(task.object).spec, start=start,
                    rules=protocol.rules(task.phase, task.difficulty), gravity=protocol.gravity, hand=hand,
                    tasks_done=task.index if tasks_done is None else tasks_done, participant=participant,
                    phase=task.phase, participant_seed=participant_seed, first_with_object=first_with_object,
                    earlier_sessions=earlier_sessions)


class Inputs(typing.Protocol):
    spec: str
    """As given on the command line; stored with the session."""
    simulated: bool
    """Frames from a simulated participant: the tables mark its data as simulated."""
    clock: str
    """``wall`` for live input, ``simulation`` otherwise."""

    def open(self, plan: TaskPlan, seed: int) -> HandSource:
        """The hand source for one task."""

    def close(self) -> None: ...


class LiveInputs:
    clock = "wall"
    simulated = False

    def __init__(self, spec: str, source: HandSource):
        self.spec = spec
        self._source: HandSource | None = source

    def open(self, plan: TaskPlan, seed: int) -> HandSource:
        if self._source is None:
            self._source = _open_tracking(self.spec)
        return Borrowed(self._source)

    def close(self) -> None:
        if self._source is not None:
            self._source.close()
            self._source = None


class SimulatedInputs:
    """A simulated participant (``microg.participant``) plays each task. From a population (the
    default one for ``practice``, or a profile file), each participant draws their own parameters,
    from their own seed, and each task done (training included) improves them by the power law of
    practice; ``veteran`` and ``beginner`` are fixed skills, the same for everyone."""

    clock = "simulation"
    simulated = True

    def __init__(self, spec: str, player: Population | SkillProfile):
        self.spec, self.player = spec, player

    def skill(self, plan: TaskPlan) -> SkillProfile:
        """The participant's skill in this task: drawn from the population (from the participant's
        seed) and practised by the tasks done, today and in earlier sessions (part of which is
        forgotten), or the fixed one."""
        from microg.participant import person_skill

        if isinstance(self.player, Population):
            return person_skill(self.player, plan.participant_seed, plan.tasks_done, plan.earlier_sessions)
        return self.player

    @staticmethod
    def time_limit_s(plan: TaskPlan) -> float:
        """The participant's own clock stops this long (s) into a task: after the task's timeout."""
        return plan.rules.timeout_s + 10.0

    def open(self, plan: TaskPlan, seed: int) -> HandSource:
        from microg.participant import HandingParticipant, SimulatedParticipant
        from microg.task import KINDS

        both = KINDS[plan.rules.kind].play.then == "hand_over"
        play = HandingParticipant if both else SimulatedParticipant
        return play(plan, self.skill(plan), seed, time_limit_s=self.time_limit_s(plan))

    def close(self) -> None:
        pass


class PacedInputs:
    """Another ``Inputs`` whose frames come no faster than their timestamps say (``speed`` times real
    time): a replayed or simulated session that a person watches on the participant's display."""

    def __init__(self, inputs: Inputs, speed: float = 1.0):
        self.inputs, self.speed = inputs, speed
        self.spec, self.simulated, self.clock = inputs.spec, inputs.simulated, inputs.clock

    def open(self, plan: TaskPlan, seed: int) -> HandSource:
        from microg.hands.source import Paced

        return Paced(self.inputs.open(plan, seed), self.speed)

    def close(self) -> None:
        self.inputs.close()


class ScriptedInputs:
    """Any function ``(plan, seed) -> HandSource`` as a session's input (tests, custom drivers)."""

    def __init__(self, make: Callable[[TaskPlan, int], HandSource], spec: str = "scripted",
                 simulated: bool = True, clock: str = "simulation"):
        self.make, self.spec, self.simulated, self.clock = make, spec, simulated, clock

    def open(self, plan: TaskPlan, seed: int) -> HandSource:
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
    """(kind, argument) of an ``--input``: ``leap``, ``webxr``, ``lsl:STREAM_NAME``, ``replay:FILE``
    or ``simulated[:PROFILE]``."""
    kind, _, argument = spec.partition(":")
    if spec in ("leap", "webxr") or kind == "simulated" or (kind in ("replay", "lsl") and argument):
        return kind, argument
    if kind in ("replay", "lsl"):
        raise InputError(f"--input {spec!r}: give the " + ("recording, as replay:FILE" if kind == "replay"
                                                            else "stream's name, as lsl:STREAM_NAME"))
    raise InputError(f"--input {spec!r}: must be leap, webxr, lsl:STREAM_NAME, replay:FILE or simulated[:PROFILE]")


def open_inputs(spec: str, group: Group | None = None, webxr: HandSource | None = None,
                align: str | None = None) -> Inputs:
    """Parse ``--input`` and check that what it needs is installed; ``simulated`` without a
    profile plays ``group``'s (``Group.player``); ``webxr`` is the source the participant's page
    feeds (``microg.hands.webxr``); ``align`` places replayed recordings (``microg.study.replay``)."""
    kind, argument = parse_input(spec)
    if align is not None and kind != "replay":
        raise InputError(f"--align {align}: only replayed recordings are placed in the workspace")
    if kind == "webxr":
        if webxr is None:
            raise InputError("--input webxr: the hands come from the participant's page; run with --display")
        return LiveInputs(spec, webxr)
    if kind == "simulated":
        if argument:
            try:
                player = simulated_player(argument, Path.cwd())
            except (ValueError, PopulationError) as error:
                raise InputError(f"--input {spec!r}: {error}") from None
            if player is None:
                raise InputError(f"--input {spec!r}: {argument!r} is no profile: give a population file (.toml) or "
                                 f"one of {', '.join(profile_names())}")
            return SimulatedInputs(f"simulated:{argument}", player)
        if group is None:
            raise InputError(f"--input {spec!r}: give a profile, as simulated:{PRACTICE}, simulated:literature, "
                             f"simulated:veteran, simulated:beginner or simulated:PROFILE.toml")
        return SimulatedInputs("simulated", group.player)
    if kind in ("leap", "lsl"):
        return LiveInputs(spec, _open_tracking(spec))  # the device answers before any session starts
    from .replay import ReplayError, ReplayInputs

    target = Path(argument)
    try:
        if target.suffix != ".toml":
            _open_tracking(spec).close()  # the recording reads before any session starts
        return ReplayInputs(spec, target, align)
    except ReplayError as error:
        raise InputError(str(error)) from None
