"""The simulated participant: a seeded motor model that plays the pick-and-place task in closed
loop with the physics and delivers Leap-shaped hand frames (see ``participant``)."""

from .participant import SimulatedParticipant
from .plan import PickPlacePlan, TaskDisplay
from .skill import BEGINNER, PROFILES, VETERAN, SkillProfile, practised, skill_profile

__all__ = [
           "BEGINNER",
           "PROFILES",
           "VETERAN",
           "PickPlacePlan",
           "SimulatedParticipant",
           "SkillProfile",
           "TaskDisplay",
           "practised",
           "skill_profile",
]
