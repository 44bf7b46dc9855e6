"""The questionnaire answers of simulated participants: what each went through with each interaction model,
read back from the study's log, rated by the participant's rating model
(``microg.participant.ratings``). The answers are stored with ``source = model``."""

from __future__ import annotations

import numpy as np

from microg.participant.ratings import Experience, RatingModel
from microg.skeleton import SIDES, side_slots

from . import framelog
from .questionnaire import Answer, Question
from .store import FINAL_RUN, Store


def _run_measures(store: Store, run_id: int) -> tuple[list[float], list[float]]:
    """Penetration samples (mm) and relative object speeds while held (mm/s) of one task run."""
    frames = framelog.read(store.db, run_id)
    penetration, shake = [], []
    for side in range(len(SIDES)):
        tracked = frames["tracked"][:, side]
        centres = 0.5 * (frames["joints"][:, side, :, 1:] + frames["joints"][:, side, :, :-1]).reshape(len(frames), -1, 3)
        sunk = np.linalg.norm(frames["rendered"][:, side] - centres, axis=-1)
        touching = framelog.touching_slots(frames["touching"])[:, side_slots(side)]
        penetration += (1e3 * sunk[touching & tracked[:, None]]).astype(np.float64).tolist()
        palm = frames["palm_position"][:, side].astype(np.float64)
        t = frames["t"]
        steps = np.flatnonzero(tracked[1:] & tracked[:-1] & frames["held"][1:] & (t[1:] > t[:-1])) + 1
        palm_velocity = (palm[steps] - palm[steps - 1]) / (t[steps] - t[steps - 1])[:, None]
        relative = frames["velocity"][steps].astype(np.float64) - palm_velocity
        shake += (1e3 * np.linalg.norm(relative, axis=1)).tolist()
    return penetration, shake


def experience(store: Store, session_id: int, interaction: str) -> Experience:
    """Measures of the session's finished task runs with ``interaction`` (the last run of each task)."""
    rows = store.db.execute("""
        SELECT r.id, r.status, r.time_s, r.attempts FROM task_runs r JOIN tasks t
            ON t.session_id = r.session_id AND t.task_index = r.task_index
        WHERE r.session_id = ? AND t.interaction = ? AND r.status IN (%s)
          AND r.run = (SELECT MAX(run) FROM task_runs m WHERE m.session_id = r.session_id
                                                           AND m.task_index = r.task_index)
        """ % ",".join("?" * len(FINAL_RUN)), (session_id, interaction, *FINAL_RUN)).fetchall()
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
        attempts_per_task=float(np.mean([r["attempts"] or 0 for r in rows])),
        not_completed=1.0 - len(times) / len(rows),
        time_s=float(np.mean(times)) if times else float("nan"),
        penetration_mm=float(np.mean(penetration)) if penetration else 0.0,
        shake_mm_s=float(np.sqrt(np.mean(np.square(shake)))) if shake else 0.0,
    )


class ModelRater:
    """Rates from the log store with the rating model; answers are stored with ``source = model``."""

    source = "model"

    def __init__(self, store: Store, session_id: int, seed: int):
        self.store, self.session_id = store, session_id
        self._model = RatingModel(seed)
        self._lived: dict[str, Experience] = {}

    def answer(self, question: Question) -> Answer:
        if question.interaction not in self._lived:
            self._lived[question.interaction] = experience(self.store, self.session_id, question.interaction)
        response = question.item.response
        rating = self._model.rate(question.item.id, self._lived[question.interaction],
                                  (int(response.low), int(response.high)))
        return Answer(rating, None)
