"""Seeded study-shaped tables (the study engine's export columns) for the analysis tests."""

from __future__ import annotations

import numpy as np
import pandas as pd

OBJECTS = ("cube", "flat_cuboid", "long_cuboid")
INTERACTIONS = ("impulse_penetration", "soft_hand")
ITEMS = ("naturalness", "efficiency")


def make_study(
    seed: int, n_veteran: int = 7, n_beginner: int = 9, unfinished: int = 2
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(trials, questionnaire) of a two-phase study: V trains first (training rows included),
    ``unfinished`` random tasks outside training time out (completed False, empty time). ``task_index``
    is a task's place in the participant's session (V's training task first).

    Times have a participant effect, object effects and correlated object deviations so that the
    pooled within-group covariance is not spherical; values are rounded to what a log would hold.
    """
    rng = np.random.default_rng(seed)
    groups = ["V"] * n_veteran + ["B"] * n_beginner
    ids = [f"P{i + 1:02d}" for i in range(len(groups))]
    rng.shuffle(ids)
    object_time = {"cube": 40.0, "flat_cuboid": 55.0, "long_cuboid": 62.0}
    rows = []
    for who, group in zip(ids, groups):
        skill = rng.normal(0, 8)
        shared = rng.normal(0, 6)
        trained = 1 if group == "V" else 0
        for stage, (phase, interaction, slow) in enumerate((("stage1", INTERACTIONS[0], 1.0),
                                                            ("stage2", INTERACTIONS[1], 1.8))):  # fmt: skip
            order = list(rng.permutation(OBJECTS))
            for position, name in enumerate(order):
                novice = 10.0 if group == "B" else 0.0
                tilt = shared if name == "long_cuboid" else -0.3 * shared
                time = slow * (object_time[name] + novice + skill + tilt) + rng.normal(0, 7)
                attempts = int(rng.poisson(0.6 * slow + (0.5 if group == "B" else 0.0)))
                rows.append(_trial(who, group, phase, interaction, name, position, max(time, 5.0), attempts,
                                   trained + 3 * stage + position))  # fmt: skip
        if trained:
            rows.append(_trial(who, group, "training", INTERACTIONS[0], "cube", 0, 300.0, 9, 0))
    trials = pd.DataFrame(rows)
    staged = np.flatnonzero(trials["phase"] != "training")
    for index in rng.choice(staged, size=unfinished, replace=False):
        trials.loc[index, ["completed", "time_s"]] = [False, np.nan]
    answers = []
    for who, group in zip(ids, groups):
        liking = rng.normal(0, 1)
        for interaction, centre in zip(INTERACTIONS, (7.0, 4.5)):
            for item in ITEMS:
                rating = int(np.clip(np.round(centre + liking + rng.normal(0, 1.5)), 0, 10))
                answers.append(
                    {"participant": who, "group": group, "interaction": interaction, "item": item,
                     "rating": rating, "simulated": False}
                )  # fmt: skip
    return trials, pd.DataFrame(answers)


def _trial(who, group, phase, interaction, name, position, time, attempts, task_index) -> dict:
    return {
        "study": "fixture",
        "participant": who,
        "group": group,
        "gender": "f" if who[-1] in "13579" else "m",
        "age": 24,
        "handedness": "right",
        "mr_experience": True,
        "phase": phase,
        "interaction": interaction,
        "object": name,
        "order_position": position,
        "completed": True,
        "time_s": round(float(time), 3),
        "attempts": attempts,
        "started_at": "2024-01-01T10:00:00",
        "ended_at": "2024-01-01T10:01:00",
        "simulated": True,
        "task_index": task_index,
    }


def make_practice(seed: int, n_per_group: int = 10, tasks: int = 8) -> pd.DataFrame:
    """Trials of participants who get faster with practice at rates of their own: log time =
    3 + their level + (their rate - 0.1) x task_index + 0.2 for the flat cuboid + noise, some tasks
    unfinished (no time). A random slope of task_index per participant is what the data hold."""
    rng = np.random.default_rng(seed)
    rows = []
    for number in range(2 * n_per_group):
        group = "V" if number < n_per_group else "B"
        level, rate = rng.normal(0, 0.3), rng.normal(0, 0.08)
        for task in range(tasks):
            name = OBJECTS[task % len(OBJECTS)]
            log_time = 3 + level + (rate - 0.1) * task + 0.2 * (name == "flat_cuboid") + rng.normal(0, 0.15)
            finished = rng.random() > 0.05
            rows.append({"participant": f"P{number + 1:02d}", "group": group, "object": name, "task_index": task,
                         "completed": finished, "time_s": round(float(np.exp(log_time)), 3) if finished else np.nan})
    return pd.DataFrame(rows)
