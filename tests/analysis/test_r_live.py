"""Live comparison with R: freshly generated studies (other seeds, other group sizes, more unfinished
tasks; training programs of other seeds and sizes) analysed by microg and by tests/analysis/r/reference.R
(afex, emmeans, car, rstatix, effectsize, geepack, stats, lme4/lmerTest, ARTool, survival). Skips when
Rscript or those R packages are not installed (scripts/install-system-deps.sh installs them: Debian's,
and ARTool from ../shared)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from microg.analysis.report import write_report
from tests.analysis.r_compare import INTERACTIONS, assert_study_matches, assert_training_matches
from tests.analysis.study_data import make_study
from tests.analysis.training_data import make_training

REFERENCE = Path(__file__).parent / "r" / "reference.R"
R_PACKAGES = ("afex", "emmeans", "car", "rstatix", "effectsize", "geepack", "lmerTest", "ARTool", "survival")


def _r_ready() -> bool:
    if shutil.which("Rscript") is None:
        return False
    load = "; ".join(f"library({name})" for name in R_PACKAGES)
    probe = subprocess.run(["Rscript", "-e", f"suppressMessages({{{load}}})"], capture_output=True, timeout=120,
                           check=False)  # fmt: skip
    return probe.returncode == 0


pytestmark = pytest.mark.skipif(not _r_ready(), reason=f"Rscript with {', '.join(R_PACKAGES)} is not installed")


@pytest.mark.parametrize("seed, n_veteran, n_beginner, unfinished", [(2024, 8, 11, 3), (31, 6, 6, 0)])
def test_whole_analysis_matches_r(tmp_path, seed, n_veteran, n_beginner, unfinished):
    trials, answers = make_study(seed, n_veteran, n_beginner, unfinished)
    trials.to_csv(tmp_path / "trials.csv", index=False)
    answers.to_csv(tmp_path / "answers.csv", index=False)
    r_out = tmp_path / "r"
    r_out.mkdir()
    command = ["Rscript", str(REFERENCE), "study", str(tmp_path / "trials.csv"), str(tmp_path / "answers.csv"),
               *INTERACTIONS, str(r_out)]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True, timeout=300)
    write_report(tmp_path / "trials.csv", tmp_path / "answers.csv", tmp_path / "ours")
    assert_study_matches(tmp_path / "ours", r_out)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("seed, n_per_group", [(7, 8), (11, 6)])
def test_training_section_matches_r(tmp_path, seed, n_per_group):
    make_training(seed, n_per_group).to_csv(tmp_path / "trials.csv", index=False)
    r_out = tmp_path / "r"
    r_out.mkdir()
    subprocess.run(["Rscript", str(REFERENCE), "training", str(tmp_path / "trials.csv"), str(r_out)], check=True,
                   capture_output=True, timeout=300)  # fmt: skip
    write_report(tmp_path / "trials.csv", None, tmp_path / "ours")
    assert_training_matches(tmp_path / "ours" / "training", r_out)
