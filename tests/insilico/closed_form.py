"""A stand-in for ``simulate_trials`` in the tests of the calibration's machinery (the order of
evaluations on Dask, resuming): the same table, from the same population draws and the same task
plan, with each task's time and attempts in closed form instead of the physics, so that a study
takes milliseconds. The calibration itself is tested against the real in-silico study
(test_recovery.py)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from microg.participant.population import practise
from microg.study.store import plan_tasks


def closed_form_trials(protocol, n_per_group: int, seed: int, *, population=None) -> pd.DataFrame:
    """A trials table: per task, time = 3 (hold + margin) + 2 (reaction + Exp(hesitation)) +
    4 Fitts movements (a + 3 b, slower carrying and with elongated objects), attempts
    Poisson(20 aim_sd); each person from ``population.draw`` and ``practise``."""
    rng = np.random.default_rng(seed)
    rows = []
    objects = tuple(o.name for o in protocol.objects)
    for g, group in enumerate(protocol.groups):
        for i in range(n_per_group):
            person = population.draw(int(rng.integers(2**31)))
            participant = f"{group.code}{i:02d}"
            for task in plan_tasks(protocol, group.code, objects):
                p = practise(person, task.index)
                size = protocol.object(task.object).spec.size
                elongation = math.log(max(size) / min(size))
                movement = (p["movement_intercept"] + 3 * p["movement_slope"]) * (1 + p["carry_slowdown"]) / 2
                time = (3 * (protocol.task.hold_s + p["hold_margin_s"])
                        + 2 * (p["reaction_s"] + rng.exponential(p["hesitation_s"]))
                        + 4 * movement * (1 + p["shape_caution"] * elongation))
                completed = time < protocol.task.timeout_s
                rows.append({"participant": participant, "group": group.code, "phase": task.phase,
                             "interaction": task.interaction, "object": task.object_code, "order_position": task.order_position,
                             "completed": completed, "time_s": time if completed else np.nan,
                             "attempts": int(rng.poisson(20 * p["aim_sd"])), "status": "completed" if completed
                             else "timeout", "task_index": task.index, "withdrawn": False})
    return pd.DataFrame(rows)


PROTOCOL = Path(__file__).parent / "protocols" / "recovery.toml"
SETTINGS = {"particles": 8, "generations": 2, "participants": 3, "check": 3, "seed": 11}


def closed_form_request():
    """A calibration of two means and a spread to a pilot of 4 per group played by the closed form."""
    from microg.insilico.calibrate import CalibrationRequest, parse_fit
    from microg.insilico.targets import Source, data_targets
    from microg.participant.population import Population, Spread, default_population
    from microg.study.protocol import load_protocol

    protocol = load_protocol(PROTOCOL)
    truth = dict(default_population().parameters)
    truth["hold_margin_s"], truth["hesitation_s"] = Spread(0.5, 0.15), Spread(0.3, 0.1)
    trials = closed_form_trials(protocol, 4, 5, population=Population(truth))
    targets, unused = data_targets(trials, "closed-form pilot", SETTINGS["seed"])
    source = Source(protocol, tuple(targets), "closed-form pilot", "0" * 64, 4, tuple(unused))
    return CalibrationRequest(source.protocol, source.targets, source.source, source.digest,
                              parse_fit("hold_margin_s,hesitation_s,hesitation_s:sd"), **SETTINGS,
                              unused=source.unused)  # fmt: skip


def main(scheduler: str, profile: str) -> None:
    """Run the closed-form calibration on the cluster at ``scheduler`` (a child process a test kills)."""
    import cloudpickle

    from microg.insilico.calibrate import calibrate
    from microg.power.run import dask_client

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with dask_client(scheduler) as client:
        calibrate(closed_form_request(), profile, client, progress=False, simulate=closed_form_trials)


if __name__ == "__main__":
    main(*sys.argv[1:])
