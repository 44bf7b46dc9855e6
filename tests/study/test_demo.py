"""The main job end to end, reduced: a simulated study from protocol to report, checked against its store."""

from __future__ import annotations

import sqlite3

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study.protocol import load_protocol

from .conftest import PROTOCOLS

pytestmark = pytest.mark.slow

REPORT_TABLES = ("anova_time.csv", "anova_attempts.csv", "posthoc_time.csv", "posthoc_attempts.csv", "interactions.csv",
                 "likert.csv")


def run_demo(out, jobs):
    result = CliRunner().invoke(main, ["demo", "--out", str(out), "--participants", "6", "--seed", "5", "--jobs",
                                       str(jobs), "--protocol", str(PROTOCOLS / "demo-quick.toml"), "--quiet"])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    output = run_demo(out / "a", jobs=2)
    return out, output


def test_the_demo_ends_by_saying_where_the_report_is(demo):
    out, output = demo
    assert f"report: {out / 'a' / 'report' / 'report.html'}" in output
    assert (out / "a" / "study" / "study.db").exists()


def test_every_report_table_and_section_is_there(demo):
    out, _ = demo
    report = out / "a" / "report"
    for name in REPORT_TABLES:
        assert (report / name).exists(), name
    html = (report / "report.html").read_text()
    for heading in ("Mixed ANOVA", "Post hoc", "Likert", "simulated"):
        assert heading.lower() in html.lower(), heading
    assert "CLAP" not in html
    assert html.count("data:image/png;base64") >= 3  # bar plots of time and attempts, rating distribution


def test_tables_agree_with_the_store(demo):
    out, _ = demo
    db = sqlite3.connect(out / "a" / "study" / "study.db")
    runs = pd.read_sql("""SELECT r.session_id, r.task_index, r.status, r.time_s, r.attempts, t.interaction, t.phase,
                                 t.object_code AS object, s.participant_id AS participant
                          FROM task_runs r JOIN tasks t ON t.session_id = r.session_id AND t.task_index = r.task_index
                          JOIN sessions s ON s.id = r.session_id""", db)
    trials = pd.read_csv(out / "a" / "tables" / "trials.csv")
    assert len(trials) == len(runs) and set(trials.participant) == set(runs.participant)
    # Table 1 recomputed from the store: each participant's mean over the three objects (those with
    # all three in both interactions: completed tasks for time, every task with a count for attempts),
    # then the mean over participants
    tested = runs[runs.phase != "training"]
    usable = {"time_s": tested[tested.status == "completed"], "attempts": tested[tested.attempts.notna()]}
    table = pd.read_csv(out / "a" / "report" / "interactions.csv").set_index("measure")
    assert "attempts" in table.index
    for measure, row in table.iterrows():
        rows = usable[measure]
        complete = (rows.groupby(["participant", "interaction"]).object.nunique().unstack() == 3).all(axis=1)
        paired = rows[rows.participant.isin(complete[complete].index)]
        means = paired.groupby(["interaction", "participant"])[measure].mean().groupby("interaction").mean()
        assert (row["interaction"], row["baseline"], row["n"]) == ("impulse_penetration", "soft_hand", complete.sum())
        assert row["mean_interaction"] == pytest.approx(means["impulse_penetration"], rel=1e-9, abs=1e-12)
        assert row["mean_baseline"] == pytest.approx(means["soft_hand"], rel=1e-9, abs=1e-12)
    answers = pd.read_sql("SELECT * FROM answers", db)
    questionnaire = pd.read_csv(out / "a" / "tables" / "questionnaire.csv")
    assert len(questionnaire) == len(answers) == 6 * 2 * 2 and (questionnaire.source == "model").all()
    assert questionnaire.simulated.all() and trials.simulated.all()


def test_same_seed_same_tables_whatever_the_number_of_workers(demo):
    out, _ = demo
    run_demo(out / "b", jobs=1)
    for name in ("trials.csv", "questionnaire.csv"):
        a, b = pd.read_csv(out / "a" / "tables" / name), pd.read_csv(out / "b" / "tables" / name)
        pd.testing.assert_frame_equal(a, b)


