"""The power options against R's Superpower 0.2.4.1 (tests/power/r/superpower.R; stored in
tests/power/r/expected/ by tests/power/r/reproduce.sh): exact power with an SD per cell and a
correlation matrix per group (``nonspherical.toml``, epsilon about .65), with and without the
Greenhouse-Geisser and Huynh-Feldt corrections; the Bonferroni-adjusted post hoc contrasts;
unequal groups (by hand in R: Superpower's exact takes equal groups only); sensitivity; power from
Cohen's f; and Monte Carlo power with a correction, within the interval of Superpower's own.

Exact numbers are compared at 1e-6 relative (1e-9 absolute near 0): R's uniroot runs at 1e-14 and
MASS::mvrnorm(empirical = TRUE) builds the same exact data set up to rounding.
"""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from microg.power import exact_power, montecarlo_batch, power_table, read_effects
from microg.power.exact import effect_size_power, sensitivity

from .superpower_data import EXPECTED, NONSPHERICAL, R_DIR, export_effects, paper_design

RTOL, ATOL = 1e-6, 1e-9
TERMS = ("group", "object", "group:object")


@pytest.fixture(scope="module")
def effects():
    return read_effects(NONSPHERICAL, paper_design())


def _close(ours, theirs, what):
    np.testing.assert_allclose(np.asarray(ours, float), np.asarray(theirs, float), rtol=RTOL, atol=ATOL, err_msg=what)


def _merge(ours: pd.DataFrame, theirs: pd.DataFrame, keys) -> pd.DataFrame:
    ours, theirs = ours.copy(), theirs.copy()
    for frame in (ours, theirs):
        for key in keys:
            frame[key] = frame[key].astype(str)
    merged = ours.merge(theirs, on=list(keys), suffixes=("", "_r"), how="outer", indicator=True)
    assert (merged["_merge"] == "both").all(), merged.loc[merged["_merge"] != "both", list(keys) + ["_merge"]]
    return merged


def _exact_matches(effects, expected: pd.DataFrame, samples) -> None:
    for correction, rows in expected.groupby("correction"):
        ours = exact_power(effects, samples, 0.05, correction)
        ours = ours[ours["term"].isin(rows["term"])]
        merged = _merge(ours, rows, ["n_per_group", "term"])
        _close(merged["power"], merged["power_r"], f"power, {correction}")
        _close(merged["np2"], merged["np2_r"], f"np2, {correction}")
        yield correction, merged


def test_exact_power_matches_anova_exact(effects):
    """Superpower's noncentrality is f^2 times the corrected df2: lambda x epsilon for a term, delta^2
    for a contrast."""
    expected = pd.read_csv(EXPECTED / "exact.csv")
    seen = set()
    for correction, merged in _exact_matches(effects, expected, [8, 15]):
        seen.add(correction)
        _close(merged["cohen_f"], merged["cohen_f_r"], "cohen_f")
        term = merged["term"].isin(TERMS)
        scaled = np.where(term, merged["noncentrality"] * merged["epsilon"], merged["noncentrality"] ** 2)
        _close(scaled, merged["noncentrality_r"], f"noncentrality, {correction}")
    assert seen == {"none", "GG", "HF"}
    assert len(expected[expected["correction"] == "none"]) == 2 * len(paper_design().tests)


def test_the_corrections_lower_the_power_of_the_within_effects(effects):
    power = {c: exact_power(effects, 8, 0.05, c).set_index("term")["power"] for c in ("none", "GG", "HF")}
    for term in ("object", "group:object"):
        assert power["GG"][term] < power["HF"][term] < power["none"][term]
    assert power["GG"]["group"] == power["none"]["group"]


def test_unequal_groups_match_the_exact_data_set_in_afex(effects):
    expected = pd.read_csv(EXPECTED / "exact_unequal.csv")
    for correction, merged in _exact_matches(effects, expected, [(12, 9), 8]):
        _close(merged["epsilon"], merged["epsilon_r"], f"epsilon, {correction}")
        lam = np.where(merged["term"].isin(TERMS), merged["noncentrality"], merged["noncentrality"] ** 2)
        _close(lam, merged["lambda"], f"lambda, {correction}")
        _close(merged["df2"], merged["df2_r"], "df2")
    assert "veteran=12,beginner=9" in set(expected["n_per_group"])


def test_sensitivity_matches_power_ftest_and_scaling_the_means_reaches_the_target(effects):
    expected = pd.read_csv(EXPECTED / "sensitivity.csv")
    checked = 0
    for (sample, correction), rows in expected.groupby(["n_per_group", "correction"]):
        n = [(12, 9)] if "=" in sample else int(sample)
        ours = sensitivity(effects.design, n, 0.05, 0.8, effects, correction)
        merged = _merge(ours, rows, ["n_per_group", "term"])
        for column in ("cohen_f", "np2", "noncentrality", "scale", "epsilon", "power"):
            _close(merged[column], merged[f"{column}_r"], f"{column}, {sample}, {correction}")
        checked += len(merged)
    assert checked == 3 * len(paper_design().tests)
    scaled = expected.dropna(subset=["power_scaled"])
    assert len(scaled) == 6
    _close(scaled["power_scaled"], 0.8, "Superpower's power at the scaled means")


