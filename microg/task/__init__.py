"""The tasks, written once: the pick-and-place (paper, section 4.3) and the kinds microgravity asks for.

    for moment in play(world, tracked, rules):   # one frame each (tracked: microg.hands.tracking)
        moment.state.stage, moment.events

``rules`` (the numbers, from a protocol, and the task's kind), ``observation`` (what the task and a
participant see of the world), the rules of each kind as a pure state machine with what the task
displays (``stages``: the pick-and-place; ``catch``; ``stop_spin``; ``holding``, the hold they
share; ``kinds``, which is which), ``respawn`` (a lost object goes back) and ``play`` (the frame
loop every task runs).
"""

from .observation import Observation, observe
from .play import Moment, play
from .respawn import inside_workspace, respawn
from .rules import KINDS, TaskRules
from .stages import COMPLETED, FINAL, MAINTENANCE, MANIPULATION, RELEASE, TIMEOUT, TaskDisplay, TaskEvent, TaskState, \
    advance, displayed

__all__ = ["COMPLETED", "FINAL", "KINDS", "MAINTENANCE", "MANIPULATION", "Moment", "Observation", "RELEASE", "TIMEOUT",
           "TaskDisplay", "TaskEvent", "TaskRules", "TaskState", "advance", "inside_workspace", "observe", "play",
           "respawn", "displayed"]
