"""``microg power`` writes what the issue names: power.csv (its columns and terms), the power curve and
summary.json with the smallest n per group that reaches the target."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from matplotlib import image

from microg.cli import main

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
