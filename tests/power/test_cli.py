"""``microg power`` writes what the issue names: power.csv (its columns and terms), the power curve and
summary.json with the smallest n per group that reaches the target."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from matplotlib import image
from scipy import stats

from microg.cli import main
from microg.power import exact_power, read_effects

from .conftest import compound_symmetry_power, effects_text

COLUMNS = ["n_per_group", "term", "power", "ci_low", "ci_high", "method"]


@pytest.mark.parametrize("target", [0.8, 0.5])
def test_exact_run_writes_table_curve_and_summary(effects_file, design, tmp_path, target):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--n", "8,10,15,20,30",
                                       "--target", str(target), "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "power.csv")
    assert list(table.columns) == COLUMNS
    assert list(table["term"][:3]) == ["group", "object", "group:object"]
    assert set(table["term"]) == set(design.tests)
    assert "veteran - beginner | cube" in set(table["term"]) and "cube - flat_cuboid | beginner" in set(table["term"])
    assert (table["method"] == "exact").all() and (table["ci_low"] == table["power"]).all()

    means = np.array([[45.0, 55.0, 55.0], [55.0, 70.0, 70.0]])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["target"] == target
    for term, name in zip(design.terms, ("between", "within", "interaction")):
        closed = {n: compound_symmetry_power(means, 20.0, 0.5, n, 0.05)[name] for n in (8, 10, 15, 20, 30)}
        rows = table[table["term"] == term].set_index("n_per_group")["power"]
        assert np.allclose([rows[n] for n in closed], list(closed.values()), atol=1e-6)
        reached = [n for n, power in closed.items() if power >= target]
        assert summary["smallest_n_per_group"][term] == (min(reached) if reached else None)
        assert str(summary["smallest_n_per_group"][term] or "> 30") in result.output

    picture = image.imread(out / "power-curve.png")
    assert picture.ndim == 3 and picture.shape[0] > 300 and picture.shape[1] > 600
    assert "sphericity assumed" in result.output


def test_the_interaction_comparison_as_the_within_factor(tmp_path):
    path = tmp_path / "effects.toml"
    means = {"veteran": {"impulse_penetration": 20.0, "soft_hand": 35.0},
             "beginner": {"impulse_penetration": 22.0, "soft_hand": 40.0}}  # fmt: skip
    path.write_text(effects_text(means, 12.0, 0.3))
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["power", "--within", "interaction", "--effects", str(path), "--n", "5",
                                       "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "power.csv").set_index("term")["power"]
    closed = compound_symmetry_power(np.array([[20.0, 35.0], [22.0, 40.0]]), 12.0, 0.3, 5, 0.05)
    assert table["interaction"] == pytest.approx(closed["within"], abs=1e-6)
    assert table["group:interaction"] == pytest.approx(closed["interaction"], abs=1e-6)
    assert "impulse_penetration - soft_hand | veteran" in table.index


def test_an_object_name_of_the_other_factor_is_refused_for_the_interaction_design(effects_file, tmp_path):
    result = CliRunner().invoke(main, ["power", "--within", "interaction", "--effects", str(effects_file),
                                       "--out", str(tmp_path)])  # fmt: skip
    assert result.exit_code == 1 and "means.veteran.cube = 45.0: no interaction 'cube'" in result.output


def test_sensitivity_answers_with_the_smallest_effect_per_test(effects_file, design, tmp_path):
    """Scaled by the factor it reports, the pattern of means gives every ANOVA term and contrast the
    target power exactly; the effect sizes are those of that power (Superpower's convention)."""
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["power", "--sensitivity", "--effects", str(effects_file), "--n", "15",
                                       "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "sensitivity.csv")
    assert list(table.columns) == ["n_per_group", "term", "scale", "np2", "cohen_f", "noncentrality", "df1", "df2",
                                   "epsilon", "power"]  # fmt: skip
    assert not (out / "power.csv").exists()
    effects = read_effects(effects_file, design)
    grand = effects.means.mean()
    for row in table[np.isfinite(table["scale"])].itertuples():
        scaled = replace(effects, means=grand + row.scale * (effects.means - grand))
        power = exact_power(scaled, 15).set_index("term").loc[row.term, "power"]
        assert power == pytest.approx(0.8, abs=1e-8), row.term
        assert row.np2 == pytest.approx(row.cohen_f**2 / (1 + row.cohen_f**2), rel=1e-12)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["smallest_effect"]["15"]["object"]["cohen_f"] == pytest.approx(
        table.set_index("term").loc["object", "cohen_f"])
    assert "group:object" in result.output and "scale" in result.output


def test_unequal_groups_are_planned_and_named(effects_file, tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["power", "--effects", str(effects_file), "--n", "veteran=15,beginner=12",
                                       "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "power.csv")
    assert set(table["n_per_group"]) == {"veteran=15,beginner=12"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_per_group"] == ["veteran=15,beginner=12"]
    assert summary["smallest_n_per_group"]["object"] == "veteran=15,beginner=12"
    assert summary["smallest_n_per_group"]["group"] is None and "not reached" in result.output


def test_effect_sizes_give_the_power_of_the_tests_named(tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["power", "--effect-size", "object:f=0.25", "--effect-size",
                                       "cube - flat_cuboid | veteran:np2=0.2", "--n", "10,20", "--out", str(out)])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "power.csv")
    assert list(table["term"]) == ["object", "cube - flat_cuboid | veteran"] * 2
    df2 = 2 * 2 * (20 - 1)
    expected = stats.ncf.sf(stats.f.isf(0.05, 2, df2), 2, df2, 0.25**2 * df2)
    assert table.set_index(["n_per_group", "term"]).loc[(20, "object"), "power"] == pytest.approx(expected, rel=1e-9)
