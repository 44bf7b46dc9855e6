"""The pick-and-place task (paper, section 4.3), written once: its stages, holds, drops and places.

    for moment in play(world, tracked, rules):   # one frame each (tracked: microg.hands.tracking)
        moment.state.stage, moment.events

``rules`` (the numbers, from a protocol), ``observation`` (what the task and a participant see
of the world), ``stages`` (the rules as a pure state machine, and what the task displays),
``respawn`` (a lost object goes back) and ``play`` (the frame loop every task runs).
"""

from .observation import Observation, observe
from .play import Moment, play
from .respawn import inside_workspace, respawn
from .rules import TaskRules
from .stages import COMPLETED, FINAL, MAINTENANCE, MANIPULATION, RELEASE, TIMEOUT, TaskDisplay, TaskEvent, TaskState, \
    advance, displayed

__all__ = ["COMPLETED", "FINAL", "MAINTENANCE", "MANIPULATION", "Moment", "Observation", "RELEASE", "TIMEOUT",
           "TaskDisplay", "TaskEvent", "TaskRules", "TaskState", "advance", "inside_workspace", "observe", "play",
           "respawn", "displayed"]
