"""The simulated participant: a seeded motor model that plays the pick-and-place task in closed
loop with the physics and delivers Leap-shaped hand frames (see ``participant``); the rating model
that answers the questionnaire for it (``ratings``)."""

from .participant import SimulatedParticipant
from .plan import TaskPlan
from .skill import BEGINNER, PROFILES, VETERAN, SkillProfile, practised, skill_profile

__all__ = [
    "BEGINNER",
    "PROFILES",
    "VETERAN",
    "SimulatedParticipant",
    "SkillProfile",
    "TaskPlan",
    "practised",
    "skill_profile",
]
