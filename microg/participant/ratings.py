"""The questionnaire answers of simulated participants: a rating model, labelled as simulated.

A simulated participant feels nothing, so its ratings come from a model fed by what happened in
its own tasks with each interaction model (the study reads it back from its log: ``microg.study.questionnaire``):

- ``attempts_per_task``: attempts (the study's drops) per task;
- ``not_completed``: share of the interaction model's tasks not completed (timeout, aborted);
- ``time_s``: mean completion time of the completed tasks;
- ``penetration_mm``: visible penetration, how far the tracked phalanges sank into the object
  while the rendered hand rested on its surface (mean distance between tracked and rendered
  phalanx centres, over phalanges in contact): the visual conflict the god-object hides;
- ``shake_mm_s``: how much the held object rattled or slid in the hand (RMS speed of the object
  relative to the palm while held).

Each rating is an anchor minus penalties, plus the participant's own leaning and noise::

    naturalness = 7 - 0.15/mm (penetration - 5 mm)+ - 0.02 s/mm (shake - 20 mm/s)+ - 1.0 x attempts/task
    efficiency  = 7 - 0.04/s (time - 20 s)+ - 1.0 x attempts/task - 4 x not_completed

then rounded and clipped to the scale. The leaning is N(0, 1), one draw per participant for all
answers (some people rate high); the noise is N(0, 0.7) per answer. The directions follow what the
paper's participants reported (drops and slow tasks felt inefficient, rich and stable contact felt
natural); the sizes are round numbers chosen before any simulated run and fitted to nothing. The
model is here so a simulated study runs end to end; its ratings say what the model assumes, not
what people feel, and the tables and the report mark them as simulated (``source = model``).

The standard instruments (``microg.instruments``) are answered the same way, by the same measures
and ``exposure_min``, the minutes of tasks done so far in the session. Each instrument has a level
per participant and filling-in; an item's answer is that level on the item's scale (the other end
for a reversed item: a present participant disagrees with "I felt like I was just perceiving
pictures"), plus noise, rounded to the scale's steps and clipped to its ends (``on_scale``):

- SSQ: each symptom 0.15 + s x exposure_min / 20 + N(0, 0.4), s the participant's susceptibility,
  lognormal with median 0.5 (some people get sick, most little): sickness rises with exposure;
- IPQ: presence 0.6 - 0.02/mm (penetration - 5 mm)+ - 0.06 x attempts/task - 0.2 x not_completed
  + N(0, 0.12) for the participant, of the scale's span, + N(0, 0.7) points per item;
- NASA-TLX: each subscale its own workload (``TLX_WORKLOAD``: a base plus 0.2-0.4/s of completion
  time over 20 s, 4-12 per attempt, 20-40 per share not completed), + N(0, 10) for the participant
  and N(0, 8) per rating; a pairwise comparison chooses the subscale rated higher, give or take N(0, 10);
- SUS: usability 0.72 - 0.08 x attempts/task - 0.3 x not_completed - 0.004/s (time - 20 s)+ + N(0, 0.1)
  for the participant, of the scale's span, + N(0, 0.5) points per item.

A task time that is not there (nothing completed) counts as a minute over the reference, as above.
The participant's terms are drawn once per instrument, the noise once per filling-in (seeded by
the session, the instrument, the administration and the interaction model: a resumed session
gives the same answers). As above, the sizes are round numbers chosen before any run, fitted to nothing.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass

import numpy as np

from microg.instruments import Instrument, Item


ANCHOR = 7.0
LEANING_SD = 1.0
NOISE_SD = 0.7
PENALTIES = {
    "naturalness": {"penetration_mm": (5.0, 0.15), "shake_mm_s": (20.0, 0.02), "attempts_per_task": (0.0, 1.0)},
    "efficiency": {"time_s": (20.0, 0.04), "attempts_per_task": (0.0, 1.0), "not_completed": (0.0, 4.0)},
}
"""item -> measure -> (reference, penalty per unit above the reference)."""


@dataclass(frozen=True)
class Experience:
    """What one participant went through with one interaction model (module docstring)."""

    tasks: int
    attempts_per_task: float
    not_completed: float
    time_s: float
    penetration_mm: float
    shake_mm_s: float


def model_rating(item: str, lived: Experience, scale: tuple[int, int], leaning: float, noise: float) -> int:
    """The model's rating of ``item`` (module docstring) for ``lived``, rounded onto ``scale``."""
    measures = asdict(lived)
    value = ANCHOR + leaning + noise
    for measure, (reference, penalty) in PENALTIES[item].items():
        amount = measures[measure]
        if np.isfinite(amount):
            value -= penalty * max(0.0, amount - reference)
        elif measure == "time_s":
            value -= penalty * 60.0  # nothing completed: as slow as a minute over the reference
    low, high = scale
    return int(np.clip(round(value), low, high))


