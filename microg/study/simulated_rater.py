"""The questionnaire answers of simulated participants: what each went through with each interaction model
(and how long it has spent on tasks so far), read back from the study's log, answered by the
participant's rating model (``microg.participant.ratings``). The answers are stored with ``source = model``."""

from __future__ import annotations

import json

import numpy as np

from microg.participant.ratings import EXPOSURE_ONLY, Experience, InstrumentModel, RatingModel
from microg.skeleton import SIDES, side_slots

from . import framelog
from .questionnaire import Answer, Question
from .store import FINAL_RUN, Store


HANDLING = "handling"
"""The event that ends a run's log with what the rating model reads of its frames (``handling``)."""
HANDLING_KEYS = ("penetration_mm_sum", "penetration_samples", "shake_mm_s_squares", "shake_samples")


def handling(frames: np.ndarray, before: np.ndarray | None = None) -> np.ndarray:
    """What a participant lived through in ``frames`` (``FRAME`` records, in order), as sums the
    rating model averages over a session (``HANDLING_KEYS``): the penetration (mm) of every touching,
    tracked phalanx and the squared speed of a held object relative to the palm (mm/s) between
    frames; ``before`` (the frame just before, one record) joins the first frame's step."""
    if before is not None:
        frames = np.concatenate([before, frames])
    sums = np.zeros(len(HANDLING_KEYS))
    touching_any = framelog.touching_slots(frames["touching"])
    for side in range(len(SIDES)):
        tracked = frames["tracked"][:, side]
        touching = touching_any[:, side_slots(side)] & tracked[:, None]
        if before is not None:
            touching[0] = False  # counted with the batch before
        rows = np.flatnonzero(touching.any(axis=1))  # the phalanges' sinking, where one touches
        joints = frames["joints"][rows, side]
        centres = 0.5 * (joints[:, :, 1:] + joints[:, :, :-1]).reshape(len(rows), frames["rendered"].shape[2], 3)
        sunk = np.linalg.norm(frames["rendered"][rows, side] - centres, axis=-1)
        penetration = (1e3 * sunk[touching[rows]]).astype(np.float64)
        palm = frames["palm_position"][:, side].astype(np.float64)
        t = frames["t"]
        steps = np.flatnonzero(tracked[1:] & tracked[:-1] & frames["held"][1:] & (t[1:] > t[:-1])) + 1
        palm_velocity = (palm[steps] - palm[steps - 1]) / (t[steps] - t[steps - 1])[:, None]
        relative = frames["velocity"][steps].astype(np.float64) - palm_velocity
        sums += (penetration.sum(), penetration.size, np.square(1e3 * np.linalg.norm(relative, axis=1)).sum(),
                 len(steps))
    return sums


def _run_handling(store: Store, session_id: int, run_id: int) -> np.ndarray:
    """A run's ``handling``: from its end (``HANDLING``), else (a run logged before runs ended with
    it) from its frames."""
    row = store.db.execute("SELECT data FROM events WHERE session_id = ? AND run_id = ? AND kind = ?",
                           (session_id, run_id, HANDLING)).fetchone()
    if row is not None:
        data = json.loads(row[0])
        return np.array([data[key] for key in HANDLING_KEYS], dtype=float)
    return handling(framelog.read(store.db, run_id))


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
    penetration, samples, shake, steps = sum(_run_handling(store, session_id, row["id"]) for row in rows)
    times = [r["time_s"] for r in rows if r["status"] == "completed"]
    return Experience(
        tasks=len(rows),
        attempts_per_task=float(np.mean([r["attempts"] or 0 for r in rows])),
        not_completed=1.0 - len(times) / len(rows),
        time_s=float(np.mean(times)) if times else float("nan"),
        penetration_mm=float(penetration / samples) if samples else 0.0,
        shake_mm_s=float(np.sqrt(shake / steps)) if steps else 0.0,
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
