"""``microg report`` on a study-shaped export, compared with the whole analysis done in R, and what a
reader of the report sees: the Results paragraphs, the effective N, labels, journal-formatted
numbers, the Markdown export, and a layout that shows every column at 1200 px.

Data: tests/analysis/r/study_trials.csv and study_questionnaire.csv (make_study(seed=11): groups of
7 V and 9 B, training rows, two unfinished tasks, non-spherical times).
R: tests/analysis/r/reference.R "study" mode (afex 1.2-1, emmeans 1.8.4-1, car 3.1-1, rstatix 0.7.2,
effectsize 0.8.3, geepack 1.3.9, R 4.2.2 stats), output kept in tests/analysis/r/expected/study/
(regenerate with tests/analysis/r/reproduce.sh).
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.analysis import (
    ANOVA_COLUMNS,
    POSTHOC_COLUMNS,
    AnalysisInputError,
    analyse_study,
    choose_interactions,
)
from microg.analysis.report import render_html, write_report
from microg.cli import main
from tests.analysis.r_compare import (
    ANSWERS_CSV,
    STUDY,
    TRIALS_CSV,
    assert_study_matches,
)
from tests.analysis.study_data import make_study
from tests.view.browser import MISSING, chromium


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report")
    args = ["report", "--trials", str(TRIALS_CSV), "--likert", str(ANSWERS_CSV), "--out", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def dropped_report(tmp_path_factory) -> Path:
    """A study of 12 V and 12 B where two V and one B participants miss a cell of each measure."""
    trials, answers = make_study(seed=7, n_veteran=12, n_beginner=12, unfinished=0)
    missing = trials[(trials["phase"] == "stage1") & (trials["object"] == "cube")].drop_duplicates("participant")
    who = [*missing[missing["group"] == "V"]["participant"][:2], *missing[missing["group"] == "B"]["participant"][:1]]
    holes = trials["participant"].isin(who) & (trials["phase"] == "stage1") & (trials["object"] == "cube")
    out = tmp_path_factory.mktemp("dropped")
    write_report(trials[~holes], answers, out)
    return out


def test_every_table_matches_r(report_dir):
    """ANOVA (with ges, Huynh-Feldt, CI of partial eta squared), post hoc with CIs, simple effects and
    their pairs, assumption checks, cell means, count models, interaction vs baseline with CIs, Likert."""
    assert_study_matches(report_dir, STUDY)


@pytest.mark.parametrize("name", ["anova_time.csv", "anova_attempts_soft_hand.csv"])
def test_the_existing_columns_stay_first(report_dir, name):
    table = pd.read_csv(report_dir / name)
    assert list(table.columns) == list(ANOVA_COLUMNS)
    assert list(table["source"]) == ["group", "object", "group:object"]
    posthoc = pd.read_csv(report_dir / name.replace("anova", "posthoc"))
    assert list(posthoc.columns) == list(POSTHOC_COLUMNS)
    assert list(ANOVA_COLUMNS[:14]) == ["source", "SS", "df1", "df2", "MS", "F", "p_unc", "np2", "eps_GG", "df1_GG",
                                        "df2_GG", "p_GG", "W_mauchly", "p_mauchly"]  # fmt: skip
    assert list(POSTHOC_COLUMNS[:11]) == ["factor", "at", "A", "B", "estimate", "SE", "df", "T", "p_unc", "p_bonf",
                                          "stars"]  # fmt: skip


def test_report_is_one_self_contained_page_in_reading_order(report_dir):
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    assert not re.search(r"""(src|href)=["'](?!data:)""", html), "the page must not load anything"
    assert html.count("data:image/png;base64,") == 5  # 2 measures x 2 interactions + ratings
    order = ["Summary", "Results", "Methods", "Mixed ANOVA", "Interaction model vs baseline", "Questionnaire",
             "Figures"]
    positions = [html.index(f"<h2>{heading}") for heading in order]
    assert positions == sorted(positions)
    assert "CLAP" not in html
    assert "Type 3 sums of squares" in html and "Greenhouse-Geisser" in html and "emmeans" in html
    assert "Simulated data" in html  # the fixture's trials are flagged simulated


