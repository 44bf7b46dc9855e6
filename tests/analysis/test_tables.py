"""Reading and checking the exported tables: bad input gets an error naming file, column and value;
trials become participant-level cells by the documented rules."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.analysis import (
    AnalysisInputError,
    analyse_study,
    check_trials,
    complete_cases,
    incomplete_cases,
    participant_cells,
    read_questionnaire,
    read_trials,
)
from microg.analysis.tables import exclude_phases
from microg.cli import main
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
    with pytest.raises(AnalysisInputError, match=rf"{path}: participant '{who}' has 'B' and 'V' in column 'group'"):
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
    columns = ["participant", "group", "interaction", "object", "time_s", "attempts", "completed"]
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
            "interaction": ["s"] * 3,
            "object": ["cube"] * 3,
            "completed": [True, False, True],
            "time_s": [10.0, np.nan, 20.0],
            "attempts": [1.0, 4.0, 0.0],
        }
    )
    assert participant_cells(trials, "time_s", completed="completed")["time_s"].tolist() == [15.0]
    assert participant_cells(trials, "attempts")["attempts"].tolist() == [5.0 / 3.0]


def test_complete_cases_lists_who_was_dropped_and_why():
    cells = pd.DataFrame(
        {
            "participant": ["a", "a", "b", "c", "c"],
            "object": ["cube", "long", "cube", "cube", "long"],
            "v": [1.0, 2.0, 3.0, 4.0, np.nan],
        }
    )
    kept = complete_cases(cells, "v", "object", "participant")
    dropped = incomplete_cases(cells, "v", "object", "participant")
    assert sorted(kept["participant"].unique()) == ["a"]
    assert dropped.set_index("participant")["reason"].to_dict() == {
        "b": "no v for object long",
        "c": "no v for object long",
    }


def test_training_trials_are_left_out(study):
    trials = study[0]
    assert (trials["phase"] == "training").any()
    kept = exclude_phases(trials, ["training"])
    assert not (kept["phase"] == "training").any()
    assert len(kept) == int((trials["phase"] != "training").sum())


@pytest.mark.parametrize("value, what", [(np.inf, "inf is not finite"), (-np.inf, "-inf is not finite"),
                                         (1e308, "1e+308 is larger than 1e+12")])  # fmt: skip
def test_non_finite_and_absurd_values_name_file_column_and_row(tmp_path, study, value, what):
    trials = study[0].copy()
    trials.loc[7, "time_s"] = value
    path = _write(tmp_path, trials, "trials.csv")
    who = trials.loc[7, "participant"]
    with pytest.raises(
        AnalysisInputError, match=re.escape(f"{path}: column 'time_s' value {what} (data row 8, participant '{who}')")
    ):
        read_trials(path)


def test_empty_files_are_refused_with_the_file_named(tmp_path, study):
    empty = tmp_path / "trials.csv"
    empty.write_text("")
    with pytest.raises(AnalysisInputError, match=rf"{empty}: the file is empty"):
        read_trials(empty)
    header_only = _write(tmp_path, study[0].iloc[:0], "header.csv")
    with pytest.raises(AnalysisInputError, match=rf"{header_only}: no trials"):
        read_trials(header_only)
    answers = _write(tmp_path, study[1].iloc[:0], "answers.csv")
    with pytest.raises(AnalysisInputError, match=rf"{answers}: no ratings"):
        read_questionnaire(answers)


def test_wrong_types_are_refused(tmp_path, study):
    trials = study[0].copy()
    trials["attempts"] = trials["attempts"].astype(object)
    trials.loc[5, "attempts"] = True
    with pytest.raises(AnalysisInputError, match=r"column 'attempts' value 'True' is not a number \(data row 6"):
        read_trials(_write(tmp_path, trials.assign(attempts=trials["attempts"].astype(str)), "a.csv"))
    flagged = study[0].assign(completed="maybe")
    with pytest.raises(AnalysisInputError, match=r"column 'completed' value 'maybe' is not True or False \(data row 1"):
        read_trials(_write(tmp_path, flagged, "b.csv"))
    not_a_table = tmp_path / "trials.parquet"
    not_a_table.write_text("participant,group")
    with pytest.raises(AnalysisInputError, match=rf"{not_a_table}: not a readable parquet table"):
        read_trials(not_a_table)


def test_an_interaction_with_two_labels_is_refused(study):
    trials = study[0].assign(interaction_label=np.where(study[0]["interaction"] == "soft_hand", "System 2", "System 1"))
    trials.loc[3, "interaction_label"] = "System 3"
    with pytest.raises(
        AnalysisInputError, match=r"interaction '.*' has 'System \d' and 'System 3' in column 'interaction_label'"
    ):
        analyse_study(trials)


def test_any_tidy_table_works_with_its_own_column_names(study):
    """The whole analysis on renamed columns gives the same numbers as on the export's names."""
    trials, answers = study
    names = {
        "participant": "pid",
        "group": "cohort",
        "object": "shape",
        "interaction": "tool",
        "time_s": "duration",
        "attempts": "errors",
        "completed": "done",
        "phase": "block",
        "item": "question",
        "rating": "score",
    }
    renamed = analyse_study(
        trials.rename(columns=names),
        answers.rename(columns=names),
        subject="pid",
        group="cohort",
        within="shape",
        interaction_column="tool",
        dv=["duration", "errors"],
        counts=["errors"],
        completed="done",
        phase="block",
        item="question",
        rating="score",
    )
    plain = analyse_study(trials, answers)
    measures = {"duration": "time_s", "errors": "attempts"}
    for piece in ("anova", "posthoc", "simple_effects", "assumptions", "cell_means", "count_model", "comparison"):
        ours = (
            getattr(renamed, piece)
            .replace({"measure": measures})
            .replace({"cohort": "group", "shape": "object", "cohort:shape": "group:object"})
        )
        numbers = ours.select_dtypes("number").columns
        theirs = getattr(plain, piece)
        np.testing.assert_allclose(ours[numbers].to_numpy(float), theirs[numbers].to_numpy(float), rtol=1e-12,
                                   err_msg=piece)  # fmt: skip
    np.testing.assert_array_equal(renamed.likert_tests["p_unc"], plain.likert_tests["p_unc"])
    assert set(renamed.dropped["pid"]) == set(plain.dropped["participant"])


