"""The simulated participant: a seeded motor model that plays every task kind in closed loop with
the physics and delivers Leap-shaped hand frames (see ``participant``); the population
each participant's parameters are drawn from (``population``); the rating model that answers the
questionnaire for it (``ratings``)."""

from .participant import HandingParticipant, SimulatedParticipant
from .plan import TaskPlan
from .population import Population, PopulationError, default_population, read_population
from .skill import BEGINNER, PROFILES, VETERAN, SkillProfile, person_skill, skill_profile

__all__ = [
    "BEGINNER",
    "PROFILES",
    "Population",
    "PopulationError",
    "VETERAN",
    "HandingParticipant",
    "SimulatedParticipant",
    "SkillProfile",
    "TaskPlan",
    "default_population",
    "person_skill",
    "read_population",
    "skill_profile",
]
