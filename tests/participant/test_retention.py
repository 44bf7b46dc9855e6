"""Learning and forgetting across days (issue 44): the practice of earlier sessions enters the power
law of practice discounted by the days since it, against the documented formula worked out by hand;
the retention parameters' draws leave every other parameter's draw as it was."""

import dataclasses
import math

import numpy as np
import pytest

from microg.participant import default_population, person_skill, read_population
from microg.participant.bench import bench_plan
from microg.participant.population import (NAMES, PARAMETERS, Population, Spread, effective_practice,
                                           population_from_dict, practise)
from microg.paths import POPULATIONS

MOTOR = [i for i, p in enumerate(PARAMETERS) if not p.retention]
RETENTION = [i for i, p in enumerate(PARAMETERS) if p.retention]
SPEC_INDEX = {name: i for i, name in enumerate(NAMES)}


def person(**values) -> np.ndarray:
    """A person's values in ``PARAMETERS`` order: each parameter's upper bound halved, but ``values``."""
    return np.array([values.get(p.name, p.high / 2.0) for p in PARAMETERS])


def test_the_retention_parameters_are_the_last_two():
    assert [NAMES[i] for i in RETENTION] == ["forgetting_rate", "spaced_forgetting"]
    assert RETENTION == [len(NAMES) - 2, len(NAMES) - 1]


def test_without_forgetting_a_second_session_continues_the_first_sessions_power_law_exactly():
    """forgetting_rate 0: whatever the gap, the tasks of earlier sessions count in full, as if they
    had been done in this session."""
    p = person(movement_slope=0.4, learning_rate=0.7, trained_fraction=0.45, forgetting_rate=0.0, grip_lapse=0.3)
    for days, before, now in ((1.0, 10, 0), (7.0, 10, 5), (30.0, 3, 1), (0.0, 12, 2)):
        assert practise(p, now, ((days, before),)) == practise(p, before + now)
    assert practise(p, 4, ((14.0, 3), (7.0, 5), (0.5, 6))) == practise(p, 3 + 5 + 6 + 4)


def test_without_earlier_sessions_the_practice_is_this_sessions():
    values = dict(zip(NAMES, person(forgetting_rate=2.0, spaced_forgetting=0.1)))
    assert effective_practice(values, 7) == 7.0
    assert practise(person(), 7, ()) == practise(person(), 7)


def test_the_loss_after_a_gap_follows_the_documented_formula():
    """One earlier session of 24 tasks, forgetting_rate 0.5 (one session: massed, S = 1, so the rate
    is 0.5 whatever spaced_forgetting): practice = 24 (1 + t)^-0.5, which is 24 / 2 = 12 after 3 days
    and 24 / 3 = 8 after 8 days. With learning_rate 1 and trained_fraction 0.5, Fitts' slope of an
    untrained 0.4 s/bit is 0.4 (0.5 + 0.5 / (1 + practice)): 0.4 x 0.52 = 0.208 after the 24 tasks
    of the first session, 0.4 x 7/13 = 2.8/13 three days later and 0.4 x 5/9 = 2/9 eight days later;
    a lapse's chance of an untrained 0.2 is 0.2 / (1 + practice) (practised toward none)."""
    p = person(movement_slope=0.4, grip_lapse=0.2, learning_rate=1.0, trained_fraction=0.5, forgetting_rate=0.5,
               spaced_forgetting=0.3)
    values = dict(zip(NAMES, p))
    assert effective_practice(values, 0, ((3.0, 24),)) == pytest.approx(12.0, rel=1e-12)
    assert effective_practice(values, 0, ((8.0, 24),)) == pytest.approx(8.0, rel=1e-12)
    assert effective_practice(values, 5, ((8.0, 24),)) == pytest.approx(13.0, rel=1e-12)
    end = practise(p, 24)["movement_slope"]
    after_3_days = practise(p, 0, ((3.0, 24),))
    after_8_days = practise(p, 0, ((8.0, 24),))
    assert end == pytest.approx(0.208, rel=1e-12)
    assert after_3_days["movement_slope"] == pytest.approx(2.8 / 13, rel=1e-12)
    assert after_8_days["movement_slope"] == pytest.approx(2.0 / 9, rel=1e-12)
    assert after_3_days["movement_slope"] - end == pytest.approx(2.8 / 13 - 0.208, rel=1e-9)
    assert after_8_days["movement_slope"] - end == pytest.approx(2.0 / 9 - 0.208, rel=1e-9)
    assert after_3_days["grip_lapse"] == pytest.approx(0.2 / 13, rel=1e-12)
    assert after_8_days["grip_lapse"] == pytest.approx(0.2 / 9, rel=1e-12)


