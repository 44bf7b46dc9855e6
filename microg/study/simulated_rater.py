"""The questionnaire answers of simulated participants: what each went through with each interaction model
(and how long it has spent on tasks so far), read back from the study's log, answered by the
participant's rating model (``microg.participant.ratings``). The answers are stored with ``source = model``."""

from __future__ import annotations

import numpy as np

from microg.participant.ratings import EXPOSURE_ONLY, Experience, InstrumentModel, RatingModel
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
    """Measures of the session's finished task runs with ``interaction`` (the last run of each task; ""
    for every interaction model)."""
    rows = store.db.execute("""
        SELECT r.id, r.status, r.time_s, r.attempts FROM task_runs r JOIN tasks t
            ON t.session_id = r.session_id AND t.task_index = r.task_index
        WHERE r.session_id = ? AND (? = '' OR t.interaction = ?) AND r.status IN (%s)
          AND r.run = (SELECT MAX(run) FROM task_runs m WHERE m.session_id = r.session_id
                                                           AND m.task_index = r.task_index)
        """ % ",".join("?" * len(FINAL_RUN)), (session_id, interaction, interaction, *FINAL_RUN)).fetchall()
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


def exposure_minutes(store: Store, session_id: int) -> float:
    """Minutes the session has spent on tasks so far (every run, on the session's clock)."""
    row = store.db.execute("SELECT COALESCE(SUM(ended_at - started_at), 0) FROM task_runs WHERE session_id = ? "
                           "AND ended_at IS NOT NULL", (session_id,)).fetchone()
    return float(row[0]) / 60.0


class SimulatedRater:
    """Answers from the log store with the rating model; answers are stored with ``source = model``.
    The paper's items draw from one stream in the order they are asked; every other instrument's
    filling-in is answered whole when its first item is asked."""

    source = "model"

    def __init__(self, store: Store, session_id: int, seed: int):
        self.store, self.session_id = store, session_id
        self._paper = RatingModel(seed)
        self._model = InstrumentModel(seed)
        self._lived: dict[tuple[str, str], Experience] = {}
        self._filled: dict[tuple[str, str, str], dict] = {}

    def answer(self, question: Question) -> Answer:
        instrument, administration, interaction, item = question.key
        if instrument == "paper":
            response = question.item.response
            return Answer(self._paper.rate(item, self._lived_with(administration, interaction),
                                           (int(response.low), int(response.high))), None)
        filling = (instrument, administration, interaction)
        if filling not in self._filled:
            lived = None if instrument in EXPOSURE_ONLY else self._lived_with(administration, interaction)
            self._filled[filling] = self._model.answers(question.instrument, administration, interaction, lived,
                                                        exposure_minutes(self.store, self.session_id))
        return Answer(self._filled[filling][item], None)

    def saved(self, question: Question) -> None:
        pass

    def _lived_with(self, administration: str, interaction: str) -> Experience:
        """What the participant went through with ``interaction`` by this administration."""
        key = (administration, interaction)
        if key not in self._lived:
            self._lived[key] = experience(self.store, self.session_id, interaction)
        return self._lived[key]