def test_sensitivity_without_a_pattern_needs_only_the_design():
    design = paper_design()
    table = sensitivity(design, 15).set_index("term")
    expected = pd.read_csv(EXPECTED / "sensitivity.csv").query("n_per_group == '15' and correction == 'none'")
    _close(table.loc[expected["term"], "cohen_f"], expected["cohen_f"], "cohen_f")
    assert table["scale"].isna().all()


def test_a_pattern_without_an_effect_is_never_scaled_into_one(effects):
    means = effects.means.copy()
    means[:, 2] = means[:, 1]  # flat and long cuboid alike in both groups
    flat = type(effects)(effects.design, means, effects.covariances, "flat = long")
    table = sensitivity(flat.design, 15, effects=flat).set_index("term")
    assert table.loc["flat_cuboid - long_cuboid", "scale"] == np.inf
    assert np.isfinite(table.loc["cube - flat_cuboid", "scale"])


def test_power_from_an_effect_size_matches_power_ftest():
    expected = pd.read_csv(EXPECTED / "effect_sizes.csv")
    design = paper_design()
    for (n, f), rows in expected.groupby(["n_per_group", "cohen_f"]):
        ours = effect_size_power(design, {term: ("f", f) for term in rows["term"]}, int(n)).set_index("term")
        _close(ours.loc[rows["term"], "power"], rows["power"], f"n = {n}, f = {f}")
        as_np2 = effect_size_power(design, {term: ("np2", f**2 / (1 + f**2)) for term in rows["term"]}, int(n))
        _close(as_np2["power"], ours.loc[as_np2["term"], "power"], "np2 = f^2 / (1 + f^2)")


@pytest.mark.parametrize("correction", ["GG", "HF"])
def test_monte_carlo_with_a_correction_agrees_with_anova_power(effects, correction):
    """Both are simulations: the difference of the two proportions lies within 3.29 of its standard
    error (99.9 %) for every term."""
    expected = pd.read_csv(EXPECTED / "montecarlo.csv").query("correction == @correction").set_index("term")
    sims = 10_000
    rows = montecarlo_batch(effects, 8, range(sims), seed=5, alpha=0.05, correction=correction)
    ours = power_table(rows, 0.05, "montecarlo").set_index("term")
    for term in TERMS:
        p, q = ours.loc[term, "power"], expected.loc[term, "power"]
        pooled = (p * sims + q * expected.loc[term, "sims"]) / (sims + expected.loc[term, "sims"])
        se = np.sqrt(pooled * (1 - pooled) * (1 / sims + 1 / expected.loc[term, "sims"]))
        assert abs(p - q) <= stats.norm.isf(0.0005) * se, (term, p, q)


def _superpower_ready() -> bool:
    if shutil.which("Rscript") is None:
        return False
    probe = subprocess.run(["Rscript", "-e", "suppressMessages({library(Superpower); library(afex)})"],
                           capture_output=True, timeout=120, check=False)  # fmt: skip
    return probe.returncode == 0


@pytest.mark.slow
@pytest.mark.skipif(not _superpower_ready(), reason="Rscript with Superpower 0.2.4.1 and afex is not installed "
                    "(scripts/install-system-deps.sh installs it from ../shared/reference/r/)")
def test_other_effects_match_superpower_live(tmp_path):
    """Fresh effects (means, SDs and correlations drawn from a seed), run through superpower.R now."""
    rng = np.random.default_rng(77)
    design = paper_design()
    lines = []
    for group in design.groups:
        lines.append(f"[means.{group}]")
        lines += [f"{level} = {rng.uniform(30, 70):.3f}" for level in design.levels]
        lines.append(f"[sd.{group}]")
        lines += [f"{level} = {rng.uniform(5, 25):.3f}" for level in design.levels]
    for group in design.groups:
        factor = rng.normal(size=(3, 3))
        covariance = factor @ factor.T + np.eye(3)
        correlation = np.round(covariance / np.sqrt(np.outer(np.diag(covariance), np.diag(covariance))), 3)
        np.fill_diagonal(correlation, 1.0)
        lines.append(f"[correlation.{group}]")
        for i, a in enumerate(design.levels):
            lines.append(f"{a} = {{ " + ", ".join(f"{b} = {float(correlation[i, j])!r}" for j, b in enumerate(design.levels))
                         + " }")
    path = tmp_path / "effects.toml"
    path.write_text("\n".join(lines) + "\n")
    export_effects(path, tmp_path)
    subprocess.run(["Rscript", str(R_DIR / "superpower.R"), str(tmp_path / "effects.csv"),
                    str(tmp_path / "covariance.csv"), str(tmp_path), "0"], check=True, capture_output=True,
                   timeout=600)  # fmt: skip
    effects = read_effects(path, design)
    for _ in _exact_matches(effects, pd.read_csv(tmp_path / "exact.csv"), [8, 15]):
        pass
    for _ in _exact_matches(effects, pd.read_csv(tmp_path / "exact_unequal.csv"), [(12, 9), 8]):
        pass
    for (sample, correction), rows in pd.read_csv(tmp_path / "sensitivity.csv").groupby(["n_per_group",
                                                                                         "correction"]):
        ours = sensitivity(design, [(12, 9)] if "=" in sample else int(sample), 0.05, 0.8, effects, correction)
        merged = _merge(ours, rows, ["n_per_group", "term"])
        for column in ("cohen_f", "scale", "epsilon"):
            _close(merged[column], merged[f"{column}_r"], f"{column}, {sample}, {correction}")
