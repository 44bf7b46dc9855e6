"""Effects from a pilot: means per cell and the pooled within-group covariance of the participants'
values, computed here with numpy's np.cov per group from the pilot's intended rows."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.power import PowerInputError, pilot_effects, read_effects

CODES = {"C": "cube", "F": "flat_cuboid", "L": "long_cuboid"}


def pilot_trials(seed: int = 2) -> tuple[pd.DataFrame, dict]:
    """An exported trials table: 6 veterans and 7 beginners, one stage1 task per object each, plus
    rows the estimate must ignore (training, stage2, a withdrawn participant) and a participant
    whose cube task was not completed (left out of time, kept for attempts). Returns the table and
    each group's intended (participants x objects) times."""
    rng = np.random.default_rng(seed)
    cov = np.array([[30.0, 12.0, 6.0], [12.0, 50.0, 20.0], [6.0, 20.0, 80.0]])
    rows, intended = [], {"V": [], "B": []}
    number = 0
    for group, size, mean in (("V", 6, [40.0, 50.0, 52.0]), ("B", 7, [48.0, 61.0, 66.0])):
        for _ in range(size):
            number += 1
            person = f"P{number:02d}"
            times = rng.multivariate_normal(mean, cov)
            intended[group].append(times)
            for code, time_s in zip(CODES, times):
                drops = int(rng.integers(0, 5))
                rows.append((person, group, "stage1", "impulse_penetration", code, True, time_s, drops, False))
                rows.append((person, group, "stage2", "soft_hand", code, True, time_s + rng.normal(400, 30), 9, False))
            if group == "V":
                rows.append((person, group, "training", "impulse_penetration", "ball", True, 900.0, 0, False))
    for code in CODES:  # a withdrawn participant: never counted
        rows.append(("P90", "B", "stage1", "impulse_penetration", code, True, 5000.0, 0, True))
    for code, time_s in zip(CODES, (np.nan, 60.0, 70.0)):  # cube not completed: no time
        rows.append(("P91", "V", "stage1", "impulse_penetration", code, code != "C", time_s, 3, False))
    columns = ["participant", "group", "phase", "interaction", "object", "completed", "time_s", "attempts", "withdrawn"]
    return pd.DataFrame(rows, columns=columns), {g: np.array(v) for g, v in intended.items()}


def expected(intended: dict) -> tuple[np.ndarray, np.ndarray]:
    means = np.array([intended["V"].mean(axis=0), intended["B"].mean(axis=0)])
    sizes = [len(intended["V"]), len(intended["B"])]
    pooled = sum((n - 1) * np.cov(intended[g], rowvar=False) for g, n in zip("VB", sizes)) / (sum(sizes) - 2)
    return means, pooled


def test_estimates_from_an_exported_trials_table(tmp_path, design):
    trials, intended = pilot_trials()
    path = tmp_path / "trials.csv"
    trials.to_csv(path, index=False)
    estimate = pilot_effects(path, design)
    means, pooled = expected(intended)
    assert np.allclose(estimate.effects.means, means, atol=1e-9)
    assert np.allclose(estimate.effects.covariances, [pooled, pooled], atol=1e-9)
    assert list(estimate.cells["n"]) == [6, 6, 6, 7, 7, 7]
    assert "pooled within-group covariance" in estimate.method and "completed tasks only" in estimate.method


def test_attempts_count_every_task(tmp_path, design):
    trials, _ = pilot_trials()
    path = tmp_path / "trials.csv"
    trials.to_csv(path, index=False)
    estimate = pilot_effects(path, design, measure="attempts")
    assert list(estimate.cells["n"]) == [7, 7, 7, 7, 7, 7]  # P91 counts: its drops count, finished or not
    counted = trials[(trials["phase"] == "stage1") & ~trials["withdrawn"]]
    means = counted.groupby(["group", "object"])["attempts"].mean()
    assert np.allclose(estimate.effects.means, [[means[g, c] for c in CODES] for g in "VB"], atol=1e-12)


def test_the_interaction_design_reads_each_participants_mean_over_objects(tmp_path):
    from microg.paths import protocol_file
    from microg.power import design_from_protocol
    from microg.study.protocol import load_protocol

    design = design_from_protocol(load_protocol(protocol_file("paper")), within="interaction")
    trials, _ = pilot_trials()
    path = tmp_path / "trials.csv"
    trials.to_csv(path, index=False)
    estimate = pilot_effects(path, design)
    both = trials[trials["phase"].isin(["stage1", "stage2"]) & ~trials["participant"].isin(["P90", "P91"])]
    wide = both.groupby(["group", "participant", "interaction"])["time_s"].mean().unstack("interaction")
    wide = wide[["impulse_penetration", "soft_hand"]]
    groups = {g: wide.loc[g].to_numpy() for g in "VB"}
    pooled = sum((len(v) - 1) * np.cov(v, rowvar=False) for v in groups.values()) / (len(wide) - 2)
    assert np.allclose(estimate.effects.means, [groups["V"].mean(axis=0), groups["B"].mean(axis=0)], atol=1e-9)
    assert np.allclose(estimate.effects.covariances[0], pooled, atol=1e-9)


def test_the_cli_shows_the_estimates_and_writes_an_effects_file_that_reads_back(tmp_path, design):
    trials, intended = pilot_trials(seed=5)
    export = tmp_path / "export"
    export.mkdir()
    trials.to_csv(export / "trials.csv", index=False)
    pd.DataFrame(columns=["participant", "group", "interaction", "item", "rating"]).to_csv(export / "questionnaire.csv",
                                                                                        index=False)  # fmt: skip
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["power", "--pilot", str(export), "--n", "10,20", "--out", str(out)])
    assert result.exit_code == 0, result.output
    means, pooled = expected(intended)
    assert "Estimated from the pilot" in result.output and "pooled correlations" in result.output
    assert f"{means[0, 0]:.4g}" in result.output
    written = read_effects(out / "effects.toml", design)
    assert np.allclose(written.means, means, atol=1e-9)
    assert np.allclose(written.covariances[1], pooled, atol=1e-9)
    power = pd.read_csv(out / "power.csv")
    assert set(power["n_per_group"]) == {10, 20} and (power["method"] == "exact").all()


def test_a_pilot_group_the_protocol_lacks_is_named(tmp_path, design):
    trials, _ = pilot_trials()
    trials.loc[trials["participant"] == "P03", "group"] = "X"
    path = tmp_path / "trials.csv"
    trials.to_csv(path, index=False)
    with pytest.raises(PowerInputError, match=r"trials\.csv: column 'group' value 'X'"):
        pilot_effects(path, design)


def test_too_small_a_pilot_is_refused(tmp_path, design):
    trials, _ = pilot_trials()
    keep = trials["participant"].isin(["P01", "P02", "P07"])
    path = tmp_path / "trials.csv"
    trials[keep].to_csv(path, index=False)
    with pytest.raises(PowerInputError, match="needs at least 5"):
        pilot_effects(path, design)
