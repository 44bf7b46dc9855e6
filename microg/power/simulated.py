"""In-silico studies: power from whole studies of simulated participants played through the physics
(batched, with a logged session's rules and trials table), each analysed with the report's own
functions.

One study is one Dask task: a whole simulated study (``microg.insilico.simulate_trials``: the
protocol resized to n per group, each group's simulated participants as ``microg demo`` runs them,
or all drawn from one population: ``microg power --simulated --profile``),
then ``microg.analysis.mixed_anova``, ``sphericity_correction`` and ``posthoc`` on the design's
cells. The study's seed is drawn from the run's seed and the study's index, as for a Monte Carlo
data set. No questionnaire is answered (the design's measures come from the tasks).
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from microg.insilico import simulate_trials
from microg.participant import Population
from microg.power.design import Design
from microg.power.montecarlo import simulation_seed
from microg.power.pilot import SUBJECT, design_cells
from microg.study.protocol import Protocol


def study_tests(trials: pd.DataFrame, design: Design, measure: str, interaction: str, alpha: float,
                correction: str = "mauchly") -> pd.Series:
    """The p read for every test of ``design.tests`` from one study's trials (``correction``: the
    report's Mauchly rule, none, or always GG or HF); NaN for all when the report cannot analyse the
    study (too few complete participants)."""
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
            anova = mixed_anova(cells, "value", d.within, d.between, SUBJECT)
            post = posthoc(cells, "value", d.within, d.between, SUBJECT, within_by_group=True)
    except AnalysisInputError:
        return pd.Series(np.nan, index=list(d.tests))
    if correction == "mauchly":
        read = sphericity_correction(anova, alpha)
    else:
        column = {"none": "p_unc", "GG": "p_GG", "HF": "p_HF"}[correction]
        p = anova[column].where(anova[column].notna(), anova["p_unc"])  # epsilon not estimable: uncorrected
        read = pd.DataFrame({"p": p.to_numpy()})
    return d.report_p(read, post)


def simulated_batch(protocol: Protocol, design: Design, n_per_group, indices, seed: int, alpha: float,
                    measure: str, interaction: str, correction: str = "mauchly",
                    population: Population | None = None) -> pd.DataFrame:
    """Run and analyse the simulated studies ``indices`` at ``n_per_group``: one Dask task per study;
    every participant drawn from ``population`` when given, else from its group's ``simulated_profile``.

    Returns the rows of ``montecarlo.SIMULATION_COLUMNS``.
    """
    tables = []
    for index in indices:
        study_seed = int(simulation_seed(seed, n_per_group, int(index)).generate_state(1)[0])
        trials = simulate_trials(protocol, n_per_group, study_seed, population=population)
        p = study_tests(trials, design, measure, interaction, alpha, correction)
        tables.append(pd.DataFrame({"n_per_group": design.sample_key(n_per_group), "sim": int(index), "term": p.index,
                                    "p": p.to_numpy()}))  # fmt: skip
    return pd.concat(tables, ignore_index=True)
