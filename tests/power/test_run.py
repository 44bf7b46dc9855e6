"""A Monte Carlo run on a local Dask cluster: results written as they arrive, an interrupted run
resumed to the same numbers, a folder never mixed with another run."""

from __future__ import annotations

import pandas as pd
from click.testing import CliRunner

from microg.cli import main
from microg.power import montecarlo_batch, power_table, read_effects

ARGS = ["--method", "montecarlo", "--sims", "300", "--n", "4,6", "--batch", "50", "--seed", "9", "--workers", "1"]


def reference(effects_file, design) -> pd.DataFrame:
    """The same data sets analysed in this process, without Dask, in one batch per n."""
    effects = read_effects(effects_file, design)
    rows = pd.concat([montecarlo_batch(effects, n, range(300), seed=9, alpha=0.05) for n in (4, 6)])
    return power_table(rows, 0.05, "montecarlo")


def same_power(table: pd.DataFrame, expected: pd.DataFrame) -> None:
    key = ["n_per_group", "term"]
    merged = table.merge(expected, on=key, suffixes=("", "_expected"), validate="one_to_one")
    assert len(merged) == len(expected) == len(table)
    for column in ("power", "ci_low", "ci_high"):
        assert (merged[column] == merged[f"{column}_expected"]).all(), column


def test_an_interrupted_run_resumes_to_the_same_numbers(effects_file, design, tmp_path):
    out = tmp_path / "run"
    runner = CliRunner()
    first = runner.invoke(main, ["power", "--effects", str(effects_file), *ARGS, "--out", str(out)])
    assert first.exit_code == 0, first.output
    expected = reference(effects_file, design)
    same_power(pd.read_csv(out / "power.csv"), expected)

    # as if killed mid-run: two and a half batches of the 12 lost, the last line cut in half, no outputs yet
    results = out / "simulations.csv"
    lines = results.read_text().splitlines(keepends=True)
    kept = len(lines) - int(2.5 * 50 * len(design.tests))
    results.write_text("".join(lines[:kept]) + lines[kept][: len(lines[kept]) // 2])
    for name in ("power.csv", "summary.json", "power-curve.png"):
        (out / name).unlink()

    again = runner.invoke(main, ["power", "--effects", str(effects_file), *ARGS, "--out", str(out), "--resume"])
    assert again.exit_code == 0, again.output
    same_power(pd.read_csv(out / "power.csv"), expected)
    rows = pd.read_csv(results)
    assert len(rows) == 2 * 300 * len(design.tests)
    assert not rows.duplicated(["n_per_group", "sim", "term"]).any()


def test_a_folder_holds_one_run(effects_file, tmp_path):
    out = tmp_path / "run"
    runner = CliRunner()
    assert runner.invoke(main, ["power", "--effects", str(effects_file), "--out", str(out)]).exit_code == 0
    again = runner.invoke(main, ["power", "--effects", str(effects_file), "--out", str(out)])
    assert again.exit_code == 1 and "holds a power run already" in again.output and "--resume" in again.output
    other = runner.invoke(main, ["power", "--effects", str(effects_file), "--alpha", "0.01", "--out", str(out),
                                 "--resume"])  # fmt: skip
    assert other.exit_code == 1 and "alpha = 0.05" in other.output and "0.01" in other.output
