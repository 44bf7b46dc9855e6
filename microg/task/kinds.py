"""The task kinds, each its rules' state machine: what ``play`` runs for a task's ``rules.kind``.

Every kind has a state (``stage``, ``held``, ``attempts``, ``finished``, ``completion_time``, and
the place fields the frame log keeps), ``advance(state, observation, rules) -> (state, events)``,
``displayed(state, t)`` and ``measures(state)``: the kind's own measures of a finished task, by the
names of their columns in the trials table (none for the pick-and-place, whose measures are the
task's time and attempts).
"""

from __future__ import annotations

from typing import Callable, NamedTuple

from . import catch, handover, send, stages, stop_spin
from .rules import CATCH, HANDOVER, PICK_AND_PLACE, SEND, STOP_SPIN


class Kind(NamedTuple):
    state: type
    """Its state's type; ``state()`` is the state before the first frame."""
    advance: Callable
    displayed: Callable
    measures: Callable
    stages: tuple[str, ...]
    """Its stages, in order."""


def _none(state) -> dict:
    """The pick-and-place's own measures: none besides time and attempts."""
    return {}


KIND = {
    PICK_AND_PLACE: Kind(stages.TaskState, stages.advance, stages.displayed, _none, stages.STAGES),
    CATCH: Kind(catch.CatchState, catch.advance, catch.displayed, catch.measures, catch.STAGES),
    STOP_SPIN: Kind(stop_spin.StopSpinState, stop_spin.advance, stop_spin.displayed, stop_spin.measures,
                    stop_spin.STAGES),
    SEND: Kind(send.SendState, send.advance, send.displayed, send.measures, send.STAGES),
    HANDOVER: Kind(handover.HandoverState, handover.advance, handover.displayed, handover.measures,
                   handover.STAGES),
}
"""Each kind by its name (``microg.task.rules.KINDS``)."""
MEASURES = {"time_to_catch_s": CATCH, "time_to_rest_s": STOP_SPIN, "flipped": STOP_SPIN, "send_error_m": SEND,
            "release_speed_error": SEND, "transfer_time_s": HANDOVER, "both_held_s": HANDOVER}
"""Each kind's own measures and the kind that has it."""
