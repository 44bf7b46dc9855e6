"""The tasks, written once: the pick-and-place (paper, section 4.3) and the kinds microgravity asks for.

    lanes = Lanes(KINDS[rules.kind], world, 1, guard=GuardConfig(), window=3)
    lanes.load(0, world, rules)
    for moments in play(lanes, source):     # tracking guard, Eq. 1, the physics, the rules, respawn
        moments.records["stage"], moments.task_events(0)

``kind`` (what a task kind declares), ``kinds`` (the kinds, one module each, and their registry
``KINDS``), ``rules`` (a protocol's numbers for a task), ``observation`` (what a participant
sees of the world), ``play`` (one frame's way, compiled once for sessions and in-silico studies).
"""

from .kind import COMPLETED, TIMEOUT, Kind, TaskDisplay, TaskEvent, TaskState
from .kinds import KINDS, PICK_AND_PLACE, register
from .observation import Observation, observe
from .play import MOMENT, Lanes, Moments, TaskResult, frame_path, play
from .rules import TaskRules

__all__ = ["COMPLETED", "KINDS", "Kind", "Lanes", "MOMENT", "Moments", "Observation", "PICK_AND_PLACE", "TIMEOUT",
           "TaskDisplay", "TaskEvent", "TaskResult", "TaskRules", "TaskState", "frame_path", "observe", "play", "register"]