TLX_WORKLOAD = {
    "mental": (40.0, 0.4, 8.0, 0.0), "physical": (30.0, 0.3, 4.0, 0.0), "temporal": (35.0, 0.2, 0.0, 20.0),
    "performance": (20.0, 0.0, 10.0, 40.0), "effort": (45.0, 0.4, 8.0, 0.0), "frustration": (20.0, 0.0, 12.0, 30.0),
}
"""NASA-TLX subscale -> (base, per s of completion time over 20 s, per attempt per task, per share not completed)."""
MODELS = ("paper", "ssq", "ipq", "tlx", "sus")
"""The instruments the rating model answers (by id)."""
EXPOSURE_ONLY = ("ssq",)
"""Instruments answered from the minutes of tasks alone (``lived`` is not needed)."""


def unanswered(instrument: Instrument) -> str:
    """Why the rating model cannot answer ``instrument``; "" when it can."""
    if instrument.id not in MODELS:
        return f"the rating model of simulated participants answers only the instruments {list(MODELS)}"
    known = PENALTIES if instrument.id == "paper" else TLX_WORKLOAD if instrument.id == "tlx" else None
    unknown = [i.id for i in instrument.items if known is not None and not i.choices and i.id not in known]
    if unknown:
        return f"the rating model of simulated participants rates only {sorted(known)}, not {unknown}"
    return ""


def on_scale(item: Item, level: float, noise: float) -> float | int:
    """The answer at ``level`` (0: the bottom of the item's scale, 1: its top; the other way round for a
    reversed item) plus ``noise`` (points of the scale), rounded to its steps and clipped to its ends."""
    response = item.response
    share = 1.0 - level if item.reversed else level
    value = response.low + share * (response.high - response.low) + noise
    steps = np.clip(round((value - response.low) / response.step), 0, round((response.high - response.low) /
                                                                              response.step))
    return item.read(response.low + steps * response.step)


def _code(text: str) -> int:
    return zlib.crc32(text.encode())


class InstrumentModel:
    """One simulated participant's answers to the standard instruments (module docstring), seeded."""

    def __init__(self, seed: int):
        self.seed = seed

    def answers(self, instrument: Instrument, administration: str, interaction: str, lived: Experience | None,
                exposure_min: float) -> dict[str, float | int | str]:
        """Every item of one filling-in of ``instrument``: item id -> answer (``lived``: None for an
        instrument of ``EXPOSURE_ONLY``)."""
        own = np.random.default_rng([self.seed, 0x5241, _code(instrument.id)])
        rng = np.random.default_rng([self.seed, 0x5241, _code(instrument.id), _code(administration),
                                     _code(interaction)])
        ratings = [i for i in instrument.items if not i.choices]
        if instrument.id == "ssq":
            susceptibility = float(own.lognormal(np.log(0.5), 0.7))
            answers = {i.id: on_scale(i, (0.15 + susceptibility * exposure_min / 20 + rng.normal(0, 0.4)) / 3, 0.0)
                       for i in ratings}
        elif instrument.id == "tlx":
            leaning = float(own.normal(0, 10))
            answers = {i.id: on_scale(i, (_workload(i.id, lived) + leaning + rng.normal(0, 8)) / 100, 0.0)
                       for i in ratings}
        else:
            presence = instrument.id == "ipq"
            level = (_presence(lived) + own.normal(0, 0.12)) if presence else (_usability(lived) + own.normal(0, 0.1))
            answers = {i.id: on_scale(i, level, rng.normal(0, 0.7 if presence else 0.5)) for i in ratings}
        for item in instrument.items:
            if item.choices:
                answers[item.id] = max(item.choices, key=lambda c: float(answers.get(c, 0)) + rng.normal(0, 10))
        return answers


def _time_over(lived: Experience) -> float:
    """Seconds of the mean completion time over 20 s (a minute when nothing was completed)."""
    return max(0.0, lived.time_s - 20.0) if np.isfinite(lived.time_s) else 60.0


def _workload(subscale: str, lived: Experience) -> float:
    base, per_s, per_attempt, per_miss = TLX_WORKLOAD[subscale]
    return base + per_s * _time_over(lived) + per_attempt * lived.attempts_per_task + per_miss * lived.not_completed


def _presence(lived: Experience) -> float:
    return (0.6 - 0.02 * max(0.0, lived.penetration_mm - 5.0) - 0.06 * lived.attempts_per_task
            - 0.2 * lived.not_completed)


def _usability(lived: Experience) -> float:
    return 0.72 - 0.08 * lived.attempts_per_task - 0.3 * lived.not_completed - 0.004 * _time_over(lived)


class RatingModel:
    """One simulated participant's answers: a leaning drawn once, noise drawn per answer (seeded)."""

    def __init__(self, seed: int):
        self._rng = np.random.default_rng([seed, 0x5241])
        self.leaning = float(self._rng.normal(0.0, LEANING_SD))

    def rate(self, item: str, lived: Experience, scale: tuple[int, int]) -> int:
        if item not in PENALTIES:
            raise ValueError(f"the rating model knows the items {sorted(PENALTIES)}, not {item!r}")
        return model_rating(item, lived, scale, self.leaning, float(self._rng.normal(0.0, NOISE_SD)))
