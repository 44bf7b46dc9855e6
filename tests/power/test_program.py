"""``microg plan training``: cohorts of a training program played in silico on Dask; one and two
workers give the same plan, a run killed mid-way resumes to it, and the plan's numbers are the
cohorts' as defined (proficient, tasks to criterion, the first session a cohort reaches the target)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.power.program import ProgramRequest, cohort_summary, plan_words
from microg.study.protocol import load_protocol
from tests.waiting import ended, wait_until

ROOT = Path(__file__).resolve().parents[2]
TOY = ROOT / "tests" / "study" / "protocols" / "program-toy.toml"
ARGS = ["plan", "training", "--protocol", str(TOY), "--n", "2", "--sims", "5", "--seed", "4", "--quiet"]
pytestmark = pytest.mark.timeout(1800)  # cold compiles of two kinds in each Dask worker on a shared machine


def plan(out: Path, *extra: str) -> str:
    result = CliRunner().invoke(main, [*ARGS, "--out", str(out), *extra])
    assert result.exit_code == 0, result.output
    return result.output


def test_one_and_two_workers_and_a_killed_run_resumed_give_the_same_plan(tmp_path):
    one = plan(tmp_path / "one", "--workers", "1")
    plan(tmp_path / "two", "--workers", "2")
    expected = (tmp_path / "one" / "plan.csv").read_bytes()
    assert (tmp_path / "two" / "plan.csv").read_bytes() == expected
    table = pd.read_csv(tmp_path / "one" / "plan.csv")
    assert list(table["session"]) == ["train1", "retention"] * 2 and (table["cohorts"] == 5).all()
    assert table.loc[table["session"] == "train1", "tasks_to_criterion"].between(2, 4).all()
    assert (tmp_path / "one" / "plan.png").stat().st_size > 10_000 and "still meet the criterion" in one

    killed = tmp_path / "killed"
    child = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", *ARGS, "--out", str(killed), "--workers", "1"],
                             cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    cohorts = killed / "cohorts.csv"
    wait_until(lambda: cohorts.exists() and cohorts.read_text().count("\n") > 1 + 4 or child.poll() is not None,
               "the first cohort's rows in cohorts.csv")
    os.killpg(child.pid, signal.SIGKILL)
    ended(child, "the plan killed after its first cohort")
    assert not (killed / "plan.csv").exists(), "the run ended before it was killed"
    plan(killed, "--workers", "1", "--resume")
    assert (killed / "plan.csv").read_bytes() == expected
    rows = pd.read_csv(cohorts)
    assert len(rows) == 5 * 4 and not rows.duplicated(["program", "cohort", "group", "session"]).any()


def trials(rows: list[tuple]) -> pd.DataFrame:
    """A program's trials table: (participant, group, session, session_index, phase, object, status,
    time_s, attempts, criterion_met)."""
    frame = pd.DataFrame(rows, columns=["participant", "group", "session", "session_index", "phase", "object",
                                        "status", "time_s", "attempts", "criterion_met"])
    frame["task_index"] = frame.groupby(["participant", "session"]).cumcount()
    frame["session_date"] = np.where(frame["session_index"] == 1, "2026-01-01", "2026-01-08")
    return frame


def test_a_cohort_counts_proficient_trainees_by_the_program_criterion():
    """train1: proficient when the criterion was met there; retention (a test of two tasks): when its
    tasks meet the criterion (16 s, no drop), two in a row capped at the test's two tasks."""
    program = load_protocol(TOY)
    rows = [("S1", "V", "train1", 1, "train", "C", "completed", 9.0, 0, False),
            ("S1", "V", "train1", 1, "train", "F", "completed", 8.0, 0, True),
            ("S1", "V", "retention", 2, "test", "C", "completed", 10.0, 0, None),
            ("S1", "V", "retention", 2, "test", "F", "completed", 17.0, 0, None),  # too slow
            ("S2", "V", "train1", 1, "train", "C", "timeout", None, 1, False),
            ("S2", "V", "train1", 1, "train", "F", "completed", 9.0, 0, False),
            ("S2", "V", "train1", 1, "train", "C", "completed", 9.0, 1, False),
            ("S2", "V", "train1", 1, "train", "F", "completed", 9.0, 0, False),
            ("S2", "V", "retention", 2, "test", "C", "completed", 12.0, 0, None),
            ("S2", "V", "retention", 2, "test", "F", "completed", 14.0, 0, None)]
    summary = cohort_summary(trials(rows), program).set_index(["group", "session"])
    assert summary.loc[("V", "train1"), "proficient"] == 0.5 and summary.loc[("V", "train1"), "tasks_to_criterion"] == 3
    assert summary.loc[("V", "retention"), "proficient"] == 0.5 and summary.loc[("V", "retention"), "day"] == 7
    assert summary.loc[("V", "retention"), "time_s"] == np.mean([10.0, 17.0, 12.0, 14.0])


def test_the_words_give_the_median_first_session_reaching_the_target_and_its_band():
    """Five cohorts reach 80 % after sessions 1, 2, 2, 2 and never: the median is session 2, its 90 %
    band session 1 to none (the last cohort never reaches it)."""
    program = load_protocol(TOY)
    request = ProgramRequest(program, 2, 5)
    shares = [(0.8, 1.0), (0.5, 0.9), (0.5, 0.8), (0.0, 1.0), (0.5, 0.5)]
    cohorts = pd.DataFrame([{"program": "plan", "cohort": c, "group": "V", "session": s, "session_index": i + 1,
                             "day": 7 * i, "proficient": share[i]}
                            for c, share in enumerate(shares) for i, s in enumerate(["train1", "retention"])])
    table = cohorts.groupby(["program", "group", "session", "session_index", "day"], as_index=False, sort=False)[
        "proficient"].mean()
    words = plan_words(table, cohorts, request)
    assert words == ["program-toy, group V (veteran): 80 % proficient after session retention (90 % band train1-not "
                     "reached); 7 days later, at retention, 84 % still meet the criterion"]


def test_a_protocol_of_one_session_or_other_groups_is_refused(tmp_path):
    result = CliRunner().invoke(main, ["plan", "training", "--protocol", "paper", "--out", str(tmp_path / "x")])
    assert result.exit_code == 1 and "declares no [[sessions]]" in result.output
    other = tmp_path / "other.toml"
    other.write_text(TOY.read_text().replace('code = "B"', 'code = "X"').replace("../", ""))
    result = CliRunner().invoke(main, [*ARGS, "--compare", str(other), "--out", str(tmp_path / "y")])
    assert result.exit_code == 1 and "differ from" in result.output and "'X'" in result.output
