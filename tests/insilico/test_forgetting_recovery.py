"""Recovery of the forgetting rate with the real in-silico program: a pilot program simulated from a
population whose ``forgetting_rate`` is known (0.8, twice the literature's 0.4), calibrated with
``microg participant calibrate --trials --fit forgetting_rate``, gives a 90 % interval that holds
the true rate and is informative: at most half the prior's width on the scale it is fitted on (the
prior is log-uniform from 0.08 to 2.0).

The pilot is designed to show forgetting (tests/insilico/protocols/retention.toml): each trainee
trains twice and takes a post-test, then a retest two weeks later and another two weeks after that;
the trainees learn much and steadily (``LEARNERS``), so the practice lost over the gaps moves their
times well beyond their task-to-task variation (docs/simulated-participant.md, "Learning and
forgetting across days", has the measurements). The fit sees each retest over the test before, the
same trainees' times (the ``paired`` ratios). With a model that forgets at 0.4 whatever the person's
rate, the interval was 0.12-1.42, three quarters of the prior: the width's bound fails it."""

from __future__ import annotations

import math
from pathlib import Path

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

PROTOCOL = Path(__file__).parent / "protocols" / "retention.toml"
LEARNERS = {"movement_intercept": Spread(0.6, 0.12), "movement_slope": Spread(0.35, 0.07),
            "hesitation_s": Spread(0.05, 0.015), "reaction_s": Spread(0.1, 0.0), "aim_sd": Spread(0.003, 0.0006),
            "learning_rate": Spread(1.0, 0.15), "trained_fraction": Spread(0.2, 0.04)}
"""The base population: the literature's, with slow untrained movements that practice makes five
times faster at a steep rate (learning rate 1, trained fraction 0.2), and little that varies from
task to task (short pauses, precise aim); its forgetting is the literature's (rate 0.4)."""
TRUTH = Spread(0.8, 0.24)
"""The pilot's forgetting rate (mean and SD between people: the literature's coefficient of variation)."""


@pytest.mark.slow
@pytest.mark.timeout(900)  # about 60 simulated programs on 2 shared cores
def test_a_calibration_recovers_the_forgetting_rate_of_a_pilot_program(tmp_path):
    base = Population(dict(read_population(POPULATIONS / "literature.toml").parameters) | LEARNERS, where="learners")
    truth = Population(dict(base.parameters) | {"forgetting_rate": TRUTH}, where="pilot")
    (tmp_path / "base.toml").write_text(base.to_toml())
    trials = tmp_path / "pilot.csv"
    simulate_trials(load_protocol(PROTOCOL), 10, 2024, population=truth).to_csv(trials, index=False)
    out = tmp_path / "fit" / "profile.toml"
    result = CliRunner().invoke(main, [
        "participant", "calibrate", "--trials", str(trials), "--protocol", str(PROTOCOL), "--out", str(out),
        "--fit", "forgetting_rate", "--base", str(tmp_path / "base.toml"), "--particles", "12", "--generations", "2",
        "--participants", "4", "--check", "2", "--seed", "5", "--workers", "2"])  # fmt: skip
    assert result.exit_code == 0, result.output
    fitted = read_population(out).parameters["forgetting_rate"]
    interval = (fitted.ci_low, fitted.ci_high)
    print(f"forgetting_rate: true {TRUTH.mean}, 90 % interval {fitted.ci_low:.3f}-{fitted.ci_high:.3f}")
    assert fitted.ci_low <= TRUTH.mean <= fitted.ci_high, interval
    prior = Free("forgetting_rate").with_prior(base.parameters["forgetting_rate"])
    assert prior.logged and (prior.low, prior.high) == pytest.approx((0.08, 2.0))
    assert math.log(fitted.ci_high / fitted.ci_low) <= 0.5 * math.log(prior.high / prior.low), interval
    # the fit saw each retest against the test before it, the same trainees' times
    check = pd.read_csv(out.parent / "calibration.csv").set_index("measure")
    retests = [key for key in check.index if key.startswith("time_s.paired[group=T,session=")]
    assert len(retests) == 2 and (check.loc[retests, "use"] == "fitted").all()
    assert check.loc[retests[0], "data"] > 1.2  # two weeks slowed the trainees down
