"""Parameter recovery with the real in-silico study: a pilot simulated from a population whose
means differ from the default's, calibrated with ``microg participant calibrate --trials``, gives
intervals that hold the true means.

Three means are fitted, each with a 90 % credible interval: if the intervals cover as they claim,
the number that hold their true value is binomial(3, 0.9), at least two with probability 0.972, so
the test asks for at least two (and the seed fixes the result). It also asks that the data narrowed
at least one interval to under 60 % of its prior's 90 % range (on the prior's log scale): intervals
as wide as the prior would hold anything."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.insilico import simulate_trials
from microg.insilico.calibrate import Free
from microg.participant import Population, read_population
from microg.participant.population import Spread
from microg.paths import POPULATIONS
from microg.study.protocol import load_protocol

PROTOCOL = Path(__file__).parent / "protocols" / "recovery.toml"
TRUTH = {"hesitation_s": Spread(0.3, 0.09), "movement_slope": Spread(0.15, 0.045), "reaction_s": Spread(0.25, 0.05)}
"""The pilot's population: these means and spreads (the literature population's means: 0.6, 0.25 and 0.35),
the rest the literature population's (whose tasks take seconds, as the protocol's timeout wants)."""
BASE = POPULATIONS / "literature.toml"


@pytest.mark.slow
@pytest.mark.timeout(1800)  # about 60 whole simulated studies on 2 shared cores
def test_a_calibration_recovers_the_means_of_a_known_population(tmp_path):
    base = read_population(BASE)
    truth = Population(dict(base.parameters) | TRUTH)
    assert all(truth.parameters[name].mean != base.parameters[name].mean for name in TRUTH)
    trials = tmp_path / "pilot.csv"
    simulate_trials(load_protocol(PROTOCOL), 4, 2024, population=truth).to_csv(trials, index=False)
    out = tmp_path / "fit" / "profile.toml"
    result = CliRunner().invoke(main, [
        "participant", "calibrate", "--trials", str(trials), "--protocol", str(PROTOCOL), "--out", str(out),
        "--fit", ",".join(TRUTH), "--base", str(BASE), "--particles", "12", "--generations", "2", "--participants", "2",
        "--check", "3", "--seed", "5", "--workers", "2"])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "posterior (mean and 90 % credible interval):" in result.output and "fitted (" in result.output
    assert f"microg power --simulated --profile {out}" in result.output  # what to do with it next
    fitted = read_population(out).parameters
    covered = [name for name in TRUTH if fitted[name].ci_low <= TRUTH[name].mean <= fitted[name].ci_high]
    assert len(covered) >= 2, {name: (fitted[name].ci_low, fitted[name].ci_high) for name in TRUTH}
    priors = {name: Free(name).with_prior(base.parameters[name]) for name in TRUTH}
    assert all(prior.logged for prior in priors.values())  # log-uniform: its 90 % range is 0.9 log(high / low)
    narrowed = [name for name, prior in priors.items()
                if np.log(fitted[name].ci_high / fitted[name].ci_low) < 0.6 * 0.9 * np.log(prior.high / prior.low)]
    assert narrowed, {name: (fitted[name].ci_low, fitted[name].ci_high) for name in TRUTH}
    check = pd.read_csv(out.parent / "calibration.csv")
    assert (check["use"] == "fitted").all() and len(check) == len(read_population(out).calibration["measures_fitted"])
