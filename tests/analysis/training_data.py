"""A seeded training program's trials table (the export's columns with the training program's
session columns) for the analysis tests of the report's training section.

Two groups of trainees (P trains with the paper's interaction model, B with the baseline) go through
six sessions: a pre-test, three training sessions on consecutive days whose training phase repeats
its task until a proficiency criterion is met (two clean tasks in a row: completed within 30 s with
no drop) or ``MAX_TASKS`` is reached, a post-test the day after and a retention test a week later.
Every test session is the same six tasks (each object twice) with the paper's interaction model.

Each trainee's completion time follows a power law of practice, time = a + b * E^-c, with their own
a, b and c, where E is the practice they keep: it grows by one with each task they run and shrinks
between sessions by forgetting, E -> E * (1 + gap in days)^-f; the baseline's practice counts less
(``TRANSFER``) and its tasks take longer (``BASELINE_SLOWER``). A task's time has log-normal noise and
its drops are Poisson, fewer with practice; a task slower than ``TIMEOUT_S`` times out (no time).
Some trainees learn slowly enough to reach ``MAX_TASKS`` without the criterion (censored).
"""

from __future__ import annotations

from datetime import date, timedelta

import numpy as np
import pandas as pd

OBJECTS = ("cube", "flat_cuboid", "long_cuboid")
OBJECT_FACTOR = {"cube": 1.0, "flat_cuboid": 1.08, "long_cuboid": 1.15}
SESSIONS = (("pretest", 0, False), ("train1", 1, True), ("train2", 2, True), ("train3", 3, True),
            ("posttest", 4, False), ("retention", 11, False))  # fmt: skip
"""(name, day of the program, trains to the criterion)."""
GROUPS = {"P": "impulse_penetration", "B": "soft_hand"}
"""Each group's interaction model in training; every test uses the paper's (impulse_penetration)."""
TEST_INTERACTION = "impulse_penetration"
CRITERION_S, CRITERION_ATTEMPTS, CONSECUTIVE = 30.0, 0, 2
MAX_TASKS = 14
TIMEOUT_S = 70.0
TRANSFER = 0.75
BASELINE_SLOWER = 1.12
START = date(2026, 3, 2)


def make_training(seed: int, n_per_group: int = 8) -> pd.DataFrame:
    """The trials table of a seeded program of ``2 * n_per_group`` trainees, one row per task."""
    rng = np.random.default_rng(seed)
    rows = []
    for number in range(2 * n_per_group):
        group = "P" if number < n_per_group else "B"
        who = f"T{number + 1:02d}"
        asymptote = max(10.0, rng.normal(16.0, 3.0))
        gain = 48.0 * np.exp(rng.normal(0, 0.25))
        rate = float(np.clip(rng.normal(0.62 if group == "P" else 0.5, 0.12), 0.2, 1.2))
        forgetting = float(np.clip(rng.normal(0.3, 0.08), 0.05, 0.6))
        kept, last_day = 0.0, 0
        for index, (session, day, trains) in enumerate(SESSIONS):
            kept *= (1 + day - last_day) ** -forgetting if index else 1.0
            last_day = day
            interaction = GROUPS[group] if trains else TEST_INTERACTION
            weight = TRANSFER if trains and group == "B" else 1.0
            slower = BASELINE_SLOWER if interaction == "soft_hand" else 1.0
            planned = MAX_TASKS if trains else 2 * len(OBJECTS)
            clean, met = 0, False
            for task in range(planned):
                name = OBJECTS[task % len(OBJECTS)]
                kept += weight
                mean = asymptote + gain * kept**-rate
                time = mean * OBJECT_FACTOR[name] * slower * np.exp(rng.normal(0, 0.1))
                attempts = int(rng.poisson(0.7 * gain * kept**-rate / mean))
                completed = time <= TIMEOUT_S
                row = _task(who, group, session, index + 1, START + timedelta(days=day), interaction, name, task,
                            completed, round(float(time), 3) if completed else np.nan, attempts)
                if trains:
                    good = completed and time <= CRITERION_S and attempts <= CRITERION_ATTEMPTS
                    clean = clean + 1 if good else 0
                    met = clean >= CONSECUTIVE
                    row["criterion_met"] = met
                rows.append(row)
                if met:
                    break
    trials = pd.DataFrame(rows)
    trials["criterion_met"] = trials["criterion_met"].astype("boolean")
    trials["difficulty"] = np.nan
    return trials


def _task(who, group, session, session_index, day, interaction, name, task, completed, time, attempts) -> dict:
    return {
        "study": "training-fixture",
        "participant": who,
        "group": group,
        "gender": "f" if who[-1] in "13579" else "m",
        "age": 27,
        "handedness": "right",
        "mr_experience": False,
        "phase": "training" if session.startswith("train") else "test",
        "interaction": interaction,
        "object": name,
        "order_position": task % len(OBJECTS),
        "completed": completed,
        "time_s": time,
        "attempts": attempts,
        "status": "completed" if completed else "timeout",
        "simulated": True,
        "object_name": name,
        "runs": 1,
        "withdrawn": False,
        "session": session,
        "task_index": task,
        "task_kind": "pick_and_place",
        "session_index": session_index,
        "session_date": day.isoformat(),
        "task_in_phase": task + 1,
        "criterion_met": pd.NA,
    }