def test_results_are_written_as_a_journal_prints_them(report_dir):
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    results = html[html.index("<h2>Results") : html.index("<h2>Methods")]
    # afex: soft_hand time, object F = 43.77, GG epsilon .611 (Mauchly p = .002): corrected df
    assert re.search(
        r"main effect of object, F\(1\.22, 15\.88\) = 43\.77, p &lt; \.001, ηp² = \.77, "
        r"95 % CI \[\.\d\d, \.\d\d\], ηG² = \.\d\d \(Greenhouse-Geisser corrected, ε = \.61\)",
        results,
    )
    assert re.search(
        r"cube − flat_cuboid = -\d+\.\d\d, 95 % CI \[-\d+\.\d\d, -?\d+\.\d\d\], p (=|&lt;) \.\d{3}", results
    )
    assert "Levene" in results and "Box&#39;s M" in results and "Shapiro-Wilk" in results
    assert "In addition to the paper&#39;s analysis" in results and "Poisson GEE" in results
    tables = re.sub(r"base64,[^\"]+", "", html[html.index("<h2>Mixed ANOVA") :])
    for raw in ("np2", "p_unc", "eps_GG", "p_bonf", "W_mauchly", "e-0", "e+0", "nan"):
        assert raw not in tables, raw
    assert "<th>ηp²</th>" in tables and "<th>ε (GG)</th>" in tables and "&lt; .001" in tables
    assert not re.search(r"<td>-?0\.\d+e", tables) and not re.search(r"-0\.0+(?!\d)", tables)


def test_markdown_holds_the_results_and_tables(report_dir):
    markdown = (report_dir / "report.md").read_text(encoding="utf-8")
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    paragraph = re.search(r"Completion time \(s\) with soft_hand: N = 15 \(B: 8, V: 7\).*", markdown).group(0)
    assert paragraph.replace("'", "&#39;").replace("<", "&lt;") in html
    assert "| Effect         | SS" in markdown and "| group × object |" in markdown
    assert "### Interaction model vs baseline (Table 1)" in markdown and "| Interaction model" in markdown


def test_report_lists_dropped_participants_and_warnings(report_dir):
    dropped = pd.read_csv(report_dir / "dropped.csv")
    unfinished = pd.read_csv(TRIALS_CSV).query("completed == False")
    assert set(dropped["participant"]) == set(unfinished["participant"])
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    for who in unfinished["participant"]:
        assert who in html
    assert "Unbalanced design" in html
    # afex: Mauchly p = 0.00227 for object in the soft_hand time ANOVA
    assert "Sphericity violated for object and group:object in the time_s ANOVA of soft_hand" in html


def test_every_n_is_the_n_analysed(dropped_report):
    """24 participants in the data; those of the interaction under test analyse 21 (V: 10, B: 11), the
    baseline's all 24: every N the report states is the N of its analysis, beside who was excluded
    and why, and the data's 24 appears only where it is labelled as such."""
    sample = pd.read_csv(dropped_report / "sample.csv", keep_default_na=False)
    assert sample.query("analysis == 'data'")["n"].sum() == 24
    analysed = sample[sample["analysis"].isin(["ANOVA", "pairs"]) & (sample["interaction"] == "impulse_penetration")]
    assert (analysed.groupby(["analysis", "measure"])["n"].sum() == 21).all()
    html = (dropped_report / "report.html").read_text(encoding="utf-8")
    markdown = (dropped_report / "report.md").read_text(encoding="utf-8")
    for text in (html, markdown):
        paragraphs = re.findall(r"(?:Completion time \(s\)|Attempts \(drops\))[^.]*?: (N = .*?)[;.] ", text)
        under_test = [p for p in re.findall(r"with impulse_penetration: (N = [^;.]*)", text)]
        baseline = re.findall(r"with soft_hand: (N = [^;.]*)", text)
        pairs = re.findall(r"vs soft_hand: (N = [^;.]*) pairs", text)
        assert len(paragraphs) == 6 and len(under_test) == 2 and len(baseline) == 2 and len(pairs) == 2
        assert set(under_test) | set(pairs) == {"N = 21 (B: 11, V: 10)"}
        assert set(baseline) == {"N = 24 (B: 12, V: 12)"}
        assert text.count("3 excluded") == 4 and "no time_s for object cube" in text
        assert re.search(r"in the data\s*(</td>\s*<td>|\|\s*)24 \(B: 12, V: 12\)", text)
    table1 = html[html.index("<h2>Interaction model vs baseline") : html.index("<h2>Questionnaire")]
    assert table1.count("<td>21</td>") == 2 * 2 + 2  # Table 1 (n per measure, both rows) and the t-tests
    legends = (dropped_report / "figures" / "bars_time_impulse_penetration.svg").read_text()
    assert "n = 10" in legends and "n = 11" in legends


