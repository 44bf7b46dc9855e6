"""Bad input to ``microg participant calibrate``: clear errors naming the file, key and value,
before any simulated study runs."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main

HERE = Path(__file__).parent
PROTOCOL = HERE / "protocols" / "recovery.toml"
TARGET = '''
n_per_group = 4
[[targets]]
measure = "time_s"
mean = 12.0
sd = 2.0
'''


def calibrate(*arguments) -> str:
    result = CliRunner().invoke(main, ["participant", "calibrate", *map(str, arguments)])
    assert result.exit_code != 0, result.output
    assert "Traceback" not in result.output
    return result.output


def test_a_profile_with_an_unknown_parameter(tmp_path):
    base = tmp_path / "base.toml"
    base.write_text("[parameters.grip_strength]\nmean = 1.0\nsd = 0.1\n")
    targets = tmp_path / "targets.toml"
    targets.write_text(TARGET)
    output = calibrate("--targets", targets, "--protocol", PROTOCOL, "--base", base, "--out", tmp_path / "out.toml")
    assert f"{base}: [parameters.grip_strength]: unknown parameter" in output


def test_a_profile_with_a_negative_sd(tmp_path):
    base = tmp_path / "base.toml"
    base.write_text("[parameters.aim_sd]\nmean = 0.004\nsd = -0.001\n")
    targets = tmp_path / "targets.toml"
    targets.write_text(TARGET)
    output = calibrate("--targets", targets, "--protocol", PROTOCOL, "--base", base, "--out", tmp_path / "out.toml")
    assert f"{base}: parameters.aim_sd.sd = -0.001: must be >= 0" in output


@pytest.mark.parametrize("entry, message", [
    ('measure = "speed"\nmean = 1.0\nse = 0.1', "targets[0].measure = 'speed': unknown measure (known: time_s, "
                                                "attempts, completed)"),
    ('measure = "time_s"\ngroup = "X"\nmean = 1.0\nse = 0.1', "targets[0].group = 'X': unknown group (known: B, V)"),
    ('measure = "time_s"\nobject = "cube"\nversus = { object = "F" }\nratio = 2.0\nse = 0.1',
     "targets[0].versus.object = 'F': unknown object (known: C)"),
    ('measure = "time_s"\nmean = 10.0', "targets[0].mean: a mean without its sd needs se"),
    ('measure = "attempts"\ngroup = "B"\nversus = { group = "V" }\nratio = 2.0', "targets[0].ratio: needs se"),
    ('measure = "time_s"\nmean = 10.0\nsd = -2.0', "targets[0].sd = -2.0: must be a finite number >= 0"),
    ('measure = "time_s"\nmedian = 10.0\nse = 1.0', "targets[0].median: unknown key"),
    ('measure = "time_s"\nn = 1\nmean = 10.0\nsd = 2.0', "targets[0].n = 1: an SD between people needs at least two"),
    ('measure = "time_s"\nn = 2.5\nmean = 10.0\nsd = 2.0', "targets[0].n = 2.5: must be a whole number"),
    ('measure = "time_s"\nmean = 10.0\nsd = 0.0', "targets[0].sd = 0.0: gives a standard error of 0"),
    ('measure = "time_s"\nmean = 10.0\nse = 1e-300', "targets[0]: a standard error of 1e-300 (from se) is below "
                                                     "1e-09: no data are that exact"),
    ('measure = "time_s"\nn = 1e30\nmean = 10.0\nsd = 1e-5', "targets[0]: a standard error of 1e-20 (from "
                                                             "sd and n) is below 1e-09"),
    ('measure = "completed"\nmean = 1.5\nse = 0.1', "targets[0].mean = 1.5: a share of tasks completed lies from 0"),
    ('measure = "time_s"\nmean = 10.0\nsd = 2.0\n[[targets]]\nmeasure = "time_s"\nmean = 20.0\nse = 1.0',
     "targets[1]: time_s.mean[] is given already by targets[0]; give each number once"),
])  # fmt: skip
def test_a_target_that_cannot_be_fitted(tmp_path, entry, message):
    targets = tmp_path / "targets.toml"
    targets.write_text(f"n_per_group = 4\n[[targets]]\n{entry}\n")
    output = calibrate("--targets", targets, "--protocol", PROTOCOL, "--out", tmp_path / "out.toml")
    assert f"{targets}: {message}" in output


def test_a_pilot_too_small_to_fit(tmp_path):
    rows = [["P1", "V", "stage1", "impulse_penetration", "C", True, 11.0, 0, 0],
            ["P2", "B", "stage1", "impulse_penetration", "C", True, 12.0, 1, 0],
            ["P3", "B", "stage1", "impulse_penetration", "C", True, 14.0, 0, 0]]
    trials = tmp_path / "pilot.csv"
    pd.DataFrame(rows, columns=["participant", "group", "phase", "interaction", "object", "completed", "time_s",
                                "attempts", "task_index"]).to_csv(trials, index=False)  # fmt: skip
    output = calibrate("--trials", trials, "--protocol", PROTOCOL, "--out", tmp_path / "out.toml")
    assert f"{trials}: group = 'V': 1 participant; a calibration needs at least two per group" in output


@pytest.mark.parametrize("column, value, message", [
    ("time_s", "fast", "column 'time_s' value 'fast' is not a number (data row 2, participant 'P1')"),
    ("time_s", "inf", "column 'time_s' value inf is not finite (data row 2, participant 'P1')"),
    ("time_s", "-5", "column 'time_s' value -5.0 is negative (data row 2, participant 'P1')"),
    ("time_s", "", "column 'completed' value True is True but time_s is empty (data row 2, participant 'P1')"),
    ("attempts", "1.5", "column 'attempts' value 1.5 is not a count (a whole number) (data row 2, participant 'P1')"),
    ("completed", "maybe", "column 'completed' value 'maybe' is not True or False (data row 2, participant 'P1')"),
    ("group", "", "column 'group' value nan is empty (data row 2, participant 'P1')"),
])  # fmt: skip
def test_a_pilot_with_a_value_that_is_not_a_measure(tmp_path, column, value, message):
    """The report's own checks of a trials table (``check_trials``): before them a text cell ended in
    a traceback, an infinite time after the sampler had started, and one odd flag turned every
    "False" of its column into a completed task."""
    header = ["participant", "group", "phase", "interaction", "object", "completed", "time_s", "attempts", "task_index"]
    rows = [[f"P{i}", group, "stage1", "impulse_penetration", "C", "True", "11.0", "0", "0"]
            for i, group in enumerate("VVBB")]
    rows[1][header.index(column)] = value
    trials = tmp_path / "pilot.csv"
    trials.write_text("\n".join(",".join(row) for row in [header, *rows]) + "\n")
    output = calibrate("--trials", trials, "--protocol", PROTOCOL, "--out", tmp_path / "fit" / "out.toml")
    assert f"{trials}: {message}" in output
    assert not (tmp_path / "fit").exists()


def test_a_targets_file_whose_protocol_is_not_there(tmp_path):
    targets = tmp_path / "targets.toml"
    targets.write_text('protocol = "nosuch"\n' + TARGET)
    assert f"{targets}: protocol = 'nosuch': " in calibrate("--targets", targets, "--out", tmp_path / "out.toml")


def test_a_pilot_with_an_object_the_protocol_lacks(tmp_path):
    rows = [[f"P{i}", group, "stage1", "impulse_penetration", "mug", True, 11.0, 0, 0]
            for i, group in enumerate("VVBB")]
    trials = tmp_path / "pilot.csv"
    pd.DataFrame(rows, columns=["participant", "group", "phase", "interaction", "object", "completed", "time_s",
                                "attempts", "task_index"]).to_csv(trials, index=False)  # fmt: skip
    output = calibrate("--trials", trials, "--protocol", PROTOCOL, "--out", tmp_path / "out.toml")
    assert f"{trials}: object = 'mug': not in protocol 'recovery' (known: C)" in output


def test_options_that_name_nothing(tmp_path):
    targets = tmp_path / "targets.toml"
    targets.write_text(TARGET)
    common = ["--targets", targets, "--protocol", PROTOCOL, "--out", tmp_path / "out.toml"]
    assert "--fit 'grip_strength': 'grip_strength': give NAME" in calibrate(*common, "--fit", "grip_strength")
    assert "--fit ',,': '': give NAME" in calibrate(*common, "--fit", ",,")
    assert "--fit '': '': give NAME" in calibrate(*common, "--fit", "")  # not the default list
    assert "--hold-out 'attempts.*': matches no number" in calibrate(*common, "--hold-out", "attempts.*")
    assert "--hold-out 'time_s.*': every number is held out" in calibrate(*common, "--hold-out", "time_s.*")
    assert "give exactly one of STUDY, --trials FILE, --targets FILE" in calibrate("--out", tmp_path / "out.toml")


def test_a_folder_that_is_no_study(tmp_path):
    output = calibrate(tmp_path / "nothing", "--out", tmp_path / "out.toml")
    assert f"no study in {tmp_path / 'nothing'}" in output
    assert "--protocol: a study is simulated with its own protocol" in calibrate(
        tmp_path / "nothing", "--protocol", "paper", "--out", tmp_path / "out.toml")


def test_a_simulated_group_larger_than_a_study_can_run_is_refused_before_anything_runs(tmp_path):
    """n_per_group of a published study of a billion people (or --participants as large) would set
    the simulated studies' groups; they are refused naming the option, and nothing is written."""
    targets = tmp_path / "targets.toml"
    targets.write_text(TARGET.replace("n_per_group = 4", "n_per_group = 1000000000"))
    output = calibrate("--targets", targets, "--protocol", PROTOCOL, "--out", tmp_path / "fit" / "out.toml")
    assert "--participants = 1000000000: simulated studies have at most 1000 participants per group" in output
    output = calibrate("--targets", targets, "--protocol", PROTOCOL, "--participants", "5000", "--out",
                       tmp_path / "fit" / "out.toml")
    assert "--participants = 5000: simulated studies have at most 1000" in output
    assert not (tmp_path / "fit").exists()


def test_a_retention_parameter_is_not_fitted_from_one_session_numbers(tmp_path):
    """A study of one session says nothing about forgetting across days: refused, nothing written."""
    targets = tmp_path / "targets.toml"
    targets.write_text(TARGET)
    output = calibrate("--targets", targets, "--protocol", PROTOCOL, "--fit", "movement_slope,forgetting_rate",
                       "--out", tmp_path / "out.toml")
    assert "--fit: forgetting_rate: a parameter of retention across sessions" in output
    assert "fit it to a training program's pilot" in output
    assert not (tmp_path / "out.toml").exists()
