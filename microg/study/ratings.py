"""The questionnaire answers of simulated participants: a rating model, labelled as simulated.

A simulated participant feels nothing, so its ratings come from a model fed by what happened in
its own tasks with each system, read back from the log store:

- ``drops_per_task``: attempts (the study's drops) per task;
- ``not_completed``: share of the system's tasks not completed (timeout, aborted);
- ``time_s``: mean completion time of the completed tasks;
- ``penetration_mm``: visible penetration, how far the tracked phalanges sank into the object
  while the rendered hand rested on its surface (mean distance between tracked and rendered
  phalanx centres, over phalanges in contact): the visual conflict the god-object hides;
- ``shake_mm_s``: how much the held object rattled or slid in the hand (RMS speed of the object
  relative to the palm while held).

Each rating is an anchor minus penalties, plus the participant's own leaning and noise::

    naturalness = 7 - 0.15/mm (penetration - 5 mm)+ - 0.02 s/mm (shake - 20 mm/s)+ - 1.0 x drops/task
    efficiency  = 7 - 0.04/s (time - 20 s)+ - 1.0 x drops/task - 4 x not_completed

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

from microg.sim.hand import BONES_PER_HAND, SIDES, bone_centres

from .protocol import Item, Questionnaire, Stage
from .store import FINAL_RUN, Store, hand_parts, hand_values

ANCHOR = 7.0
LEANING_SD = 1.0
NOISE_SD = 0.7
PENALTIES = {
    "naturalness": {"penetration_mm": (5.0, 0.15), "shake_mm_s": (20.0, 0.02), "drops_per_task": (0.0, 1.0)},
    "efficiency": {"time_s": (20.0, 0.04), "drops_per_task": (0.0, 1.0), "not_completed": (0.0, 4.0)},
}
"""item -> measure -> (reference, penalty per unit above the reference)."""


@dataclass(frozen=True)
class Experience:
    """What one participant went through with one system (module docstring)."""

    tasks: int
    drops_per_task: float
    not_completed: float
    time_s: float
    penetration_mm: float
    shake_mm_s: float


def _run_measures(store: Store, run_id: int) -> tuple[list[float], list[float]]:
    """Penetration samples (mm) and relative object speeds while held (mm/s) of one task run."""
    rows = store.db.execute("SELECT t, held, touching, vx, vy, vz, left, right FROM frames WHERE run_id = ? "
                            "ORDER BY frame", (run_id,)).fetchall()
    penetration, shake = [], []
    previous_palm, previous_t = {}, None
    for row in rows:
        for side_index, side in enumerate(SIDES):
            if row[side] is None:
                previous_palm.pop(side, None)
                continue
            parts = hand_parts(hand_values(row[side]))
            joints = parts["joints"].reshape(5, 5, 3)
            tracked = bone_centres(joints).reshape(-1, 3)
            rendered = parts["rendered"].reshape(-1, 3)
            bits = [(row["touching"] >> (side_index * BONES_PER_HAND + k)) & 1 for k in range(BONES_PER_HAND)]
            for k in np.flatnonzero(bits):
                penetration.append(1e3 * float(np.linalg.norm(rendered[k] - tracked[k])))
            palm = parts["palm_position"]
            if row["held"] and side in previous_palm and previous_t is not None and row["t"] > previous_t:
                palm_velocity = (palm - previous_palm[side]) / (row["t"] - previous_t)
                relative = np.array([row["vx"], row["vy"], row["vz"]]) - palm_velocity
                shake.append(1e3 * float(np.linalg.norm(relative)))
            previous_palm[side] = palm
        previous_t = row["t"]
    return penetration, shake


def experience(store: Store, session_id: int, system: str) -> Experience:
    """Measures of the session's finished task runs with ``system`` (the last run of each task)."""
    rows = store.db.execute("""
        SELECT r.id, r.status, r.time_s, r.attempts FROM task_runs r JOIN tasks t
            ON t.session_id = r.session_id AND t.task_index = r.task_index
        WHERE r.session_id = ? AND t.system = ? AND r.status IN (%s)
          AND r.run = (SELECT MAX(run) FROM task_runs m WHERE m.session_id = r.session_id
                                                           AND m.task_index = r.task_index)
        """ % ",".join("?" * len(FINAL_RUN)), (session_id, system, *FINAL_RUN)).fetchall()
    rows = [r for r in rows if r["status"] != "skipped"]
    if not rows:
        return Experience(0, 0.0, 1.0, float("nan"), float("nan"), float("nan"))
    penetration, shake = [], []
    for row in rows:
        p, s = _run_measures(store, row["id"])
        penetration += p
        shake += s
    times = [r["time_s"] for r in rows if r["status"] == "completed"]
    return Experience(
        tasks=len(rows),
        drops_per_task=float(np.mean([r["attempts"] or 0 for r in rows])),
        not_completed=1.0 - len(times) / len(rows),
        time_s=float(np.mean(times)) if times else float("nan"),
        penetration_mm=float(np.mean(penetration)) if penetration else 0.0,
        shake_mm_s=float(np.sqrt(np.mean(np.square(shake)))) if shake else 0.0,
    )


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


class ModelRater:
    """Rates from the log store with the rating model; answers are stored with ``source = model``."""

    source = "model"

    def __init__(self, store: Store, session_id: int, seed: int):
        self.store, self.session_id = store, session_id
        self._rng = np.random.default_rng([seed, 0x5241])
        self._leaning = float(self._rng.normal(0.0, LEANING_SD))
        self._lived: dict[str, Experience] = {}

    def rate(self, item: Item, stage: Stage, questionnaire: Questionnaire) -> int:
        if item.name not in PENALTIES:
            raise ValueError(f"the rating model knows the items {sorted(PENALTIES)}, not {item.name!r}")
        if stage.system not in self._lived:
            self._lived[stage.system] = experience(self.store, self.session_id, stage.system)
        noise = float(self._rng.normal(0.0, NOISE_SD))
        return model_rating(item.name, self._lived[stage.system], (questionnaire.scale_min, questionnaire.scale_max),
                            self._leaning, noise)
