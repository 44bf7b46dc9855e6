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
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


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


def unanswered(instrument) -> str:
    """Why the rating model cannot answer ``instrument`` (a ``microg.instruments.Instrument``); "" when it can."""
    if instrument.id != "paper":
        return f"the rating model of simulated participants answers only the instruments ['paper']"
    unknown = [item.id for item in instrument.items if item.id not in PENALTIES]
    if unknown:
        return f"the rating model of simulated participants rates only {sorted(PENALTIES)}, not {unknown}"
    return ""


class RatingModel:
    """One simulated participant's answers: a leaning drawn once, noise drawn per answer (seeded)."""

    def __init__(self, seed: int):
        self._rng = np.random.default_rng([seed, 0x5241])
        self.leaning = float(self._rng.normal(0.0, LEANING_SD))

    def rate(self, item: str, lived: Experience, scale: tuple[int, int]) -> int:
        if item not in PENALTIES:
            raise ValueError(f"the rating model knows the items {sorted(PENALTIES)}, not {item!r}")
        return model_rating(item, lived, scale, self.leaning, float(self._rng.normal(0.0, NOISE_SD)))
