"""Summary statistics of a trials table (microg.insilico.summaries), against numbers computed
here by hand from the table's rows, and the targets read from a pilot's trials."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from microg.insilico.summaries import RESOLUTION, Statistic, bootstrap_se, study_statistics, summarise
from microg.insilico.targets import TargetError, data_targets

STAGE1 = (("phase", "stage1"),)


def trials_of(rows) -> pd.DataFrame:
    columns = ["participant", "group", "phase", "interaction", "object", "completed", "time_s", "attempts",
               "task_index", "status", "withdrawn"]
    return pd.DataFrame(rows, columns=columns)


def pilot() -> pd.DataFrame:
    """Three beginners and two veterans; P3 times out on F; P9 withdrew; one task never ran."""
    rows = []
    times = {"P1": (20.0, 30.0), "P2": (26.0, 40.0), "P3": (35.0, None), "P4": (15.0, 18.0), "P5": (17.0, 24.0),
             "P9": (99.0, 99.0)}
    attempts = {"P1": (0, 1), "P2": (1, 3), "P3": (0, 4), "P4": (0, 0), "P5": (1, 1), "P9": (9, 9)}
    for person, (cube, flat) in times.items():
        group = "V" if person in ("P4", "P5") else "B"
        withdrawn = person == "P9"
        rows.append([person, group, "stage1", "m", "C", True, cube, attempts[person][0], 0, "completed", withdrawn])
        rows.append([person, group, "stage1", "m", "F", flat is not None, flat, attempts[person][1], 1,
                     "completed" if flat is not None else "timeout", withdrawn])
    rows.append(["P1", "B", "stage2", "s", "C", False, None, None, 2, "not_run", False])
    return trials_of(rows)


def test_means_sds_and_ratios_over_participants():
    trials = pilot()
    wanted = [Statistic("time_s", "mean", STAGE1 + (("group", "B"),)),
              Statistic("time_s", "sd", STAGE1 + (("group", "B"),)),
              Statistic("attempts", "mean", (("group", "B"), ("object", "F"))),
              Statistic("completed", "mean", (("group", "B"),)),
              Statistic("time_s", "ratio", (("group", "B"),), (("group", "V"),))]
    table = summarise(trials, wanted)
    # each beginner's mean time over their completed stage-1 tasks: P1 25, P2 33, P3 35 (F timed out)
    assert table["value"][0] == pytest.approx(np.mean([25, 33, 35]))
    assert table["value"][1] == pytest.approx(np.std([25, 33, 35], ddof=1))
    assert table["value"][2] == pytest.approx(np.mean([1, 3, 4]))
    assert table["value"][3] == pytest.approx(np.mean([1, 1, 0.5]))  # the task that never ran does not count
    assert table["value"][4] == pytest.approx(np.mean([25, 33, 35]) / np.mean([16.5, 20.5]))
    assert table["n"].tolist() == [3, 3, 3, 3, 3]  # P9 withdrew


def test_the_practice_slope_is_each_participants_least_squares_slope():
    rows, expected = [], []
    for person, rate in (("P1", 0.3), ("P2", 0.5)):
        times = [40.0 * (1 + n) ** -rate * (1.05 if n == 1 else 1.0) for n in range(4)]
        rows += [[person, "B", "stage1", "m", "C", True, t, 0, n, "completed", False] for n, t in enumerate(times)]
        expected.append(stats.linregress(np.log1p(np.arange(4)), np.log(times)).slope)
    value = summarise(trials_of(rows), [Statistic("time_s", "slope", (("group", "B"),))])["value"][0]
    assert value == pytest.approx(np.mean(expected))
    assert -0.5 < value < -0.3


def test_undefined_statistics_are_nan():
    trials = pilot()
    wanted = [Statistic("time_s", "sd", (("group", "V"), ("object", "F"), ("phase", "stage1"))),
              Statistic("time_s", "mean", (("phase", "training"),))]
    single = trials[trials["participant"] != "P5"]
    values = summarise(single, wanted)["value"]
    assert np.isnan(values[0])  # one veteran left: no SD
    assert np.isnan(values[1])  # nobody trained


def test_a_pilot_shows_its_cells_with_standard_errors():
    trials = pilot()
    keys = [s.key for s in study_statistics(trials)]
    assert "time_s.mean[group=B,phase=stage1,interaction=m,object=F]" in keys
    assert "completed.mean[group=V,phase=stage1,interaction=m]" in keys
    assert not any("stage2" in key for key in keys)  # one beginner's task that never ran
    se = bootstrap_se(trials, study_statistics(trials), seed=3)
    assert np.all(se >= min(RESOLUTION.values())) and np.all(np.isfinite(se))
    # the bootstrap SE of a mean is close to SD / sqrt(n) (a loose check: 3 participants)
    mean_index = keys.index("time_s.mean[group=B,phase=stage1,interaction=m,object=C]")
    assert 0.4 < se[mean_index] / (np.std([20, 26, 35], ddof=1) / np.sqrt(3)) < 1.2
    again = bootstrap_se(trials, study_statistics(trials), seed=3)
    assert np.array_equal(se, again)


def test_a_pilot_too_small_to_fit_is_refused_naming_the_group():
    trials = pilot()
    lonely = trials[~trials["participant"].isin(["P5"])]
    with pytest.raises(TargetError, match=r"pilot.csv: group = 'V': 1 participant; .*at least two per group"):
        data_targets(lonely, "pilot.csv", seed=1)


def test_a_ratio_compares_the_same_selection_with_the_keys_of_versus_changed():
    """``group = "B", interaction = M, versus = { group = "V" }`` is B against V, both with M: the
    paper's beginners against its veterans with its model, not against every task the veterans did."""
    from microg.insilico.targets import targets_from_dict
    from microg.paths import protocol_file
    from microg.study.protocol import load_protocol

    entry = {"measure": "time_s", "group": "B", "interaction": "impulse_penetration", "versus": {"group": "V"},
             "above": 1.0, "se": 0.1}
    parsed = targets_from_dict({"n_per_group": 15, "targets": [entry]}, load_protocol(protocol_file("paper")), "t.toml")
    statistic = parsed.targets[0].statistic
    assert statistic.where == (("group", "B"), ("interaction", "impulse_penetration"))
    assert statistic.versus == (("group", "V"), ("interaction", "impulse_penetration"))
    # a phase names its interaction model: changing one drops the other
    models = dict(entry, group=None, phase="stage1", versus={"interaction": "soft_hand"})
    models.pop("group"), models.pop("interaction")
    parsed = targets_from_dict({"n_per_group": 15, "targets": [models]}, load_protocol(protocol_file("paper")), "t.toml")
    assert parsed.targets[0].statistic.versus == (("interaction", "soft_hand"),)
    with pytest.raises(TargetError, match=re.escape("t.toml: targets[0].versus = {'group': 'B'}: compares the "
                                                    "selection with itself")):
        targets_from_dict({"n_per_group": 15, "targets": [dict(entry, versus={"group": "B"})]},
                          load_protocol(protocol_file("paper")), "t.toml")


