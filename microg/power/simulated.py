"""In-silico studies: power from whole studies run through the real sessions with simulated
participants and the physics, each analysed with the report's own functions.

One study is one Dask task: a study in a temporary folder with the protocol resized to n per
group, n x groups simulated participants (the protocol's skill profile per group, as ``microg
demo``), every session run by the session runner on simulation time, the trials table read back,
then ``microg.analysis.mixed_anova``, ``sphericity_correction`` and ``posthoc`` on the design's
cells. The study's seed is drawn from the run's seed and the study's index, as for a Monte Carlo
data set. No questionnaire is answered (the design's measures come from the tasks).
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from microg.power.design import Design
from microg.power.montecarlo import simulation_seed
from microg.power.pilot import SUBJECT, design_cells
from microg.study.protocol import Protocol, protocol_from_resolved


def sized_protocol(protocol: Protocol, n_per_group: int) -> Protocol:
    """The protocol with every group of ``n_per_group`` participants."""
    resolved = dict(protocol.resolved)
    resolved["groups"] = [dict(group, size=n_per_group) for group in resolved["groups"]]
    resolved["participants"] = dict(resolved["participants"], total=n_per_group * len(resolved["groups"]))
    return protocol_from_resolved(resolved, f"{protocol.where} (resized to {n_per_group} per group)")


def simulated_trials(protocol: Protocol, n_per_group: int, study_seed: int) -> pd.DataFrame:
    """The trials table of one whole simulated study with ``n_per_group`` participants per group."""
    from microg.study import (
        Participant,
        SimulationClock,
        create_study,
        open_inputs,
        run_session,
        trials_table,
    )

    sized = sized_protocol(protocol, n_per_group)
    rng = np.random.default_rng(study_seed)
    youngest, oldest = sized.age_range or (18, 60)
    with tempfile.TemporaryDirectory(prefix="microg-power-") as folder, \
            create_study(Path(folder) / "study", sized, study_seed) as store:
        for number in range(sized.total_participants):
            store.add_participant(Participant(f"S{number + 1:03d}", ("female", "male")[number % 2],
                                              int(rng.integers(youngest, oldest + 1)), "right", True))
        for record in store.participants():
            inputs = open_inputs("simulated", sized.group(record.group))
            session = store.create_session(record.participant.id, inputs.spec, inputs.simulated, inputs.clock)
            run_session(store, session.id, inputs, clock=SimulationClock())
        return trials_table(store)


def study_tests(trials: pd.DataFrame, design: Design, measure: str, interaction: str, alpha: float) -> pd.Series:
    """The p the report reads for every test of ``design.tests``, from one study's trials; NaN for
    all when the report cannot analyse the study (too few complete participants)."""
    from microg.analysis import (
        AnalysisInputError,
        mixed_anova,
        posthoc,
        sphericity_correction,
    )

    d = design
    try:
        cells = design_cells(trials, d, measure, interaction, "simulated study")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the report's warnings name participants left out: counted as such
            anova = sphericity_correction(mixed_anova(cells, "value", d.within, d.between, SUBJECT), alpha)
            post = posthoc(cells, "value", d.within, d.between, SUBJECT, within_by_group=True)
    except AnalysisInputError:
        return pd.Series(np.nan, index=list(d.tests))
    return d.report_p(anova, post)


def simulated_batch(protocol: Protocol, design: Design, n_per_group: int, indices, seed: int, alpha: float,
                    measure: str, interaction: str) -> pd.DataFrame:
    """Run and analyse the simulated studies ``indices`` at ``n_per_group``: one Dask task per study.

    Returns the rows of ``montecarlo.SIMULATION_COLUMNS``.
    """
    tables = []
    for index in indices:
        study_seed = int(simulation_seed(seed, n_per_group, int(index)).generate_state(1)[0])
        p = study_tests(simulated_trials(protocol, n_per_group, study_seed), design, measure, interaction, alpha)
        tables.append(pd.DataFrame({"n_per_group": n_per_group, "sim": int(index), "term": p.index, "p": p.to_numpy()}))
    return pd.concat(tables, ignore_index=True)