def test_spaced_practice_loses_less_than_massed_by_the_formula():
    """30 tasks, massed (one session on day 2) or spaced (10 on each of days 0, 1 and 2), then a
    week without practice (day 9); forgetting_rate 0.4, spaced_forgetting 0.5.

    Massed: one session, S = 1, rate 0.4: 30 x 8^-0.4 = 13.05826 a week later, from 30.
    Spaced: gaps of 1 day between the earlier sessions, S = 1 / ln(e + 1) = 0.761463, rate
    0.4 (1 - 0.5 (1 - S)) = 0.352293; a week later 10 (10^-rate + 9^-rate + 8^-rate) = 13.86137;
    at the end of the last session (sessions 1 and 2 two days and one day before, the same S)
    10 + 10 (3^-rate + 2^-rate) = 24.62407, so it lost 10.76270 against massed practice's 16.94174.
    Without the stability (spaced_forgetting 1) the spaced sessions, older, would keep less than the
    massed one: 10 (10^-0.4 + 9^-0.4 + 8^-0.4) = 12.48626."""
    values = {"forgetting_rate": 0.4, "spaced_forgetting": 0.5}
    massed_week = effective_practice(values, 0, ((7.0, 30),))
    spaced_week = effective_practice(values, 0, ((9.0, 10), (8.0, 10), (7.0, 10)))
    spaced_end = effective_practice(values, 10, ((2.0, 10), (1.0, 10)))
    assert massed_week == pytest.approx(13.05826, rel=1e-6)
    assert spaced_week == pytest.approx(13.86137, rel=1e-6)
    assert spaced_end == pytest.approx(24.62407, rel=1e-6)
    assert spaced_week > massed_week
    assert spaced_end - spaced_week == pytest.approx(10.76270, rel=1e-6)
    assert 30 - massed_week == pytest.approx(16.94174, rel=1e-6)
    unstable = effective_practice({"forgetting_rate": 0.4, "spaced_forgetting": 1.0}, 0,
                                  ((9.0, 10), (8.0, 10), (7.0, 10)))
    assert unstable == pytest.approx(12.48626, rel=1e-6) and unstable < massed_week
    p = person(movement_slope=0.4, learning_rate=0.5, trained_fraction=0.5, forgetting_rate=0.4,
               spaced_forgetting=0.5)
    spaced = practise(p, 0, ((9.0, 10), (8.0, 10), (7.0, 10)))["movement_slope"]
    massed = practise(p, 0, ((7.0, 30),))["movement_slope"]
    assert spaced == pytest.approx(0.4 * (0.5 + 0.5 * (1 + 13.86137) ** -0.5), rel=1e-6) and spaced < massed


@pytest.mark.parametrize("seed", range(6))
def test_a_participant_warms_up_after_a_gap_of_days_but_not_the_same_day(seed):
    """The first task of the second session, two days after a first of 10 tasks, is played with
    less skill than the first session's last (its practice: 10 x 3^-forgetting_rate against 9
    tasks); on the same day it continues the first session (10 tasks against 9)."""
    population = default_population()
    last_of_first = person_skill(population, seed, 9)
    first_of_second = person_skill(population, seed, 0, ((2.0, 10),))
    same_day = person_skill(population, seed, 0, ((0.0, 10),))
    for name in ("movement_slope", "hesitation_s", "aim_sd"):
        assert getattr(first_of_second, name) > getattr(last_of_first, name), name
        assert getattr(same_day, name) < getattr(last_of_first, name), name
    assert same_day == dataclasses.replace(person_skill(population, seed, 10), name=same_day.name)
    second_session = [person_skill(population, seed, k, ((2.0, 10),)).movement_slope for k in range(30)]
    assert all(later < earlier for earlier, later in zip(second_session, second_session[1:]))
    assert second_session[-1] < last_of_first.movement_slope


def draw_before_retention(population: Population, seed: int) -> np.ndarray:
    """``Population.draw`` as it was before the retention parameters came: one stream, one normal
    per motor parameter, in order."""
    motor = [p for p in PARAMETERS if not p.retention]
    normals = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5057])).standard_normal(len(motor))
    return np.array([_value_before(p, population.parameters[p.name], z) for p, z in zip(motor, normals)])


