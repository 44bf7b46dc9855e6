"""The questionnaires in the report: scores per administration and interaction model, the paired
comparison by the test that fits the scale, SSQ's post minus pre, Cronbach's alpha with its CI; the
numbers against R (base R's t.test, wilcox.test and the alpha formula with Feldt's interval) and
against the formulas worked by hand; the paper's report unchanged when only its items are answered."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from microg.analysis.questionnaires import (
    PAIRED_T,
    WILCOXON,
    analyse_questionnaires,
    compare_scores,
    internal_consistency,
    score_changes,
)
from microg.analysis.report import write_report
from microg.analysis.scoring import check_answers
from microg.instruments import load_instrument

from .study_data import make_study

INSTRUMENTS = {name: load_instrument(name) for name in ("ssq", "ipq", "sus", "tlx")}
IPQ = [i.id for i in INSTRUMENTS["ipq"].items]
SUS = [i.id for i in INSTRUMENTS["sus"].items]


def vr_answers(participants, seed: int = 5) -> pd.DataFrame:
    """Answers as paper-vr's export holds them: SSQ pre and post (about no interaction model), IPQ after each
    interaction model, SUS at the end about each; a shared leaning per participant makes the items agree."""
    rng = np.random.default_rng(seed)
    rows = []
    for who in participants:
        leaning = rng.normal(0, 1)
        sickness = rng.exponential(0.5)
        for administration, exposure in (("pre", 0.0), ("post", 1.0)):
            for item in range(1, 17):
                value = int(np.clip(np.round(rng.exponential(0.3) + sickness * exposure * rng.uniform(0, 2)), 0, 3))
                rows.append((who, "ssq", administration, "", f"ssq{item:02d}", value))
        for interaction, centre in (("impulse_penetration", 4.2), ("soft_hand", 2.8)):
            for item in IPQ:
                rating = centre + leaning + rng.normal(0, 0.8)
                rating = 6 - rating if INSTRUMENTS["ipq"].item(item).reversed else rating
                rows.append((who, "ipq", "after", interaction, item, int(np.clip(np.round(rating), 0, 6))))
            for item in SUS:
                rating = centre / 1.5 + 0.5 * leaning + rng.normal(0, 0.7)
                rating = 6 - rating if INSTRUMENTS["sus"].item(item).reversed else rating
                rows.append((who, "sus", "end", interaction, item, int(np.clip(np.round(rating), 1, 5))))
    return pd.DataFrame(rows, columns=["participant", "instrument", "administration", "interaction", "item", "value"])


PARTICIPANTS = [f"P{i:02d}" for i in range(1, 17)]


def test_the_test_that_fits_the_scale_is_read():
    found = analyse_questionnaires(vr_answers(PARTICIPANTS), None, "impulse_penetration", "soft_hand")
    ipq = found.rows("comparisons", "ipq").set_index("scale")
    # G1 is a single 7-point item: ordinal, Wilcoxon; the subscale means: paired t unless far from normal
    assert ipq.loc["general", "test"] == WILCOXON and ipq.loc["general", "p"] == ipq.loc["general", "p_wilcoxon"]
    for scale in ("spatial", "involvement", "realism"):
        row = ipq.loc[scale]
        assert row["test"] == (WILCOXON if row["p_shapiro"] < 0.05 else PAIRED_T)
        assert row["p"] == (row["p_wilcoxon"] if row["test"] == WILCOXON else row["p_t"])
        assert row["p_bonf"] == pytest.approx(min(1.0, 4 * row["p"]))  # over IPQ's four scales
        assert row["held"] == "after" and (row["first"], row["second"]) == ("impulse_penetration", "soft_hand")
    assert (ipq["mean_first"] > ipq["mean_second"]).all()
    changes = found.rows("changes", "ssq").set_index("scale")
    assert list(changes.index) == ["nausea", "oculomotor", "disorientation", "total"]
    assert (changes["first"] == "post").all() and (changes["second"] == "pre").all() and (changes["held"] == "").all()
    assert (changes["mean_diff"] > 0).all()  # sickness rises with exposure in these answers
    assert set(found.summary["instrument"]) == {"ssq", "ipq", "sus"}
    # every participant's SUS score at the end, one per interaction model; the paper's items are not here
    assert len(found.rows("scores", "sus")) == 2 * len(PARTICIPANTS)


def test_cronbachs_alpha_and_its_interval_are_the_formulas_worked_out_here():
    answers = check_answers(vr_answers(PARTICIPANTS))
    table = internal_consistency(answers, INSTRUMENTS)
    row = table[(table.instrument == "ipq") & (table.scale == "spatial") & (table.interaction == "soft_hand")].iloc[0]
    spatial = answers[(answers.instrument == "ipq") & (answers.interaction == "soft_hand")
                      & answers["item"].isin(["SP1", "SP2", "SP3", "SP4", "SP5"])]
    wide = spatial.pivot(index="participant", columns="item", values="value").astype(float)
    wide["SP2"] = 6 - wide["SP2"]  # reversed, as the key counts it
    k, n = 5, len(wide)
    # alpha = k / (k - 1) (1 - sum of item variances / variance of the sum)
    alpha = k / (k - 1) * (1 - wide.var(ddof=1).sum() / wide.sum(axis=1).var(ddof=1))
    # Feldt: 1 - (1 - alpha) F(1 - g/2; n - 1, (n - 1)(k - 1)) .. 1 - (1 - alpha) F(g/2; ...)
    low = 1 - (1 - alpha) * stats.f.ppf(0.975, n - 1, (n - 1) * (k - 1))
    high = 1 - (1 - alpha) * stats.f.ppf(0.025, n - 1, (n - 1) * (k - 1))
    assert (row["n"], row["items"]) == (n, k)
    assert row["alpha"] == pytest.approx(alpha, abs=1e-12)
    assert (row["alpha_ci_low"], row["alpha_ci_high"]) == pytest.approx((low, high), abs=1e-3)  # pingouin rounds
    # SSQ's total is scored from all 16 symptoms, each once; TLX's weighted score has no alpha
    assert table[(table.instrument == "ssq") & (table.scale == "total")]["items"].unique().tolist() == [16]


R_SCRIPT = """
d <- read.csv(commandArgs(TRUE)[1])
a <- d[d$which == "a", "score"]; b <- d[d$which == "b", "score"]
t <- t.test(a, b, paired = TRUE)
w <- suppressWarnings(wilcox.test(a, b, paired = TRUE))
items <- read.csv(commandArgs(TRUE)[2])
k <- ncol(items); n <- nrow(items)
alpha <- k / (k - 1) * (1 - sum(apply(items, 2, var)) / var(rowSums(items)))
low <- 1 - (1 - alpha) * qf(0.975, n - 1, (n - 1) * (k - 1))
high <- 1 - (1 - alpha) * qf(0.025, n - 1, (n - 1) * (k - 1))
cat(sprintf("%.15g", c(t$statistic, t$parameter, t$p.value, w$statistic, w$p.value, alpha, low, high)), sep = "\\n")
"""


@pytest.mark.skipif(shutil.which("Rscript") is None, reason="Rscript is not installed")
def test_the_comparisons_and_alpha_equal_rs(tmp_path):
    found = analyse_questionnaires(vr_answers(PARTICIPANTS, seed=9), None, "impulse_penetration", "soft_hand")
    scores = found.rows("scores", "sus")
    wide = scores.pivot(index="participant", columns="interaction", values="score")
    pd.DataFrame({"which": ["a"] * len(wide) + ["b"] * len(wide),
                  "score": [*wide["impulse_penetration"], *wide["soft_hand"]]}).to_csv(tmp_path / "s.csv", index=False)
    answers = check_answers(vr_answers(PARTICIPANTS, seed=9))
    items = answers[(answers.instrument == "sus") & (answers.interaction == "soft_hand")].pivot(
        index="participant", columns="item", values="value").astype(float)
    for item in SUS[1::2]:
        items[item] = 6 - items[item]
    items.to_csv(tmp_path / "items.csv", index=False)
    (tmp_path / "check.R").write_text(R_SCRIPT)
    out = subprocess.run(["Rscript", str(tmp_path / "check.R"), str(tmp_path / "s.csv"), str(tmp_path / "items.csv")],
                         capture_output=True, text=True, timeout=120, check=True).stdout.split()
    T, df, p_t, V, p_w, alpha, low, high = map(float, out)
    row = found.rows("comparisons", "sus").iloc[0]
    assert (row["T"], row["dof"], row["p_t"]) == pytest.approx((T, df, p_t), rel=1e-9)
    assert (row["V"], row["p_wilcoxon"]) == pytest.approx((V, p_w), rel=1e-9)
    consistency = found.rows("consistency", "sus")
    mine = consistency[consistency.interaction == "soft_hand"].iloc[0]
    assert mine["alpha"] == pytest.approx(alpha, rel=1e-9)
    assert (mine["alpha_ci_low"], mine["alpha_ci_high"]) == pytest.approx((low, high), abs=1e-3)


def test_few_pairs_or_one_administration_give_no_comparison():
    scores = pd.DataFrame({"participant": ["a", "b"] * 2, "instrument": "sus", "administration": "end",
                           "interaction": ["s", "s", "b", "b"], "scale": "sus", "score": [50.0, 60.0, 40.0, 55.0]})
    assert compare_scores(scores, INSTRUMENTS, "s", "b").empty  # 2 pairs < 3
    assert score_changes(scores, INSTRUMENTS).empty  # one administration


@pytest.mark.slow
def test_the_report_has_a_section_per_instrument_and_the_papers_report_is_unchanged(tmp_path):
    trials, likert = make_study(3, 8, 8, 0)
    participants = sorted(trials["participant"].unique())
    write_report(trials, likert, tmp_path / "paper")
    paper_only = pd.DataFrame([(who, "paper", "questionnaire", row.interaction, row.item, row.rating)
                               for who in participants for row in likert[likert.participant == who].itertuples()],
                              columns=["participant", "instrument", "administration", "interaction", "item", "value"])
    write_report(trials, likert, tmp_path / "same", answers=paper_only)
    assert (tmp_path / "same" / "report.md").read_text() == (tmp_path / "paper" / "report.md").read_text()
    assert not (tmp_path / "same" / "scores.csv").exists()

    answers = pd.concat([paper_only, vr_answers(participants)], ignore_index=True)
    write_report(trials, likert, tmp_path / "vr", answers=answers)
    markdown = (tmp_path / "vr" / "report.md").read_text()
    for title in ("### Simulator Sickness Questionnaire (SSQ)", "### igroup presence questionnaire (IPQ)",
                  "### System Usability Scale (SUS)"):
        assert title in markdown
    assert "Simulator Sickness Questionnaire (SSQ), post vs pre; p Bonferroni-corrected over 4 scale(s): nausea" \
        in markdown
    assert "System Usability Scale (SUS), impulse_penetration vs soft_hand (end)" in markdown
    assert "Internal consistency of the igroup presence questionnaire (IPQ) (Cronbach's \u03b1 [95 % CI])" in markdown
    assert "Questionnaires: each instrument scored by its published key" in markdown
    tests = pd.read_csv(tmp_path / "vr" / "score_tests.csv")
    assert set(tests.instrument) == {"ssq", "ipq", "sus"}
    for name in ("scores", "score_summary", "consistency"):
        assert (tmp_path / "vr" / f"{name}.csv").exists()
    for name in ("ssq", "ipq", "sus"):
        assert (tmp_path / "vr" / "figures" / f"scores_{name}.png").exists()
    assert "<h2>Questionnaires</h2>" in (tmp_path / "vr" / "report.html").read_text()
