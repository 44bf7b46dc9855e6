"""The power law of practice of a population's person, against its closed form; a population's
absurd spread refused by name."""

import math

import numpy as np
import pytest

from microg.participant.population import NAMES, PARAMETERS, PopulationError, population_from_dict, practise

SPEC = {p.name: p for p in PARAMETERS}


def person(**values) -> np.ndarray:
    """A person's values in ``PARAMETERS`` order: each parameter's upper bound halved, but ``values``."""
    return np.array([values.get(p.name, p.high / 2.0) for p in PARAMETERS])


def test_practice_moves_each_practised_parameter_along_the_power_law_and_leaves_the_others():
    untrained = person(movement_intercept=0.4, carry_slowdown=2.0, learning_rate=0.5, trained_fraction=0.6)
    after = practise(untrained, 3)
    factor = 0.6 + 0.4 * 4.0 ** -0.5
    assert after["movement_intercept"] == pytest.approx(0.4 * factor, rel=1e-12)
    assert after["carry_slowdown"] == 2.0 and not SPEC["carry_slowdown"].practised
    assert practise(untrained, 0)["movement_intercept"] == pytest.approx(0.4, rel=1e-12)


def test_practice_takes_the_chance_of_an_error_toward_none():
    """Issue 28: a lapse of the grip is practised as untrained x (1 + n)^-rate, without the trained
    fraction's floor that a movement's time keeps."""
    untrained = person(grip_lapse=0.4, movement_intercept=0.4, learning_rate=0.5, trained_fraction=0.6)
    for n in (1, 3, 99):
        after = practise(untrained, n)
        assert after["grip_lapse"] == pytest.approx(0.4 * (1.0 + n) ** -0.5, rel=1e-12)
        assert after["movement_intercept"] > 0.4 * 0.6
    assert [p.name for p in PARAMETERS if p.error] == ["grip_lapse"]


def test_practice_takes_no_parameter_below_the_smallest_value_a_person_can_have():
    """Issue 28: a fast learner near its trained fraction's floor would otherwise move faster than a
    hand (a Fitts time of a few milliseconds)."""
    untrained = person(movement_intercept=0.4, movement_slope=0.05, learning_rate=3.0, trained_fraction=0.05)
    after = practise(untrained, 100)
    assert after["movement_intercept"] == SPEC["movement_intercept"].low
    assert after["movement_slope"] == SPEC["movement_slope"].low
    for name in NAMES:
        assert after[name] >= SPEC[name].low, name
    assert math.isclose(after["learning_rate"], 3.0)


def test_a_spread_between_people_beyond_any_persons_value_is_refused():
    """An SD of a million s/bit for Fitts' slope (at most 2 s/bit) would put nearly every person at a
    bound: the file is refused, naming the key and the value."""
    with pytest.raises(PopulationError, match=r"pilot.toml: parameters.movement_slope.sd = 1000000.0: larger than the "
                                              r"largest value a person may have \(2 s/bit\)"):
        population_from_dict({"parameters": {"movement_slope": {"mean": 0.25, "sd": 1e6}}}, "pilot.toml")