def _value_before(spec, spread: Spread, z: float) -> float:
    mean, sd = spread.mean, spread.sd
    if sd == 0:
        value = mean
    elif spec.scale == "log":
        sigma = math.sqrt(math.log1p((sd / mean) ** 2))
        value = mean * math.exp(sigma * z - sigma * sigma / 2)
    else:
        logit = math.log(mean / (1 - mean)) + z * sd / (mean * (1 - mean))
        value = 1 / (1 + math.exp(-logit))
    return min(max(value, spec.low), spec.high)


def test_drawing_the_retention_parameters_leaves_every_other_draw_as_it_was():
    """Two populations that differ only in their retention parameters give each person the same
    motor parameters, those the draw gave before the retention parameters existed; the retention
    parameters differ."""
    default = default_population()
    other = Population(dict(default.parameters) | {"forgetting_rate": Spread(1.5, 0.6),
                                                   "spaced_forgetting": Spread(0.2, 0.05)})
    for seed in range(20):
        one, two = default.draw(seed), other.draw(seed)
        assert np.array_equal(one[MOTOR], two[MOTOR])
        assert np.array_equal(one[MOTOR], draw_before_retention(default, seed))
        assert not np.any(one[RETENTION] == two[RETENTION])
    rates = np.array([default.draw(seed)[RETENTION[0]] for seed in range(400)])
    assert abs(rates.mean() - 0.4) < 5 * 0.12 / 20 and abs(rates.std() - 0.12) < 0.03


def test_a_profile_without_the_retention_parameters_loads_with_the_literatures_and_round_trips(tmp_path):
    """A PROFILE.toml written before the retention parameters (every other table of the default)
    still loads: they come from the default population, which has the literature's; the profile
    the calibration writes (``to_toml``) reads back to the same population."""
    text = default_population().to_toml()
    old = "\n".join(block for block in text.split("\n\n")
                    if not any(f"[parameters.{NAMES[i]}]" in block for i in RETENTION))
    (tmp_path / "old.toml").write_text(old, encoding="utf-8")
    loaded = read_population(tmp_path / "old.toml")
    literature = read_population(POPULATIONS / "literature.toml")
    for i in RETENTION:
        assert f"[parameters.{NAMES[i]}]" not in old
        assert loaded.parameters[NAMES[i]] == literature.parameters[NAMES[i]] == Spread(
            *{"forgetting_rate": (0.4, 0.12), "spaced_forgetting": (0.5, 0.1)}[NAMES[i]])
    assert loaded.parameters == default_population().parameters
    (tmp_path / "profile.toml").write_text(loaded.to_toml() + "\n", encoding="utf-8")
    assert read_population(tmp_path / "profile.toml").parameters == loaded.parameters
    with pytest.raises(ValueError, match=r"pilot.toml: parameters.spaced_forgetting.mean = 1.0: must lie in \[0.05, "
                                         r"0.999\] \(fraction: retention: "):
        population_from_dict({"parameters": {"spaced_forgetting": {"mean": 1.0, "sd": 0.0}}}, "pilot.toml")


def test_a_population_that_forgets_nothing_carries_every_task_over():
    """forgetting_rate 0 for everyone (a population's switch): each person's next session continues
    the last, whatever the days between."""
    keeps = population_from_dict({"parameters": {"forgetting_rate": {"mean": 0.0, "sd": 0.0}}}, "keeps.toml")
    for seed in range(5):
        assert keeps.draw(seed)[SPEC_INDEX["forgetting_rate"]] == 0.0
        carried = person_skill(keeps, seed, 3, ((30.0, 8), (2.0, 5)))
        assert carried == dataclasses.replace(person_skill(keeps, seed, 16), name=carried.name)


def test_a_plan_takes_its_earlier_sessions_oldest_first_and_refuses_others_by_name():
    plan = bench_plan("cube")
    assert plan.earlier_sessions == ()
    assert dataclasses.replace(plan, earlier_sessions=((7.0, 10), (1.5, 12))).earlier_sessions == ((7.0, 10), (1.5, 12))
    for bad in (((1.0, 10), (7.0, 10)), ((-1.0, 3),), ((1.0, 2.5),), ((math.inf, 3),), ((1.0,),), ((1.0, -2),)):
        with pytest.raises(ValueError, match=r"TaskPlan.earlier_sessions = "):
            dataclasses.replace(plan, earlier_sessions=bad)
