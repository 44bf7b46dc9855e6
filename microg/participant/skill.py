"""Skill profiles: how fast, how accurately and how steadily a simulated participant moves.

The two profiles follow the paper's groups: a *veteran* trained with the interaction model before the test,
a *beginner* did not. Where a number comes from the motor-control literature it says so; where it
is a modelling choice it says that too. Nothing here is tuned to make an interaction model look
good: both profiles run every model with the same numbers.

- Movement time, Fitts' law T = a + b log2(D / W + 1): reaches of 10-20 cm to targets a few cm
  wide take 0.5-0.8 s for the veteran, in the range of prehension times for such distances
  (Jeannerod 1984: 0.6-1 s for 20-30 cm); the beginner's slope is higher, as mid-air Leap pointing
  is about twice as slow as with a mouse for the untrained (Bachmann et al. 2015). Carrying a held
  object is slower than reaching (``carry_slowdown``; a modelling choice).
- Aim: endpoint error SD per axis; reaching endpoints scatter by a few millimetres when trained
  (van Beers et al. 2004: SD 3-8 mm for 10-20 cm reaches); the beginner's doubled.
- Reaction and hesitation before each new movement: simple visual reaction about 0.25 s; the
  beginner adds longer, exponentially distributed pauses (a modelling choice).
- Tremor: RMS per axis, 50 um (a steady, trained hand) and 100 um (Becker et al. 2008 mean under
  strain); see ``noise``.
- Grip: the pre-shape opens ``preshape_margin`` beyond each face (the measured hand cannot open
  much more than 12 mm around a 6 cm cube); closing speed per side; the grip is sized for the
  expected load with a safety margin of 1.4 (grip force 20-40 % above the slip limit, Johansson and
  Westling 1984), through the participant's belief of how stiff a pressed phalanx is; the
  veteran's belief is calibrated by training (10 % error), the beginner's is not (40 %).
- Holding: the participant times the hold on its own clock (Weber fraction of interval timing
  about 0.05-0.15, Grondin 2010) and holds ``hold_margin_s`` longer than required, about three
  clock SDs so a hold is rarely cut short.
- Placement: the object must be within ``place_accept`` of the place radius before the
  participant starts holding; otherwise it makes a corrective sub-movement.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace


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

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "name":
                if not isinstance(value, str) or not value:
                    raise ValueError(f"SkillProfile.name = {value!r}: must be a non-empty string")
            elif not isinstance(value, (int, float)) or isinstance(value, bool) or not value >= 0:
                raise ValueError(f"SkillProfile({self.name}).{f.name} = {value!r}: must be a number >= 0")
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

PRACTICE_EXPONENT = 0.4
"""Power law of practice: what separates a novice from a trained user shrinks as (1 + n)^-0.4
after n tasks done (exponents of 0.2-0.6 are typical for perceptual-motor tasks, Newell and
Rosenbloom 1981; the middle of that range, not fitted to anything)."""


def practised(tasks_done: int) -> SkillProfile:
    """The skill of someone new to the interaction model after ``tasks_done`` tasks with it: the beginner's
    profile at 0, moving toward the veteran's (the trained asymptote) along the power law of practice.

    A study whose simulated participants all play this profile gets any difference between trained
    and untrained groups from the practice the training gave, not from a label."""
    if not isinstance(tasks_done, int) or tasks_done < 0:
        raise ValueError(f"tasks_done = {tasks_done!r}: must be a whole number >= 0")
    remaining = (1.0 + tasks_done) ** -PRACTICE_EXPONENT
    values = {}
    for f in fields(SkillProfile):
        if f.name != "name":
            trained, novice = getattr(VETERAN, f.name), getattr(BEGINNER, f.name)
            values[f.name] = trained + remaining * (novice - trained)
    return replace(BEGINNER, name=f"practised:{tasks_done}", **values)


def skill_profile(name: str) -> SkillProfile:
    """The profile called ``name`` (``veteran``, ``beginner`` or ``practised:N``); the error lists the known ones."""
    kind, _, count = name.partition(":")
    if kind == "practised" and count.isdigit():
        return practised(int(count))
    try:
        return PROFILES[name]
    except KeyError:
        raise ValueError(f"skill = {name!r}: unknown profile (known: {sorted(PROFILES)}, practised:N)") from None