def test_a_pilot_program_shows_each_session_level():
    """A training program's pilot: its cells are per group x session x phase (over the objects), the
    level of each session being what practice kept and lost across days shows; a session's mean is
    the mean over its participants of their means in it."""
    rows = []
    for person, (train, retention) in {"P1": ((20.0, 16.0), (19.0, 21.0)), "P2": ((30.0, 22.0), (25.0, 27.0))}.items():
        for index, (session, phase, times) in enumerate([("train1", "train", train), ("retention", "test", retention)]):
            for k, (obj, time) in enumerate(zip("CF", times)):
                rows.append([person, "B", phase, "m", obj, True, time, 0, k, "completed", False, session])
    trials = pd.DataFrame(rows, columns=["participant", "group", "phase", "interaction", "object", "completed",
                                         "time_s", "attempts", "task_index", "status", "withdrawn", "session"])
    statistics = study_statistics(trials)
    keys = [s.key for s in statistics]
    assert "time_s.mean[group=B,session=retention,phase=test,interaction=m]" in keys
    assert "time_s.sd[group=B,session=train1,phase=train,interaction=m]" in keys
    assert not any("object=" in key for key in keys)
    values = dict(zip(keys, summarise(trials, statistics)["value"]))
    assert values["time_s.mean[group=B,session=retention,phase=test,interaction=m]"] == (20.0 + 26.0) / 2


def test_a_phase_repeated_across_sessions_gives_the_same_trainees_change():
    """A test repeated in later sessions gives, per group, its time in each session over the session
    before (the sessions in the trainees' order, ``session_index``, not by name), over the trainees
    who have a time in both: P3, who timed out on the retest, counts in neither mean of that ratio."""
    times = {"P1": (10.0, 15.0, 12.0), "P2": (12.0, 16.0, 14.0), "P3": (8.0, None, 9.0)}
    rows = []
    for person, tests in times.items():
        rows.append([person, "T", "training", "m", "C", True, 20.0, 0, 0, "completed", False, "post", 1])
        for index, (session, time) in enumerate(zip(("post", "fortnight", "month"), tests)):
            rows.append([person, "T", "test", "m", "C", time is not None, time, 0, int(index == 0), "completed"
                         if time is not None else "timeout", False, session, index + 1])
    trials = pd.DataFrame(rows, columns=["participant", "group", "phase", "interaction", "object", "completed",
                                         "time_s", "attempts", "task_index", "status", "withdrawn", "session",
                                         "session_index"])
    statistics = [s for s in study_statistics(trials) if s.statistic == "paired"]
    cell = "group=T,session={},phase=test,interaction=m"
    assert [s.key for s in statistics] == [
        f"time_s.paired[{cell.format('fortnight')}]/[{cell.format('post')}]",
        f"time_s.paired[{cell.format('month')}]/[{cell.format('fortnight')}]"]  # training runs in one session only
    values = summarise(trials, statistics)["value"]
    assert values[0] == pytest.approx((15.0 + 16.0) / 2 / ((10.0 + 12.0) / 2))
    assert values[1] == pytest.approx((12.0 + 14.0) / 2 / ((15.0 + 16.0) / 2))
    # a ratio of the same selections over whoever has a time in each: P3 in the post-test's mean
    unpaired = Statistic("time_s", "ratio", statistics[0].where, statistics[0].versus)
    assert summarise(trials, [unpaired])["value"][0] == pytest.approx((15.0 + 16.0) / 2 / ((10.0 + 12.0 + 8.0) / 3))
    se = bootstrap_se(trials, statistics, seed=2)
    assert np.all(se >= RESOLUTION["ratio"]) and np.all(np.isfinite(se))
