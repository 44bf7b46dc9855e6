"""Exact power against closed forms: the noncentralities of a balanced mixed design under compound
symmetry (and under any covariance, for the traces), and of each post hoc t test, fed to scipy."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from microg.power import effects_from_means, exact_dataset, exact_power, read_effects

from .conftest import compound_symmetry_power, effects_text

MEANS = {"veteran": {"cube": 40.0, "flat_cuboid": 55.0, "long_cuboid": 60.0},
         "beginner": {"cube": 50.0, "flat_cuboid": 58.0, "long_cuboid": 75.0}}  # fmt: skip


def _means_array(design) -> np.ndarray:
    return np.array([[MEANS[g][level] for level in design.levels] for g in design.groups])


@pytest.mark.parametrize("sd, rho", [(15.0, 0.6), (25.0, -0.3), (10.0, 0.0)])
@pytest.mark.parametrize("alpha", [0.05, 0.01])
def test_anova_terms_match_the_compound_symmetry_closed_form(tmp_path, design, sd, rho, alpha):
    path = tmp_path / "effects.toml"
    path.write_text(effects_text(MEANS, sd, rho))
    sizes = [2, 3, 5, 12, 30]  # 2 and 3: fewer participants than levels + 1
    table = exact_power(read_effects(path, design), sizes, alpha).set_index(["n_per_group", "term"])
    for n in sizes:
        expected = compound_symmetry_power(_means_array(design), sd, rho, n, alpha)
        for term, name in zip(design.terms, ("between", "within", "interaction")):
            assert table.loc[(n, term), "power"] == pytest.approx(expected[name], abs=1e-6), (n, term)


def test_contrasts_match_the_t_test_closed_form(tmp_path, design):
    sd, rho, alpha, g = 15.0, 0.6, 0.05, 2
    path = tmp_path / "effects.toml"
    path.write_text(effects_text(MEANS, sd, rho))
    m = _means_array(design)
    levels = list(design.levels)
    for n in (3, 10, 25):
        table = exact_power(read_effects(path, design), n, alpha).set_index("term")["power"]
        df = g * (n - 1)

        def power(delta, family, df=df):
            critical = stats.t.isf(alpha / family / 2, df)
            return stats.nct.sf(critical, df, delta) + stats.nct.cdf(-critical, df, delta)

        for a, b in [("cube", "flat_cuboid"), ("cube", "long_cuboid"), ("flat_cuboid", "long_cuboid")]:
            i, j = levels.index(a), levels.index(b)
            averaged = np.mean(m[:, i] - m[:, j]) / np.sqrt(2 * sd**2 * (1 - rho) / (g * n))
            assert table[f"{a} - {b}"] == pytest.approx(power(averaged, 3), abs=1e-6)
            for row, group in enumerate(design.groups):
                inside = (m[row, i] - m[row, j]) / np.sqrt(2 * sd**2 * (1 - rho) / n)
                assert table[f"{a} - {b} | {group}"] == pytest.approx(power(inside, 6), abs=1e-6)
        for j, level in enumerate(levels):
            between = (m[0, j] - m[1, j]) / np.sqrt(2 * sd**2 / n)
            assert table[f"veteran - beginner | {level}"] == pytest.approx(power(between, 3), abs=1e-6)


def test_a_full_covariance_per_group_gives_the_trace_noncentralities(tmp_path, design):
    """Any common covariance S: lambda_group = n k sum (m_g. - m..)^2 / (1'S1 / k) and lambda_within =
    n g |m_.j - m..|^2 / (tr(P S) / (k - 1)) with P the centring matrix (the error mean squares of
    the exact data set are these population values)."""
    covariance = np.array([[100.0, 30.0, 10.0], [30.0, 400.0, 150.0], [10.0, 150.0, 900.0]])
    rows = "".join(
        f"[covariance.{group}]\n" + "".join(
            f"{a} = {{ " + ", ".join(f"{b} = {float(covariance[i, j])!r}" for j, b in enumerate(design.levels)) + " }\n"
            for i, a in enumerate(design.levels))
        for group in design.groups)  # fmt: skip
    path = tmp_path / "effects.toml"
    path.write_text(effects_text(MEANS, extra=rows))
    m, g, k, n, alpha = _means_array(design), 2, 3, 9, 0.05
    centring = np.eye(k) - 1 / k
    lam_group = n * k * np.sum((m.mean(axis=1) - m.mean()) ** 2) / (covariance.sum() / k)
    lam_within = n * g * np.sum((m.mean(axis=0) @ centring) ** 2) / (np.trace(centring @ covariance) / (k - 1))
    table = exact_power(read_effects(path, design), n, alpha).set_index("term")["power"]
    df2 = g * (n - 1)
    assert table["group"] == pytest.approx(stats.ncf.sf(stats.f.isf(alpha, 1, df2), 1, df2, lam_group), abs=1e-6)
    dfs = (k - 1, (k - 1) * df2)
    assert table["object"] == pytest.approx(stats.ncf.sf(stats.f.isf(alpha, *dfs), *dfs, lam_within), abs=1e-6)


def test_no_effect_has_power_alpha(design):
    means = pd.DataFrame({"group": np.repeat(design.groups, 3), "object": list(design.levels) * 2, "mean": 50.0})
    table = exact_power(effects_from_means(means, design, sd=10.0, correlation=0.4), [4, 20], alpha=0.05)
    assert np.allclose(table.loc[table["term"].isin(design.terms), "power"], 0.05, atol=1e-12)
    contrasts = table[~table["term"].isin(design.terms)]
    assert (contrasts["power"] < 0.05).all()  # Bonferroni: each test at alpha / family size


def test_the_exact_data_set_has_exactly_the_given_means_and_covariances(design):
    means = pd.DataFrame({"group": np.repeat(design.groups, 3), "object": list(design.levels) * 2,
                          "mean": [45.0, 55, 55, 55, 70, 70]})  # fmt: skip
    effects = effects_from_means(means, design, sd=20.0, correlation=0.5)
    data = exact_dataset(effects, 7)
    for i, group in enumerate(design.groups):
        wide = data[data["group"] == group].pivot(index="participant", columns="object", values="value")
        wide = wide[list(design.levels)].to_numpy()
        assert wide.shape == (7, 3)
        assert np.allclose(wide.mean(axis=0), effects.means[i], atol=1e-9)
        assert np.allclose(np.cov(wide, rowvar=False), effects.covariances[i], atol=1e-9)