def test_cli_takes_column_names_as_options_and_from_a_file(tmp_path, study):
    trials = study[0].rename(columns={"participant": "pid", "object": "shape", "time_s": "rt", "attempts": "errors"})
    path = _write(tmp_path, trials, "mine.csv")
    options = ["report", "--trials", str(path), "--subject", "pid", "--within", "shape", "--dv", "rt",
               "--dv", "errors", "--count", "errors"]  # fmt: skip
    result = CliRunner().invoke(main, [*options, "--out", str(tmp_path / "a")])
    assert result.exit_code == 0, result.output
    mapping = tmp_path / "columns.toml"
    mapping.write_text('subject = "pid"\nwithin = "shape"\ndv = ["rt", "errors"]\ncounts = "errors"\n')
    result = CliRunner().invoke(main, ["report", "--trials", str(path), "--columns", str(mapping), "--out",
                                       str(tmp_path / "b")])  # fmt: skip
    assert result.exit_code == 0, result.output
    for name in ("anova_rt.csv", "anova_errors_soft_hand.csv", "count_model.csv", "interactions.csv"):
        pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "a" / name), pd.read_csv(tmp_path / "b" / name))
    assert set(pd.read_csv(tmp_path / "a" / "count_model.csv")["measure"]) == {"errors"}
    plain = analyse_study(study[0])
    anova = pd.read_csv(tmp_path / "a" / "anova_rt.csv")
    np.testing.assert_allclose(anova["F"], plain.table("anova", "impulse_penetration", "time_s")["F"], rtol=1e-12)


def test_cli_names_a_bad_mapping_file(tmp_path, study):
    mapping = tmp_path / "columns.toml"
    mapping.write_text('participant = "pid"\n')
    path = _write(tmp_path, study[0], "trials.csv")
    result = CliRunner().invoke(main, ["report", "--trials", str(path), "--columns", str(mapping), "--out",
                                       str(tmp_path / "out")])  # fmt: skip
    assert result.exit_code == 1
    assert f"{mapping}: unknown key 'participant'" in result.output


def test_a_row_given_twice_is_refused_naming_it_and_dropped_only_when_asked(tmp_path, study):
    """Rows pasted in twice would count twice in every mean and test: refused, naming each copy;
    with --drop-duplicates dropped and listed, and the results are those of the table without them."""
    trials, answers = study
    doubled = pd.concat([trials, trials.iloc[[3, 10]]], ignore_index=True)
    path = _write(tmp_path, doubled, "trials.csv")
    n = len(trials)
    listed = f"data row {n + 1} repeats row 4, data row {n + 2} repeats row 11"
    with pytest.raises(AnalysisInputError, match=re.escape(f"{path}: 2 row(s) repeat an earlier row in every "
                                                           f"column: {listed}")):
        read_trials(path)
    result = CliRunner().invoke(main, ["report", "--trials", str(path), "--out", str(tmp_path / "refused")])
    assert result.exit_code == 1 and listed in result.output and "--drop-duplicates" in result.output
    assert not (tmp_path / "refused").exists()

    repeated_answers = pd.concat([answers, answers.iloc[[0]]], ignore_index=True)
    kept = analyse_study(path, repeated_answers, drop_duplicates=True)
    original = analyse_study(trials, answers)
    for table in ("anova", "comparison", "likert_tests"):
        pd.testing.assert_frame_equal(getattr(kept, table), getattr(original, table))
    assert kept.warnings[:2] == (
        f"{path}: 2 rows repeated earlier rows in every column and were dropped ({listed})",
        f"questionnaire table: 1 row repeated an earlier row in every column and was dropped (data row "
        f"{len(answers) + 1} repeats row 1)")
    assert kept.warnings[2:] == original.warnings


def test_two_different_rows_of_one_exported_task_are_refused(study):
    trials = study[0].assign(session=lambda t: t.participant.str[1:].astype(int),
                             task_index=lambda t: t.groupby("participant").cumcount())
    changed = pd.concat([trials, trials.iloc[[5]].assign(time_s=1.0)], ignore_index=True)
    row = trials.iloc[5]
    with pytest.raises(AnalysisInputError, match=re.escape(
            f"trials table: data rows 6 and {len(trials) + 1} are the same task (participant {row.participant!r}, "
            f"study 'fixture', session {int(row.session)}, task_index {int(row.task_index)}) with different values")):
        analyse_study(changed)
    assert len(check_trials(trials)) == len(trials)  # one row per task is what an export has
