"""Skill: how fast, how accurately and how steadily a simulated participant moves in one task.

A ``SkillProfile`` holds one person's motor parameters at one moment of practice. A study's
simulated participants each draw their own from a population (``population``: every parameter's
mean and spread between people, in a profile file) and practice moves them along the power law of
practice task by task, the practice of earlier sessions discounted by the days since
(``population.practise``); ``person_skill`` makes the profile for one task.
The two fixed profiles ``VETERAN`` and ``BEGINNER`` (every participant the same) remain for
benches and tests. What each parameter means, its unit and where its value comes from is in
``population.PARAMETERS`` and docs/simulated-participant.md; nothing here is tuned to make an
interaction model look good: every model is played with the same numbers.

- Movement time, Fitts' law T = a + b log2(D / W + 1), carrying slower than reaching
  (``carry_slowdown``), and more slowly still with an elongated object (``shape_caution``).
- Aim: endpoint error SD per axis (van Beers et al. 2004: SD 3-8 mm for 10-20 cm reaches).
- Reaction and hesitation before each new movement (simple visual reaction about 0.25 s), an
  extra pause before the first reach for an object not handled before in the session
  (``new_object_pause_s``) and after a drop (``drop_pause_s``).
- Tremor: RMS per axis (Becker et al. 2008); see ``noise``.
- Grip: the pre-shape opens ``preshape_margin`` beyond each face; closing speed per side; the grip
  is sized for the expected load with a safety margin (grip force 20-40 % above the slip limit,
  Johansson and Westling 1984), through the participant's belief of how stiff a pressed phalanx is;
  after a drop the grip is raised by ``drop_grip_gain`` of itself for the rest of the task (a slip
  raises the grip force, and it stays raised in the lifts that follow: Johansson and Westling 1984).
- Holding: the participant times the hold on its own clock (Weber fraction of interval timing
  about 0.05-0.15, Grondin 2010) and holds ``hold_margin_s`` longer than required.
- Grip lapses: a bare hand feels no grip, so during a carry its grip may open by itself
  (``grip_lapse``, the chance per carry); once a drop in the task has shown it, the participant
  minds its grip and no longer lapses in that task. Practice makes lapses rarer.
- Placement: the object must be within ``place_accept`` of the place radius before the
  participant starts holding; otherwise it makes a corrective sub-movement.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from .population import EarlierSessions, Population, practise


@dataclass(frozen=True)
class SkillProfile:
    """One participant's motor skill; every field in SI units (s, m, m/s)."""

    name: str
    movement_intercept: float
    """a in Fitts' law (s)."""
    movement_slope: float
    """b in Fitts' law (s per bit)."""
    carry_slowdown: float
    """Movement times with the object held are this many times longer."""
    aim_sd: float
    """SD (m) of the endpoint error per axis."""
    reaction_s: float
    """Pause before every new movement (s)."""
    hesitation_s: float
    """Mean of an extra exponential pause before every new movement (s)."""
    tremor_rms: float
    """Physiological tremor, RMS per axis (m)."""
    preshape_margin: float
    """How far each pressing phalanx stays from its face while the hand approaches (m)."""
    closing_speed: float
    """How fast each side of the grip closes (m/s)."""
    grip_safety: float
    """Grip force over the force needed to hold the expected load."""
    stiffness_belief_sd: float
    """Log-normal SD of the participant's belief of contact stiffness (sizes the squeeze)."""
    hold_margin_s: float
    """Extra hold time beyond the required one (s)."""
    clock_cv: float
    """Coefficient of variation of the internal clock over one hold."""
    place_accept: float
    """Fraction of the place radius the object must be within before holding starts."""
    shape_caution: float = 0.0
    """Extra movement time per unit of log elongation (longest over shortest extent) of the object."""
    new_object_pause_s: float = 0.0
    """Mean of an extra pause before the first reach for an object not handled before (s)."""
    drop_pause_s: float = 0.0
    """Mean of an extra pause before reaching again after a drop (s)."""
    grip_lapse: float = 0.0
    """Chance that the grip lapses open during a carry, until a drop in the task (then the
    participant minds its grip)."""
    drop_grip_gain: float = 0.0
    """The grip force is raised by this fraction of itself for each drop in the task."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "name":
                if not isinstance(value, str) or not value:
                    raise ValueError(f"SkillProfile.name = {value!r}: must be a non-empty string")
            elif not isinstance(value, (int, float)) or isinstance(value, bool) or not value >= 0:
                raise ValueError(f"SkillProfile({self.name}).{f.name} = {value!r}: must be a number >= 0")
        if not self.grip_lapse <= 1:
            raise ValueError(f"SkillProfile({self.name}).grip_lapse = {self.grip_lapse}: must be a probability")
        if not 0 < self.place_accept <= 1:
            raise ValueError(f"SkillProfile({self.name}).place_accept = {self.place_accept}: must lie in (0, 1]")


VETERAN = SkillProfile(
    name="veteran", movement_intercept=0.30, movement_slope=0.15, carry_slowdown=1.25, aim_sd=0.003,
    reaction_s=0.25, hesitation_s=0.15, tremor_rms=50e-6, preshape_margin=0.010, closing_speed=0.04,
    grip_safety=1.4, stiffness_belief_sd=0.10, hold_margin_s=0.5, clock_cv=0.05, place_accept=0.5)

BEGINNER = SkillProfile(
    name="beginner", movement_intercept=0.40, movement_slope=0.25, carry_slowdown=1.5, aim_sd=0.006,
    reaction_s=0.35, hesitation_s=0.6, tremor_rms=100e-6, preshape_margin=0.012, closing_speed=0.07,
    grip_safety=1.4, stiffness_belief_sd=0.40, hold_margin_s=1.0, clock_cv=0.10, place_accept=0.7)

PROFILES: dict[str, SkillProfile] = {p.name: p for p in (VETERAN, BEGINNER)}


def skill_profile(name: str) -> SkillProfile:
    """The fixed profile called ``name`` (``veteran`` or ``beginner``); the error lists them."""
    try:
        return PROFILES[name]
    except KeyError:
        raise ValueError(f"skill = {name!r}: unknown profile (known: {sorted(PROFILES)})") from None


def person_skill(population: Population, participant_seed: int, tasks_done: int,
                 earlier_sessions: EarlierSessions = ()) -> SkillProfile:
    """The skill of the participant whose seed is ``participant_seed``, drawn from ``population``,
    after ``tasks_done`` tasks of practice in this session and the tasks of ``earlier_sessions``
    ((days before this session, tasks done), oldest first) as much as they are retained."""
    values = practise(population.draw(participant_seed), tasks_done, earlier_sessions)
    earlier = "".join(f"+{tasks}@{days:g}d" for days, tasks in earlier_sessions)
    return SkillProfile(name=f"{Path(population.where).stem}:{participant_seed}:{tasks_done}{earlier}",
                        **{f.name: values[f.name] for f in fields(SkillProfile) if f.name != "name"})
