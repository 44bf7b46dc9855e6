"""Bad input ends with one clear line naming the file (or option), the key and the value; no traceback."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.paths import PROTOCOLS

from .conftest import ISSUE_EFFECTS, effects_text

BIG = "1" + "0" * 400
"""An integer TOML reads and no double holds."""
GOOD = {"veteran": {"cube": 45.0, "flat_cuboid": 55.0, "long_cuboid": 55.0},
        "beginner": {"cube": 55.0, "flat_cuboid": 70.0, "long_cuboid": 70.0}}  # fmt: skip


def _correlations(diagonal=1.0, pair=0.5, other=0.3, asymmetric=False) -> str:
    """[correlation.<group>] tables; the veteran's with the oddity asked for, the beginner's sound."""
    text = ""
    for group in GOOD:
        d, p, o = (diagonal, pair, other) if group == "veteran" else (1.0, 0.5, 0.3)
        back = 0.4 if asymmetric and group == "veteran" else p
        text += (f"[correlation.{group}]\ncube = {{ cube = {d}, flat_cuboid = {p}, long_cuboid = {o} }}\n"
                 f"flat_cuboid = {{ cube = {back}, flat_cuboid = 1.0, long_cuboid = {p} }}\n"
                 f"long_cuboid = {{ cube = {o}, flat_cuboid = {p}, long_cuboid = 1.0 }}\n")
    return text


def _sds(long_cuboid: float) -> str:
    return "".join(f"[sd.{group}]\ncube = 10.0\nflat_cuboid = 12.0\nlong_cuboid = "
                   f"{long_cuboid if group == 'veteran' else 14.0}\n" for group in GOOD)

CASES = {
    "unknown group": (effects_text({**GOOD, "expert": {"cube": 1.0}}, 20.0, 0.5), ["means.expert", "expert"]),
    "unknown object": (effects_text({**GOOD, "veteran": {**GOOD["veteran"], "ball": 50.0}}, 20.0, 0.5),
                       ["means.veteran.ball", "50.0", "'ball'"]),
    "missing object": (effects_text({**GOOD, "beginner": {"cube": 1.0, "flat_cuboid": 2.0}}, 20.0, 0.5),
                       ["means.beginner.long_cuboid"]),
    "correlation 1": (effects_text(GOOD, 20.0, 1.0), ["correlation = 1.0", "(-0.5, 1)"]),
    "correlation at -1/(k-1)": (effects_text(GOOD, 20.0, -0.5), ["correlation = -0.5", "(-0.5, 1)"]),
    "correlation above 1": (effects_text(GOOD, 20.0, 1.7), ["correlation = 1.7"]),
    "SD 0": (effects_text(GOOD, 0.0, 0.5), ["sd = 0.0", "positive"]),
    "SD negative": (effects_text(GOOD, -3.0, 0.5), ["sd = -3.0", "positive"]),
    "a mean that is text": (ISSUE_EFFECTS.replace("cube = 45.0", 'cube = "fast"'), ["means.veteran.cube", "'fast'"]),
    "unknown key": ("sigma = 3\n" + ISSUE_EFFECTS, ["sigma = 3", "unknown key"]),
    "both forms": (ISSUE_EFFECTS + "[covariance.veteran]\ncube = { cube = 1.0 }\n", ["sd = 20.0", "not both"]),
    "asymmetric covariance": (
        effects_text(GOOD, extra="".join(
            f"[covariance.{g}]\ncube = {{ cube = 4.0, flat_cuboid = 1.0, long_cuboid = 0.0 }}\n"
            f"flat_cuboid = {{ cube = {2.0 if g == 'beginner' else 1.0}, flat_cuboid = 4.0, long_cuboid = 0.0 }}\n"
            "long_cuboid = { cube = 0.0, flat_cuboid = 0.0, long_cuboid = 4.0 }\n" for g in GOOD)),
        ["covariance.beginner.cube.flat_cuboid = 1.0", "covariance.beginner.flat_cuboid.cube = 2.0", "symmetric"]),
    "not TOML": ("sd = = 3\n", ["not valid TOML"]),
    "an integer no double holds": (ISSUE_EFFECTS.replace("cube = 45.0", f"cube = {BIG}", 1),
                                   [f"means.veteran.cube = {BIG}", "too large for a double"]),
    "a mean 1e300": (ISSUE_EFFECTS.replace("cube = 45.0", "cube = 1e300", 1),
                     ["means.veteran.cube = 1e+300", "SDs (SD 20) from zero", "up to 10000 SDs"]),
    "a mean 10^5 SDs from zero": (ISSUE_EFFECTS.replace("cube = 45.0", "cube = 2000045.0", 1),
                                  ["means.veteran.cube = 2000045.0", "lies 1e+05 SDs (SD 20)"]),
    "SD 1e200": (effects_text(GOOD, 1e200, 0.5), ["sd = 1e+200", "from 1e-50 to 1e+50"]),
    "SD 1e-200": (effects_text(GOOD, 1e-200, 0.5), ["sd = 1e-200", "from 1e-50 to 1e+50"]),
    "a variance 1e300": (
        effects_text(GOOD, extra="".join(
            f"[covariance.{g}]\ncube = {{ cube = 1e300, flat_cuboid = 0.0, long_cuboid = 0.0 }}\n"
            "flat_cuboid = { cube = 0.0, flat_cuboid = 4.0, long_cuboid = 0.0 }\n"
            "long_cuboid = { cube = 0.0, flat_cuboid = 0.0, long_cuboid = 4.0 }\n" for g in GOOD)),
        ["covariance.veteran.cube.cube = 1e+300", "a variance must be a positive number from 1e-100 to 1e+100"]),
    "nested too deeply": ("sd = " + "[" * 2000 + "]" * 2000 + "\n", ["nested too deeply"]),
    "correlation matrix without 1 on its diagonal": (
        effects_text(GOOD, 20.0, extra=_correlations(diagonal=0.9)), ["correlation.veteran.cube.cube = 0.9", "is 1"]),
    "correlation matrix entry of 1": (
        effects_text(GOOD, 20.0, extra=_correlations(pair=1.0)), ["correlation.veteran.cube.flat_cuboid = 1.0",
                                                                   "(-1, 1)"]),
    "correlation matrix not positive definite": (
        effects_text(GOOD, 20.0, extra=_correlations(pair=0.95, other=-0.95)),
        ["correlation.veteran", "not positive definite"]),
    "asymmetric correlation matrix": (
        effects_text(GOOD, 20.0, extra=_correlations(asymmetric=True)),
        ["correlation.veteran.cube.flat_cuboid = 0.5", "symmetric"]),
    "SD of 0 for one object": (
        effects_text(GOOD, correlation=0.5, extra=_sds(0.0)), ["sd.veteran.long_cuboid = 0.0", "positive"]),
    "SD table without a group": (
        effects_text(GOOD, correlation=0.5, extra="[sd.veteran]\ncube = 1.0\nflat_cuboid = 1.0\nlong_cuboid = 1.0\n"),
        ["missing table [sd.beginner]"]),
}  # fmt: skip


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_effects_file_names_file_key_and_value(tmp_path, case):
    text, expected = CASES[case]
    path = tmp_path / "effects.toml"
    path.write_text(text)
    result = CliRunner().invoke(main, ["power", "--effects", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1, result.output
    assert result.output.startswith("Error: ") and "Traceback" not in result.output
    assert str(path) in result.output
    for part in expected:
        assert part in result.output, (part, result.output)
    assert not (tmp_path / "out" / "power.csv").exists()


def test_an_effects_file_that_is_not_utf8_is_named(tmp_path):
    path = tmp_path / "effects.toml"
    path.write_bytes(("# temps de réalisation\n" + ISSUE_EFFECTS).encode("latin-1"))
    result = CliRunner().invoke(main, ["power", "--effects", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert f"Error: {path}: not UTF-8 text (byte 0xe9 at position 12)" in result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("sizes, shown, why", [("8,1", "--n = 1", "at least 2"), ("0", "--n = 0", "at least 2"),
                                               ("-4,10", "--n = -4", "at least 2"),
                                               ("10,100000", "--n = 100000", "at most 1000"),
                                               (BIG, f"--n = {BIG}", "at most 1000")])
def test_group_sizes_the_computation_cannot_handle_are_refused(effects_file, tmp_path, sizes, shown, why):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--n", sizes, "--out", str(tmp_path)])
    assert result.exit_code == 1 and result.output.startswith("Error: ")
    assert shown in result.output and why in result.output
    assert list(tmp_path.iterdir()) == [effects_file]


def test_a_negative_seed_is_refused_by_the_option(effects_file, tmp_path):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--method", "montecarlo",
                                       "--seed", "-1", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "-1 is not in the range 0<=x<=9223372036854775807" in result.output


@pytest.mark.parametrize("option, value", [("--alpha", "1.5"), ("--alpha", "0"), ("--target", "0")])
def test_levels_outside_their_range_are_refused(effects_file, tmp_path, option, value):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), option, value, "--out", str(tmp_path)])
    assert result.exit_code == 1 and f"{option} = {float(value)!r}" in result.output


def test_one_source_of_effects_exactly(effects_file, tmp_path):
    both = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--simulated", "--out", str(tmp_path)])
    none = CliRunner().invoke(main, ["power", "--out", str(tmp_path)])
    assert both.exit_code == 2 and "--effects and --simulated" in both.output
    assert none.exit_code == 2 and "exactly one of" in none.output


def test_a_population_is_only_for_in_silico_studies(effects_file, tmp_path):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--profile",
                                       str(PROTOCOLS / "populations" / "literature.toml"), "--out", str(tmp_path)])
    assert result.exit_code == 1 and "--profile draws the participants of --simulated studies" in result.output


def test_a_bad_population_file_is_named_with_its_key_and_value(tmp_path):
    profile = tmp_path / "pilot.toml"
    text = (PROTOCOLS / "populations" / "literature.toml").read_text()
    assert "sd = 0.0018" in text  # the aim's SD between people
    profile.write_text(text.replace("sd = 0.0018", "sd = -0.0018"))
    result = CliRunner().invoke(main, ["power", "--simulated", "--profile", str(profile), "--out", str(tmp_path / "run")])
    assert result.exit_code == 2 and str(profile) in result.output and "aim_sd" in result.output, result.output
    assert "-0.0018" in result.output
    assert not (tmp_path / "run").exists()


def test_in_silico_studies_of_a_group_without_a_simulated_participant_are_refused_before_any_runs(tmp_path):
    protocol = tmp_path / "mine.toml"
    protocol.write_text((PROTOCOLS / "paper.toml").read_text().replace('simulated_profile = "practice"',
                                                                      'simulated_profile = "expert"'))
    result = CliRunner().invoke(main, ["power", "--simulated", "--protocol", str(protocol), "--out", str(tmp_path / "run")])
    assert result.exit_code == 1 and f"{protocol}: groups[0].simulated_profile = 'expert'" in result.output
    assert not (tmp_path / "run").exists()


def test_a_scheduler_that_is_no_address(tmp_path):
    result = CliRunner().invoke(main, ["power", "--simulated", "--scheduler", "foo", "--out", str(tmp_path / "run")])
    assert result.exit_code == 1 and "--scheduler foo: cannot connect: " in result.output, result.output
    assert "Traceback" not in result.output


def test_exact_power_of_in_silico_studies_is_refused(tmp_path):
    result = CliRunner().invoke(main, ["power", "--simulated", "--method", "exact", "--out", str(tmp_path)])
    assert result.exit_code == 1 and "--method exact" in result.output


@pytest.mark.parametrize("sizes, shown", [
    ("veteran=15", "no size for group 'beginner'"),
    ("veteran=15,beginner=12,expert=3", "no group 'expert'"),
    ("veteran=15,beginner=1", "group beginner needs at least 2"),
])  # fmt: skip
def test_unequal_groups_name_every_group_of_the_protocol(effects_file, tmp_path, sizes, shown):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--n", sizes, "--out", str(tmp_path)])
    assert result.exit_code == 1 and result.output.startswith("Error: ") and shown in result.output, result.output


def test_a_size_that_is_not_a_number_is_refused(effects_file, tmp_path):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--n", "veteran=15,beginner=x",
                                       "--out", str(tmp_path)])  # fmt: skip
    assert result.exit_code == 2 and "'x' is not a whole number" in result.output


@pytest.mark.parametrize("args, shown", [
    (["--effect-size", "object:g=0.2"], "the effect size is f or np2"),
    (["--effect-size", "object - cube:f=0.2"], "no such test"),
    (["--effect-size", "np2=1.2"], "partial eta squared must lie in [0, 1)"),
    (["--effect-size", "f=-0.1"], "Cohen's f must be 0 or more"),
    (["--effect-size", "f=0.2", "--method", "montecarlo"], "computed exactly"),
    (["--effect-size", "f=0.2", "--correction", "GG"], "needs the covariance"),
    (["--sensitivity", "--method", "montecarlo"], "computed exactly"),
    (["--sensitivity", "--correction", "HF"], "needs the covariance"),
])  # fmt: skip
def test_effect_sizes_and_sensitivity_refuse_what_they_cannot_compute(tmp_path, args, shown):
    result = CliRunner().invoke(main, ["power", *args, "--n", "10", "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and result.output.startswith("Error: ") and shown in result.output, result.output


def test_the_reports_mauchly_rule_needs_simulated_data_sets(effects_file, tmp_path):
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--correction", "mauchly",
                                       "--out", str(tmp_path)])  # fmt: skip
    assert result.exit_code == 1 and "--correction mauchly with --method exact" in result.output


def test_sensitivity_takes_a_pattern_or_none(effects_file, tmp_path):
    result = CliRunner().invoke(main, ["power", "--sensitivity", "--simulated", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--sensitivity takes the pattern of --effects or --pilot" in result.output
    both = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--effect-size", "f=0.1",
                                     "--out", str(tmp_path)])  # fmt: skip
    assert both.exit_code == 2 and "--effects and --effect-size" in both.output