def test_labels_replace_codes_wherever_a_reader_sees_a_condition(tmp_path):
    trials, answers = pd.read_csv(TRIALS_CSV), pd.read_csv(ANSWERS_CSV)
    labels = {"impulse_penetration": "System 1", "soft_hand": "System 2"}
    out = write_report(trials.assign(interaction_label=trials["interaction"].map(labels)),
                       answers.assign(interaction_label=answers["interaction"].map(labels)), tmp_path)  # fmt: skip
    html = out.read_text(encoding="utf-8")
    reader = re.sub(r"figures/\S+", "", html[html.index("<h2>Results") :])  # file names keep the codes
    assert "impulse_penetration" not in reader and "soft_hand" not in reader
    assert "Completion time (s) with System 1: N = 15" in reader and "System 1 vs System 2" in reader
    summary = html[: html.index("<h2>Results")]
    assert "System 1 (interaction model under test): impulse_penetration" in summary
    assert set(pd.read_csv(tmp_path / "interactions.csv")["interaction"]) == {"impulse_penetration"}
    assert pd.read_csv(tmp_path / "conditions.csv").set_index("interaction")["label"].to_dict() == labels
    assert "System 1" in (tmp_path / "report.md").read_text(encoding="utf-8")


def test_a_measure_without_variation_is_reported_not_a_traceback(tmp_path):
    """Nobody dropped anything with the interaction under test: F = 0 and p = 1 in the tables, and the
    Results say there is nothing to test; the count model says it has nothing to model."""
    trials = pd.read_csv(TRIALS_CSV)
    trials.loc[trials["interaction"] == "impulse_penetration", "attempts"] = 0
    trials.to_csv(tmp_path / "trials.csv", index=False)
    result = CliRunner().invoke(
        main, ["report", "--trials", str(tmp_path / "trials.csv"), "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 0, result.output
    anova = pd.read_csv(tmp_path / "r" / "anova_attempts.csv")
    assert (anova["F"] == 0).all() and (anova["p_unc"] == 1).all()
    html = (tmp_path / "r" / "report.html").read_text(encoding="utf-8")
    assert "the measure does not vary, so there is nothing to test" in html
    assert "no events: every attempts is 0, nothing to model" in html


def test_figures_are_written_as_png_and_svg_with_every_participant(report_dir):
    stems = {path.stem for path in (report_dir / "figures").iterdir()}
    for stem in stems:
        assert (report_dir / "figures" / f"{stem}.png").stat().st_size > 1000
        assert (report_dir / "figures" / f"{stem}.svg").read_text().lstrip().startswith("<?xml")
    assert {"ratings", "bars_time_impulse_penetration", "bars_attempts_soft_hand"} <= stems
    svg = (report_dir / "figures" / "bars_attempts_impulse_penetration.svg").read_text()
    assert svg.count('id="PathCollection_') == 6  # a cloud of points per group and object


def test_simulated_ratings_are_announced_in_the_likert_section():
    answers = pd.read_csv(ANSWERS_CSV)
    answers.loc[answers.index[:4], "simulated"] = True
    trials = pd.read_csv(TRIALS_CSV).assign(simulated=False)
    html = render_html(analyse_study(trials, answers), [], "t")
    likert = html[html.index("<h2>Questionnaire (Likert") :]
    assert "Simulated ratings" in likert and "rating model, not people" in likert
    assert "Simulated data:" not in html  # no simulated trials


def test_interaction_choice():
    assert choose_interactions(["soft_hand", "impulse_penetration"], None, None) == ("impulse_penetration", "soft_hand")
    assert choose_interactions(["a", "b", "c"], None, None) == ("a", "b")
    assert choose_interactions(["a", "b", "c"], "c", None) == ("c", "a")
    assert choose_interactions(["penetration_only"], None, None) == ("penetration_only", None)
    with pytest.raises(AnalysisInputError, match=r"column 'interaction' has no value 'clap'"):
        choose_interactions(["a", "b"], None, "clap")


def test_withdrawn_participants_are_left_out_and_listed():
    trials, answers = pd.read_csv(TRIALS_CSV), pd.read_csv(ANSWERS_CSV)
    who = trials["participant"].iloc[0]
    flagged = trials.assign(withdrawn=trials["participant"] == who)
    analysis = analyse_study(flagged, answers)
    without = analyse_study(trials[trials["participant"] != who], answers[answers["participant"] != who])
    pd.testing.assert_frame_equal(analysis.anova, without.anova)
    pd.testing.assert_frame_equal(analysis.likert_tests, without.likert_tests)
    listed = analysis.dropped[analysis.dropped["participant"] == who]
    assert listed["reason"].tolist() == ["withdrew from the study"]


def test_far_from_normal_paired_differences_are_warned_about():
    trials = pd.read_csv(TRIALS_CSV)
    slow = (trials["participant"] == trials["participant"].iloc[0]) & (trials["interaction"] == "soft_hand")
    trials.loc[slow, "time_s"] *= 8  # one participant far slower with the baseline
    analysis = analyse_study(trials)
    p_shapiro = analysis.comparison.set_index("measure").loc["time_s", "p_shapiro"]
    assert p_shapiro < 0.05
    assert any("time_s (impulse_penetration - soft_hand) are far from normal" in w for w in analysis.warnings)


def test_an_interaction_without_a_within_design_is_reported_not_fatal():
    trials = pd.read_csv(TRIALS_CSV)
    extra = trials[(trials["interaction"] == "soft_hand") & (trials["object"] == "cube")]
    extra = extra.assign(interaction="penetration_only")
    analysis = analyse_study(pd.concat([trials, extra]))
    assert analysis.interactions == ("impulse_penetration", "soft_hand", "penetration_only")
    assert ("penetration_only", "time_s") not in analysis.analysed()
    assert any(w.startswith("No time_s ANOVA for penetration_only") and "1 level(s) of column 'object'" in w
               for w in analysis.warnings)  # fmt: skip


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium chromium-driver)")
def test_every_table_shows_all_its_columns_at_1200_px(report_dir):
    with chromium((1200, 900)) as driver:
        driver.get((report_dir / "report.html").as_uri())
        widths = driver.execute_script(
            "return Array.from(document.querySelectorAll('table')).map(t => "
            "[t.innerText.split('\\n')[0], t.getBoundingClientRect().right, t.parentElement.getBoundingClientRect().right,"
            " t.scrollWidth, t.clientWidth]);"
        )
    assert len(widths) > 20
    for header, right, container, scroll, client in widths:
        assert right <= container + 0.5 and scroll <= client, header


def test_the_trial_model_takes_its_practice_column_or_goes_without():
    trials = pd.read_csv(TRIALS_CSV)
    named = analyse_study(trials.rename(columns={"task_index": "place"}), None, practice="place")
    assert named.trial_models["formula"].iloc[0].startswith("log(time_s) ~ group * object * interaction + place")
    without = analyse_study(trials.drop(columns="task_index"), None)
    formula = without.trial_models["formula"].iloc[0]
    assert formula == "log(time_s) ~ group * object * interaction + (1 | participant)"
    assert without.practice is None and list(without.trial_models["measure"]) == ["time_s"]


def test_the_questionnaire_art_reads_groups_from_the_trials_when_it_has_none():
    answers = pd.read_csv(ANSWERS_CSV)
    with_groups = analyse_study(TRIALS_CSV, answers).likert_art
    without = analyse_study(TRIALS_CSV, answers.drop(columns="group")).likert_art
    pd.testing.assert_frame_equal(with_groups, without)
    assert set(with_groups["item"]) == {"efficiency", "naturalness"} and len(with_groups) == 6
