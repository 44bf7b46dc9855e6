"""Live comparison with R: a freshly generated study (another seed, other group sizes, more
unfinished tasks) analysed by microg and by tests/analysis/r/reference.R (afex, emmeans, stats).
Skips when Rscript or the R packages afex and emmeans are not installed
(Debian: apt-get install r-base-core r-cran-afex r-cran-emmeans)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from microg.analysis import analyse_study
from microg.analysis.report import likert_table, write_tables
from tests.analysis.study_data import make_study
from tests.analysis.test_report import ANOVA_NUMBERS, POSTHOC_NUMBERS, SYSTEMS_NUMBERS, assert_same_numbers

REFERENCE = Path(__file__).parent / "r" / "reference.R"
SYSTEMS = ("impulse_penetration", "soft_hand")


def _r_ready() -> bool:
    if shutil.which("Rscript") is None:
        return False
    probe = subprocess.run(
        ["Rscript", "-e", "suppressMessages({library(afex); library(emmeans)})"],
        capture_output=True,
        timeout=120,
        check=False,
    )
    return probe.returncode == 0


pytestmark = pytest.mark.skipif(not _r_ready(), reason="Rscript with afex and emmeans is not installed")


@pytest.mark.parametrize("seed, n_veteran, n_beginner, unfinished", [(2024, 8, 11, 3), (31, 6, 6, 0)])
def test_whole_analysis_matches_r(tmp_path, seed, n_veteran, n_beginner, unfinished):
    trials, answers = make_study(seed, n_veteran, n_beginner, unfinished)
    trials.to_csv(tmp_path / "trials.csv", index=False)
    answers.to_csv(tmp_path / "answers.csv", index=False)
    r_out = tmp_path / "r"
    r_out.mkdir()
    command = ["Rscript", str(REFERENCE), "study", str(tmp_path / "trials.csv"), str(tmp_path / "answers.csv"),
               *SYSTEMS, str(r_out)]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True, timeout=120)

    analysis = analyse_study(tmp_path / "trials.csv", tmp_path / "answers.csv")
    ours = tmp_path / "ours"
    ours.mkdir()
    write_tables(analysis, ours)

    for name in SYSTEMS:
        suffix = "" if name == SYSTEMS[0] else f"_{name}"
        for dv, short in (("time_s", "time"), ("attempts", "attempts")):
            assert_same_numbers(
                pd.read_csv(ours / f"anova_{short}{suffix}.csv"),
                pd.read_csv(r_out / f"anova_{dv}_{name}.csv"),
                ["source"],
                ANOVA_NUMBERS,
            )
            mine = pd.read_csv(ours / f"posthoc_{short}{suffix}.csv")
            theirs = pd.read_csv(r_out / f"posthoc_{dv}_{name}.csv")
            for frame in (mine, theirs):
                frame["at"] = frame["at"].fillna("")
            assert_same_numbers(mine, theirs, ["factor", "at", "A", "B"], POSTHOC_NUMBERS)
    assert_same_numbers(
        pd.read_csv(ours / "systems.csv"),
        pd.read_csv(r_out / "systems.csv"),
        ["measure", "system", "baseline"],
        SYSTEMS_NUMBERS,
    )
    likert = likert_table(analysis)
    counts = [f"count_{score}" for score in range(11)]
    assert_same_numbers(likert, pd.read_csv(r_out / "likert_summary.csv"), ["item", "system"],
                        ["n", "median", "q1", "q3", "mean", *counts])  # fmt: skip
    tests = analysis.likert_tests
    assert_same_numbers(tests, pd.read_csv(r_out / "likert_tests.csv"), ["item"],
                        ["n", "V", "p_unc", "z", "r", "rbc", "p_bonf"])  # fmt: skip
