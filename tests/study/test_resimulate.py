"""Counterfactual replay: a logged session's hand motion through the physics again, kept apart."""

from __future__ import annotations

from click.testing import CliRunner

from microg.analysis.compare import compare_run_sets, write_comparison
from microg.cli import main
from microg.study.export import read_tables
from microg.study.store import open_study

from .conftest import PROTOCOLS

COLUMNS = ["participant", "phase", "interaction", "object", "status", "completed", "time_s", "attempts"]


def run(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


def test_the_same_model_reproduces_the_trials_and_another_gives_a_separate_marked_run_set(tmp_path):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "tiny.toml", "--seed", "5")
    run("participant", "add", study, "--id", "P01", "--gender", "male", "--age", "22", "--handedness", "right",
        "--mr-experience", "no")
    run("session", "run", study, "--participant", "P01", "--input", "simulated:veteran", "--questionnaire", "skip",
        "--quiet")
    original = read_tables(study)[0][COLUMNS]
    assert original.completed.any()

    run("session", "resimulate", study, "--participant", "P01", "--label", "same", "--quiet")
    again = read_tables(study / "resimulated" / "same")[0][COLUMNS]
    assert again.equals(original)  # the physics is deterministic: the same motion, the same outcome

    output = run("session", "resimulate", study, "--participant", "P01", "--interaction", "soft_hand", "--quiet")
    other = study / "resimulated" / "soft_hand"
    assert str(other) in output
    moved = read_tables(other)[0]
    assert set(moved.interaction) == {"soft_hand"} and len(moved) == len(original)
    with open_study(other, readonly=True) as store:
        assert store.name == "tiny-soft_hand" and "re-simulated: soft_hand" in store.protocol.title
        session = store.session_of("P01")
        assert session.input.startswith("resimulated:") and f"{study.resolve()}" in session.input
    with open_study(study, readonly=True) as store:  # the original is untouched
        assert read_tables(study)[0][COLUMNS].equals(original) and len(store.participants()) == 1

    text = write_comparison(read_tables(study)[0], moved, tmp_path / "report", ("original", "soft_hand")).read_text()
    assert "original and soft_hand, side by side" in text and "How the tasks ended" in text
    outcomes = compare_run_sets(read_tables(study)[0], moved, ("original", "soft_hand"))["outcomes"]
    assert outcomes.groupby("run_set").sum(numeric_only=True).sum(axis=1).tolist() == [len(original)] * 2


def test_a_training_programs_sessions_are_replayed_in_order_with_their_criterion_tasks(tmp_path):
    """Each session of a trainee's program replayed: the criterion phases' tasks as they ran, each at
    its staircase difficulty; the same model gives the same tasks, outcomes and criterion."""
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "program-toy.toml", "--seed", "3")
    run("participant", "add", study, "--id", "P01", "--gender", "female", "--age", "22", "--handedness", "right",
        "--mr-experience", "no")
    for _ in range(2):  # train1, then the retention test on the simulated calendar
        run("session", "run", study, "--participant", "P01", "--input", "simulated", "--quiet")
    columns = COLUMNS + ["session", "session_index", "task_in_phase", "difficulty", "criterion_met"]
    original = read_tables(study)[0][columns]
    assert set(original.session) == {"train1", "retention"} and original.difficulty.notna().any()

    run("session", "resimulate", study, "--participant", "P01", "--label", "same", "--quiet")
    again = read_tables(study / "resimulated" / "same")[0][columns]
    assert again.equals(original)
