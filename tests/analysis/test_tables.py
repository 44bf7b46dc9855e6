"""Reading and checking the exported tables: bad input gets an error naming file, column and value;
trials become participant-level cells by the documented rules."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.analysis import AnalysisInputError, complete_cases, participant_cells, read_questionnaire, read_trials
from microg.analysis.tables import exclude_stages
from microg.study.cli import main
from tests.analysis.study_data import make_study


@pytest.fixture(scope="module")
def study():
    return make_study(seed=3)


def _write(tmp_path, table: pd.DataFrame, name: str):
    path = tmp_path / name
    table.to_csv(path, index=False)
    return path


def test_missing_column_names_file_and_column(tmp_path, study):
    path = _write(tmp_path, study[0].drop(columns=["attempts"]), "trials.csv")
    with pytest.raises(AnalysisInputError, match=rf"{path}: missing column 'attempts'"):
        read_trials(path)


def test_non_numeric_time_names_file_column_value_and_row(tmp_path, study):
    trials = study[0].astype({"time_s": object})
    trials.loc[4, "time_s"] = "12,5s"
    path = _write(tmp_path, trials, "trials.csv")
    who = trials.loc[4, "participant"]
    with pytest.raises(AnalysisInputError) as error:
        read_trials(path)
    message = str(error.value)
    assert str(path) in message and "'time_s'" in message and "'12,5s'" in message
    assert "data row 5" in message and who in message


def test_participant_in_two_groups_is_named(tmp_path, study):
    trials = study[0].copy()
    who = trials.loc[0, "participant"]
    other = "B" if trials.loc[0, "group"] == "V" else "V"
    trials.loc[trials.index[trials["participant"] == who][-1], "group"] = other
    path = _write(tmp_path, trials, "trials.csv")
    with pytest.raises(AnalysisInputError, match=rf"{path}: participant '{who}' appears in groups 'B' and 'V'"):
        read_trials(path)


@pytest.mark.parametrize("rating", [11, -1, 7.5])
def test_rating_outside_the_scale_names_file_column_and_value(tmp_path, study, rating):
    answers = study[1].astype({"rating": float})
    answers.loc[6, "rating"] = rating
    path = _write(tmp_path, answers, "answers.csv")
    with pytest.raises(
        AnalysisInputError, match=rf"{path}: column 'rating' value {float(rating)!r} is not an integer rating in 0-10"
    ):
        read_questionnaire(path)


def test_single_group_is_refused(tmp_path, study):
    path = _write(tmp_path, study[0].assign(group="V"), "trials.csv")
    with pytest.raises(AnalysisInputError, match=rf"{path}: column 'group' has the single value 'V'"):
        read_trials(path)


def test_negative_time_and_fractional_attempts_are_refused(tmp_path, study):
    trials = study[0].copy()
    trials.loc[2, "time_s"] = -3.0
    with pytest.raises(AnalysisInputError, match=r"column 'time_s' value -3.0 is negative"):
        read_trials(_write(tmp_path, trials, "a.csv"))
    trials = study[0].astype({"attempts": float})
    trials.loc[2, "attempts"] = 1.5
    with pytest.raises(AnalysisInputError, match=r"column 'attempts' value 1.5 is not a count"):
        read_trials(_write(tmp_path, trials, "b.csv"))


def test_completed_task_without_time_is_refused(tmp_path, study):
    trials = study[0].copy()
    trials.loc[3, "time_s"] = np.nan
    with pytest.raises(AnalysisInputError, match=r"column 'completed' value True is True but time_s is empty"):
        read_trials(_write(tmp_path, trials, "trials.csv"))


def test_rating_twice_is_refused(tmp_path, study):
    answers = pd.concat([study[1], study[1].iloc[[0]]])
    with pytest.raises(AnalysisInputError, match=r"rated item .* more than once"):
        read_questionnaire(_write(tmp_path, answers, "answers.csv"))


def test_unknown_format_is_refused(tmp_path):
    path = tmp_path / "trials.xlsx"
    path.write_bytes(b"")
    with pytest.raises(AnalysisInputError, match=r"trials.xlsx: unknown table format '.xlsx'"):
        read_trials(path)


def test_parquet_and_csv_read_the_same(tmp_path, study):
    study[0].to_parquet(tmp_path / "trials.parquet")
    from_parquet = read_trials(tmp_path / "trials.parquet")
    from_csv = read_trials(_write(tmp_path, study[0], "trials.csv"))
    columns = ["participant", "group", "system", "object", "time_s", "attempts", "completed"]
    pd.testing.assert_frame_equal(from_parquet[columns], from_csv[columns], check_dtype=False)


def test_cli_reports_bad_input_with_the_file_and_exit_code(tmp_path, study):
    trials = study[0].astype({"time_s": object})
    trials.loc[0, "time_s"] = "abc"
    path = _write(tmp_path, trials, "trials.csv")
    result = CliRunner().invoke(main, ["report", "--trials", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert f"{path}: column 'time_s' value 'abc' is not a number" in result.output


def test_cells_use_completed_times_and_all_attempts():
    trials = pd.DataFrame(
        {
            "participant": ["p1"] * 3,
            "group": ["V"] * 3,
            "system": ["s"] * 3,
            "object": ["cube"] * 3,
            "completed": [True, False, True],
            "time_s": [10.0, np.nan, 20.0],
            "attempts": [1.0, 4.0, 0.0],
        }
    )
    assert participant_cells(trials, "time_s")["time_s"].tolist() == [15.0]
    assert participant_cells(trials, "attempts")["attempts"].tolist() == [5.0 / 3.0]


def test_complete_cases_lists_who_was_dropped_and_why():
    cells = pd.DataFrame(
        {
            "participant": ["a", "a", "b", "c", "c"],
            "object": ["cube", "long", "cube", "cube", "long"],
            "v": [1.0, 2.0, 3.0, 4.0, np.nan],
        }
    )
    kept, dropped = complete_cases(cells, "v", "object", "participant")
    assert sorted(kept["participant"].unique()) == ["a"]
    assert dropped.set_index("participant")["reason"].to_dict() == {
        "b": "no v for object long",
        "c": "no v for object long",
    }


def test_training_trials_are_left_out(study):
    trials = study[0]
    assert (trials["stage"] == "training").any()
    kept = exclude_stages(trials, ["training"])
    assert not (kept["stage"] == "training").any()
    assert len(kept) == int((trials["stage"] != "training").sum())
