"""A task's numbers: where the object starts, the limits every kind shares, and each kind's own.

A task is of one *kind*: ``pick_and_place`` (the paper's, ``microg.task.stages``), ``catch``
(``microg.task.catch``), ``stop_spin`` (``microg.task.stop_spin``), ``send`` (``microg.task.send``)
or ``handover`` (``microg.task.handover``). Every kind reads the start, the timeout, the holding's
settle and grace times and the workspace; the places and their holds are the pick-and-place's;
``CatchRules``, ``StopSpinRules``, ``SendRules`` and ``HandoverRules`` hold the other kinds' numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

PICK_AND_PLACE, CATCH, STOP_SPIN, SEND, HANDOVER = "pick_and_place", "catch", "stop_spin", "send", "handover"
KINDS = (PICK_AND_PLACE, CATCH, STOP_SPIN, SEND, HANDOVER)
"""The task kinds a protocol may choose (``kind = ...``)."""


@dataclass(frozen=True)
class CatchRules:
    """A catch: the object leaves the task's start at ``launch_speed`` (m/s) along ``direction`` (a
    unit vector, tracker frame) turning at ``spin`` (rad/s, tracker frame), and is caught once held
    for ``hold_s`` (s)."""

    launch_speed: float
    direction: tuple[float, float, float]
    spin: tuple[float, float, float]
    hold_s: float


@dataclass(frozen=True)
class StopSpinRules:
    """A stop of a spin: the object floats at the task's start turning at ``spin_rate`` (rad/s) about
    ``spin_axis`` (a unit vector in the object's own frame: an intermediate axis makes it flip); it is
    at rest once it turns slower than ``rest_omega`` (rad/s) while held or moving slower than
    ``rest_speed`` (m/s), and stopped once at rest for ``hold_s`` (s)."""

    spin_axis: tuple[float, float, float]
    spin_rate: float
    rest_omega: float
    rest_speed: float
    hold_s: float


@dataclass(frozen=True)
class SendRules:
    """A send: the object released so that it drifts into the target zone, a sphere of ``radius`` (m)
    about ``target`` (tracker frame), where a colleague catches it; ``arrival_s`` (s) is how long the
    drift from the release point to the target's centre should take (the right release speed)."""

    target: tuple[float, float, float]
    radius: float
    arrival_s: float


@dataclass(frozen=True)
class HandoverRules:
    """A handover: the object taken by the ``first_hand`` (``left`` or ``right``), passed to the other
    hand, and held by that hand alone inside the place zone, a sphere of ``radius`` (m) about
    ``place`` (tracker frame), for ``hold_s`` (s)."""

    first_hand: str
    place: tuple[float, float, float]
    radius: float
    hold_s: float


def timeout_reason(rules: TaskRules) -> str:
    """Why a task that ran out of time was not completed, as its run records it."""
    return f"not completed within timeout_s = {rules.timeout_s:g} s"


@dataclass(frozen=True)
class TaskRules:
    """A task's numbers (a protocol's ``task`` table sets them): the pick-and-place's (``stages``
    applies them), shared by every kind but the places, and the other kinds' own."""

    start: tuple[float, float, float]
    start_orientation: tuple[float, float, float, float]
    places: tuple[tuple[float, float, float], ...]
    place_radius: float
    hold_s: float
    timeout_s: float
    grasp_settle_s: float
    drop_grace_s: float
    workspace_min: tuple[float, float, float]
    workspace_max: tuple[float, float, float]
    kind: str = PICK_AND_PLACE
    """Which rules judge the task (``KINDS``)."""
    catch: CatchRules | None = None
    """The catch's numbers (``task.catch``); None when the protocol has none."""
    stop_spin: StopSpinRules | None = None
    """The stop of a spin's numbers (``task.stop_spin``); None when the protocol has none."""
    send: SendRules | None = None
    """The send's numbers (``task.send``); None when the protocol has none."""
    handover: HandoverRules | None = None
    """The handover's numbers (``task.handover``); None when the protocol has none."""