def test_a_demo_with_a_profile_draws_every_participant_from_it(tmp_path):
    """``--profile`` replaces each group's own population (this protocol's: ``literature``) for every
    participant: each session's input names the file and each task's skill is drawn from it."""
    from microg.paths import PROTOCOLS as SHIPPED

    profile = SHIPPED / "populations" / "default.toml"
    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path / "d"), "--participants", "2", "--seed", "3",
                                       "--jobs", "1", "--protocol", str(PROTOCOLS / "demo-quick.toml"),
                                       "--profile", str(profile), "--quiet"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "d" / "report" / "report.html").exists()
    db = sqlite3.connect(tmp_path / "d" / "study" / "study.db")
    sessions = pd.read_sql("SELECT input FROM sessions", db)
    runs = pd.read_sql("SELECT source FROM task_runs", db)
    assert len(sessions) == 2 and (sessions.input == f"simulated:{profile.resolve()}").all()
    assert len(runs) > 0 and runs.source.str.startswith("simulated:default:").all(), runs.source.tolist()


def test_an_existing_demo_is_not_overwritten_unless_asked(demo):
    out, _ = demo
    result = CliRunner().invoke(main, ["demo", "--out", str(out / "a"), "--participants", "2", "--quiet"])
    assert result.exit_code == 1 and "exists and is not empty" in result.output


def test_a_study_of_task_kinds_runs_to_a_report_of_each_kinds_measures(tmp_path):
    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path), "--participants", "2", "--seed", "1", "--jobs",
                                       "1", "--protocol", str(PROTOCOLS / "kinds-simulated.toml"), "--quiet"])
    assert result.exit_code == 0, result.output
    report = tmp_path / "report"
    markdown = (report / "report.md").read_text()
    for text in ("### Catch", "### Stop of a spin", "time to catch (s)", "time to rest (s)",
                 "flipped (proportion of tasks)", "The study asks no questionnaire"):
        assert text in markdown, text
    trials = pd.read_csv(tmp_path / "tables" / "trials.csv")
    for kind, measures in (("catch", {"time_s", "attempts", "time_to_catch_s"}),
                           ("stop_spin", {"time_s", "attempts", "time_to_rest_s", "flipped"})):
        described = pd.read_csv(report / kind / "description.csv")
        tasks = trials[trials["task_kind"] == kind]
        assert set(described["measure"]) == {m for m in measures if tasks[m].notna().any()}
        flips = described[described["measure"] == "flipped"]["mean"]
        assert flips.between(0, 1).all()


def test_a_simulated_skills_study_trains_a_catch_then_stops_a_spin_sends_and_hands_over_to_a_report(tmp_path):
    """The microgravity-skills protocol (the cube only, a short timeout) end to end: the veterans'
    training catch, then everyone's stop of a spin, send and handover (with both hands) with one
    interaction model, logged, exported and reported per kind, and that interaction model rated once
    by each participant."""
    protocol = PROTOCOLS / "skills-quick.toml"
    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path), "--participants", "2", "--seed", "1", "--jobs",
                                       "1", "--protocol", str(protocol), "--quiet"])
    assert result.exit_code == 0, result.output
    trials = pd.read_csv(tmp_path / "tables" / "trials.csv")
    played = set(trials[["group", "phase", "task_kind"]].itertuples(index=False, name=None))
    assert played == {("V", "training", "catch"), ("V", "stopping", "stop_spin"), ("B", "stopping", "stop_spin"),
                      ("V", "sending", "send"), ("B", "sending", "send"), ("V", "passing", "handover"),
                      ("B", "passing", "handover")}
    arrived = trials[(trials["task_kind"] == "send") & (trials["status"] == "completed")]
    radius = load_protocol(protocol).task.send.radius
    assert len(arrived) and (arrived["send_error_m"] < radius).all()  # an arrival's line passes through the zone
    markdown = (tmp_path / "report" / "report.md").read_text()
    handovers = trials.loc[trials["task_kind"] == "handover", "transfer_time_s"]  # (the 30 s may end one before
    assert (handovers.dropna() > 0).any()                                        # the place: a handover happened)
    for text in ("### Stop of a spin", "### Send", "### Handover", "send error (m)", "release speed error (m/s)",
                 "time to rest (s)", "transfer time (s)"):
        assert text in markdown, text
    for kind in ("stop_spin", "send", "handover"):
        assert (tmp_path / "report" / kind / "description.csv").exists()
    answers = pd.read_csv(tmp_path / "tables" / "answers.csv")
    assert set(answers["interaction"]) == {"impulse_penetration"}
    assert (answers.groupby(["participant", "item"]).size() == 1).all() and answers["participant"].nunique() == 2
