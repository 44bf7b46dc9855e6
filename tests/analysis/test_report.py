"""``microg report`` on a study-shaped export, compared with the whole analysis done in R.

Data: tests/analysis/r/study_trials.csv and study_questionnaire.csv (make_study(seed=11): groups of
7 V and 9 B, training rows, two unfinished tasks, non-spherical times).
R: tests/analysis/r/reference.R "study" mode (afex 1.2-1, emmeans 1.8.4-1, R 4.2.2 stats), output
kept in tests/analysis/r/expected/study/ (regenerate with tests/analysis/r/reproduce.sh).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.analysis import ANOVA_COLUMNS, POSTHOC_COLUMNS, AnalysisInputError, analyse_study, choose_systems
from microg.analysis.report import render_html
from microg.study.cli import main

RTOL = 1e-6
ATOL = 1e-12  # for quantities that are exactly zero in R (an estimate of 0 vs -1.7e-16)
R_DIR = Path(__file__).parent / "r"
TRIALS = R_DIR / "study_trials.csv"
ANSWERS = R_DIR / "study_questionnaire.csv"
EXPECTED = R_DIR / "expected" / "study"
ANOVA_NUMBERS = ["SS", "df1", "df2", "F", "p_unc", "np2", "eps_GG", "p_GG", "W_mauchly", "p_mauchly"]
POSTHOC_NUMBERS = ["estimate", "SE", "df", "T", "p_unc", "p_bonf"]
SYSTEMS_NUMBERS = ["n", "mean_system", "sd_system", "mean_baseline", "sd_baseline", "mean_diff", "T", "dof",
                   "p_t", "cohen_d", "V", "p_wilcoxon", "rbc", "p_shapiro"]  # fmt: skip
OUR_FILES = {  # our file -> R's file
    "anova_time.csv": "anova_time_s_impulse_penetration.csv",
    "anova_attempts.csv": "anova_attempts_impulse_penetration.csv",
    "anova_time_soft_hand.csv": "anova_time_s_soft_hand.csv",
    "anova_attempts_soft_hand.csv": "anova_attempts_soft_hand.csv",
}
POSTHOC_FILES = {ours.replace("anova", "posthoc"): r.replace("anova", "posthoc") for ours, r in OUR_FILES.items()}


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report")
    args = ["report", "--trials", str(TRIALS), "--likert", str(ANSWERS), "--out", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    return out


def assert_same_numbers(ours: pd.DataFrame, theirs: pd.DataFrame, keys: list[str], numbers: list[str]) -> None:
    """Rows matched on ``keys``; equal to RTOL (ATOL near zero); NaN where R has NA."""
    merged = ours.merge(theirs, on=keys, how="outer", suffixes=("", "_r"), indicator=True)
    assert (merged["_merge"] == "both").all(), merged[keys + ["_merge"]]
    for column in numbers:
        np.testing.assert_allclose(merged[column].astype(float), merged[f"{column}_r"].astype(float),
                                   rtol=RTOL, atol=ATOL, err_msg=column)  # fmt: skip


@pytest.mark.parametrize("ours, theirs", OUR_FILES.items())
def test_anova_tables_match_afex(report_dir, ours, theirs):
    table = pd.read_csv(report_dir / ours)
    assert list(table.columns) == list(ANOVA_COLUMNS)
    assert list(table["source"]) == ["group", "object", "group:object"]
    assert_same_numbers(table, pd.read_csv(EXPECTED / theirs), ["source"], ANOVA_NUMBERS)


@pytest.mark.parametrize("ours, theirs", POSTHOC_FILES.items())
def test_posthoc_tables_match_emmeans(report_dir, ours, theirs):
    table = pd.read_csv(report_dir / ours)
    assert list(table.columns) == list(POSTHOC_COLUMNS)
    expected = pd.read_csv(EXPECTED / theirs)
    for frame in (table, expected):
        frame["at"] = frame["at"].fillna("")
    assert_same_numbers(table, expected, ["factor", "at", "A", "B"], POSTHOC_NUMBERS)


def test_systems_table_matches_r(report_dir):
    table = pd.read_csv(report_dir / "systems.csv")
    assert_same_numbers(
        table, pd.read_csv(EXPECTED / "systems.csv"), ["measure", "system", "baseline"], SYSTEMS_NUMBERS
    )


def test_likert_table_matches_r(report_dir):
    table = pd.read_csv(report_dir / "likert.csv")
    numbers = ["n", "median", "q1", "q3", "mean", *[f"count_{score}" for score in range(11)]]
    assert_same_numbers(table, pd.read_csv(EXPECTED / "likert_summary.csv"), ["item", "system"], numbers)
    tests = table.drop_duplicates("item").drop(columns="n").rename(columns={"n_pairs": "n"})
    assert (tests["test_system"] == "impulse_penetration").all() and (tests["test_baseline"] == "soft_hand").all()
    assert_same_numbers(
        tests[["item", "n", "V", "p_unc", "z", "r", "rbc", "p_bonf"]],
        pd.read_csv(EXPECTED / "likert_tests.csv"),
        ["item"],
        ["n", "V", "p_unc", "z", "r", "rbc", "p_bonf"],
    )


def test_report_is_one_self_contained_page_in_reading_order(report_dir):
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    assert not re.search(r"""(src|href)=["'](?!data:)""", html), "the page must not load anything"
    assert html.count("data:image/png;base64,") == 5  # 2 measures x 2 systems + ratings
    order = ["Summary", "Methods", "Mixed ANOVA", "Post hoc", "System vs baseline", "Questionnaire", "Figures"]
    positions = [html.index(f"<h2>{heading}") for heading in order]
    assert positions == sorted(positions)
    assert "CLAP" not in html
    assert "Type 3 sums of squares" in html and "Greenhouse-Geisser" in html and "emmeans" in html
    assert "Simulated data" in html  # the fixture's trials are flagged simulated


