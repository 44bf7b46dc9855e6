"""The questionnaire: each item for each system, on the protocol's scale (the paper: 0-10).

``TerminalRater`` asks in the terminal with the paper's question text and anchors, and asks again
on anything that is not a whole number on the scale. Simulated participants answer through the
rating model (``ModelRater``: what each simulated participant went through, read back from the log,
rated by ``microg.participant.ratings``); those answers are marked ``source = model``.
"""

from __future__ import annotations

from typing import Callable, Protocol as Interface

import numpy as np

from microg.participant.ratings import Experience, RatingModel
from microg.sim.hand import BONES_PER_HAND, SIDES, bone_centres

from .protocol import Item, Questionnaire, Stage
from .store import FINAL_RUN, Store, hand_parts, hand_values


class RatingError(ValueError):
    """An answer that is not a rating on the scale; the message says what is expected."""


class Rater(Interface):
    source: str
    """``participant`` (a person answered) or ``model`` (a simulated participant's rating model)."""

    def rate(self, item: Item, stage: Stage, questionnaire: Questionnaire) -> int: ...


def parse_rating(text: str, low: int, high: int) -> int:
    """The rating in ``text``, or RatingError naming the answer and the scale."""
    answer = text.strip()
    if not answer:
        raise RatingError(f"no answer: type a whole number from {low} to {high}")
    try:
        value = int(answer)
    except ValueError:
        raise RatingError(f"{answer!r} is not a whole number: type a whole number from {low} to {high}") from None
    if not low <= value <= high:
        raise RatingError(f"{value} is off the scale: type a whole number from {low} to {high}")
    return value


def question_text(item: Item, stage: Stage, questionnaire: Questionnaire) -> str:
    q = questionnaire
    return (f"{stage.label}: {item.question}\n"
            f"  ({q.scale_min}: {item.low}, {q.scale_max}: {item.high})")


class TerminalRater:
    """Asks a person; ``read`` and ``write`` default to the terminal."""

    source = "participant"

    def __init__(self, read: Callable[[str], str] = input, write: Callable[[str], None] = print,
                 on_rejected: Callable[[Item, Stage, str, str], None] | None = None):
        self.read, self.write, self.on_rejected = read, write, on_rejected

    def rate(self, item: Item, stage: Stage, questionnaire: Questionnaire) -> int:
        self.write(question_text(item, stage, questionnaire))
        while True:
            text = self.read(f"Rating ({questionnaire.scale_min}-{questionnaire.scale_max}): ")
            try:
                return parse_rating(text, questionnaire.scale_min, questionnaire.scale_max)
            except RatingError as error:
                self.write(f"  {error}")
                if self.on_rejected:
                    self.on_rejected(item, stage, text, str(error))


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


class ModelRater:
    """Rates from the log store with the rating model; answers are stored with ``source = model``."""

    source = "model"

    def __init__(self, store: Store, session_id: int, seed: int):
        self.store, self.session_id = store, session_id
        self._model = RatingModel(seed)
        self._lived: dict[str, Experience] = {}

    def rate(self, item: Item, stage: Stage, questionnaire: Questionnaire) -> int:
        if stage.system not in self._lived:
            self._lived[stage.system] = experience(self.store, self.session_id, stage.system)
        return self._model.rate(item.name, self._lived[stage.system], (questionnaire.scale_min, questionnaire.scale_max))
