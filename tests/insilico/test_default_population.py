"""The shipped default population against the paper's numbers it was fitted to
(``protocols/targets/paper.toml``): studies simulated from it (6 per group, as fitted), as the
calibration's predictive check simulates them."""

from __future__ import annotations

import numpy as np
import pytest

from microg.insilico import simulate_trials
from microg.insilico.calibrate import check_table
from microg.insilico.studies import protocol_through
from microg.insilico.targets import file_source, simulated_values
from microg.participant import default_population
from microg.paths import PROTOCOLS

STUDIES = 8
SOURCE = file_source(PROTOCOLS / "targets" / "paper.toml")
UNDER_FIT = {
    "attempts.sd[phase=stage1]": "about 0.5 between people where the paper has 0.3: a participant's three tasks "
                                 "of stage 1 give a mean of counts, and the lapses and the physics' drops vary "
                                 "more from task to task than the paper's people did",
    "time_s.ratio[group=B,phase=stage1]/[group=V,phase=stage1]>1.2": "beginners about 1.16 times slower on average, "
                                                                    "short of the 1.2 asked",
}
"""Fitted numbers the shipped default does not yet reach (docs/simulated-participant.md): each must
fail here, so that a better fit is noticed."""


@pytest.fixture(scope="module")
def check():
    population = default_population()
    assert population.calibration["fitted_to"].endswith("(protocols/targets/paper.toml)")
    protocol = protocol_through(SOURCE.protocol, [t.statistic for t in SOURCE.targets])
    simulated = np.array([simulated_values(simulate_trials(protocol, 6, seed, population=population), SOURCE.targets)
                          for seed in range(STUDIES)])
    table = check_table(SOURCE.targets, simulated)
    print(table.to_string(index=False))  # the held-out number is reported, not asserted
    return table.set_index("measure")


@pytest.mark.slow
@pytest.mark.parametrize("target", [
    pytest.param(t, id=t.key, marks=[pytest.mark.xfail(strict=True, reason=UNDER_FIT[t.key])] if t.key in UNDER_FIT
                 else []) for t in SOURCE.targets if not t.held_out])
def test_studies_of_the_default_population_match_each_number_it_was_fitted_to(check, target):
    """A number lies within the 90 % interval of eight simulated studies; a direction (beginners
    slower, the cuboids slower than the cube) holds on average."""
    row = check.loc[target.key]
    if target.direction == "above":
        assert row.simulated_mean > target.value, row
    else:
        assert row.simulated_low <= target.value <= row.simulated_high, row