def test_report_lists_dropped_participants_and_warnings(report_dir):
    dropped = pd.read_csv(report_dir / "dropped.csv")
    unfinished = pd.read_csv(TRIALS).query("completed == False")
    assert set(dropped["participant"]) == set(unfinished["participant"])
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    for who in unfinished["participant"]:
        assert who in html
    assert "Unbalanced design" in html
    # afex: Mauchly p = 0.00227 for object in the soft_hand time ANOVA
    assert "Sphericity violated for object and group:object in the time_s ANOVA of soft_hand" in html


def test_figures_are_written_as_png_and_svg(report_dir):
    stems = {path.stem for path in (report_dir / "figures").iterdir()}
    for stem in stems:
        assert (report_dir / "figures" / f"{stem}.png").stat().st_size > 1000
        assert (report_dir / "figures" / f"{stem}.svg").read_text().lstrip().startswith("<?xml")
    assert {"ratings", "bars_time_impulse_penetration", "bars_attempts_soft_hand"} <= stems


def test_simulated_ratings_are_announced_in_the_likert_section():
    answers = pd.read_csv(ANSWERS)
    answers.loc[answers.index[:4], "simulated"] = True
    trials = pd.read_csv(TRIALS).assign(simulated=False)
    html = render_html(analyse_study(trials, answers), [], "t")
    likert = html[html.index("Questionnaire (Likert") :]
    assert "Simulated ratings" in likert and "rating model, not people" in likert
    assert "Simulated data:" not in html  # no simulated trials


def test_system_choice():
    assert choose_systems(["soft_hand", "impulse_penetration"], None, None) == ("impulse_penetration", "soft_hand")
    assert choose_systems(["a", "b", "c"], None, None) == ("a", "b")
    assert choose_systems(["a", "b", "c"], "c", None) == ("c", "a")
    assert choose_systems(["penetration_only"], None, None) == ("penetration_only", None)
    with pytest.raises(AnalysisInputError, match=r"column 'system' has no value 'clap'"):
        choose_systems(["a", "b"], None, "clap")


def test_study_directory_is_read_through_the_study_export(tmp_path):
    """``--study`` on an export folder, read by microg.study.export.read_tables."""
    pytest.importorskip("microg.study.export")
    study = tmp_path / "export"
    study.mkdir()
    pd.read_csv(TRIALS).to_csv(study / "trials.csv", index=False)
    pd.read_csv(ANSWERS).to_csv(study / "questionnaire.csv", index=False)
    result = CliRunner().invoke(main, ["report", "--study", str(study), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert_same_numbers(
        pd.read_csv(tmp_path / "out" / "anova_time.csv"),
        pd.read_csv(EXPECTED / OUR_FILES["anova_time.csv"]),
        ["source"],
        ANOVA_NUMBERS,
    )
    assert (tmp_path / "out" / "likert.csv").exists()


def test_withdrawn_participants_are_left_out_and_listed():
    trials, answers = pd.read_csv(TRIALS), pd.read_csv(ANSWERS)
    who = trials["participant"].iloc[0]
    flagged = trials.assign(withdrawn=trials["participant"] == who)
    analysis = analyse_study(flagged, answers)
    without = analyse_study(trials[trials["participant"] != who], answers[answers["participant"] != who])
    key = ("impulse_penetration", "time_s")
    pd.testing.assert_frame_equal(analysis.anova[key], without.anova[key])
    pd.testing.assert_frame_equal(analysis.likert_tests, without.likert_tests)
    listed = analysis.dropped[analysis.dropped["participant"] == who]
    assert listed["reason"].tolist() == ["withdrew from the study"]


def test_far_from_normal_paired_differences_are_warned_about():
    trials = pd.read_csv(TRIALS)
    slow = (trials["participant"] == trials["participant"].iloc[0]) & (trials["system"] == "soft_hand")
    trials.loc[slow, "time_s"] *= 8  # one participant far slower with the baseline
    analysis = analyse_study(trials)
    p_shapiro = analysis.comparison.set_index("measure").loc["time_s", "p_shapiro"]
    assert p_shapiro < 0.05
    assert any("time_s (impulse_penetration - soft_hand) are far from normal" in w for w in analysis.warnings)


def test_a_system_without_a_within_design_is_reported_not_fatal():
    trials = pd.read_csv(TRIALS)
    extra = trials[(trials["system"] == "soft_hand") & (trials["object"] == "cube")].assign(system="penetration_only")
    analysis = analyse_study(pd.concat([trials, extra]))
    assert analysis.systems == ("impulse_penetration", "soft_hand", "penetration_only")
    assert ("penetration_only", "time_s") not in analysis.anova
    assert any(w.startswith("No time_s ANOVA for penetration_only") and "1 level(s) of column 'object'" in w
               for w in analysis.warnings)  # fmt: skip
