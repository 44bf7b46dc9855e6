"""Reading and checking the exported tidy tables, and turning trials into participant-level cells.

Everything that comes from outside is checked here, once; the statistics modules trust what they get.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

TRIAL_COLUMNS = ("participant", "group", "system", "object", "time_s", "attempts")
QUESTIONNAIRE_COLUMNS = ("participant", "system", "item", "rating")
LABEL_COLUMNS = ("participant", "group", "system", "object", "item", "stage")
RATING_RANGE = (0, 10)
MEASURES = ("time_s", "attempts")


class AnalysisInputError(ValueError):
    """A table handed to the analysis is unusable; the message names the file, column and value."""


def read_table(path: str | Path) -> pd.DataFrame:
    """Read an exported table from CSV or Parquet (chosen by the file's suffix)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        header = pd.read_csv(path, nrows=0).columns
        labels = {column: str for column in LABEL_COLUMNS if column in header}
        return pd.read_csv(path, dtype=labels)
    if suffix in (".parquet", ".pq"):
        return pd.read_parquet(path)
    raise AnalysisInputError(f"{path}: unknown table format {suffix!r} (expected .csv or .parquet)")


def read_trials(path: str | Path) -> pd.DataFrame:
    """Read and check an exported trials table."""
    return check_trials(read_table(path), source=str(path))


def read_questionnaire(path: str | Path) -> pd.DataFrame:
    """Read and check an exported questionnaire table."""
    return check_questionnaire(read_table(path), source=str(path))


def check_trials(trials: pd.DataFrame, source: str = "trials table") -> pd.DataFrame:
    """Return a checked copy of a trials table with numeric measures and boolean flags.

    Raises AnalysisInputError naming the source, column and offending value for: a missing column,
    a missing label, a non-numeric or negative time, a negative or fractional attempt count, a
    completed task without a time, a participant listed in two groups, fewer than two groups or
    fewer than two objects.
    """
    trials = trials.reset_index(drop=True)
    _require_columns(trials, TRIAL_COLUMNS, source)
    if trials.empty:
        raise AnalysisInputError(f"{source}: no trials")
    out = trials.copy()
    for column in ("participant", "group", "system", "object"):
        out[column] = _labels(trials, column, source)
    out["time_s"] = _numbers(trials, "time_s", source)
    out["attempts"] = _numbers(trials, "attempts", source)
    _require(out, "time_s", out["time_s"] < 0, source, "is negative")
    fractional = out["attempts"].notna() & (out["attempts"] != np.round(out["attempts"]))
    _require(out, "attempts", (out["attempts"] < 0) | fractional, source, "is not a count of drops")
    for flag in ("completed", "simulated", "withdrawn"):
        if flag in trials.columns:
            out[flag] = _flags(trials, flag, source)
    if "completed" in out.columns:
        untimed = out["completed"] & out["time_s"].isna()
        _require(out, "completed", untimed, source, "is True but time_s is empty")
    _check_one_group_each(out, source)
    _require_levels(out, "group", source, "a mixed ANOVA needs at least two groups")
    _require_levels(out, "object", source, "a within-participant comparison needs at least two objects")
    return out


def check_questionnaire(answers: pd.DataFrame, source: str = "questionnaire table") -> pd.DataFrame:
    """Return a checked copy of a questionnaire table with integer ratings in 0-10.

    Raises AnalysisInputError for a missing column or label, a rating that is not an integer in
    0-10, an item rated twice by one participant for one system, or a participant in two groups.
    """
    answers = answers.reset_index(drop=True)
    _require_columns(answers, QUESTIONNAIRE_COLUMNS, source)
    out = answers.copy()
    for column in ("participant", "system", "item"):
        out[column] = _labels(answers, column, source)
    rating = _numbers(answers, "rating", source)
    _require(out.assign(rating=rating), "rating", rating.isna(), source, "is empty")
    low, high = RATING_RANGE
    invalid = (rating < low) | (rating > high) | (rating != np.round(rating))
    _require(out, "rating", invalid, source, f"is not an integer rating in {low}-{high}")
    out["rating"] = rating.astype(int)
    for flag in ("simulated", "withdrawn"):
        if flag in answers.columns:
            out[flag] = _flags(answers, flag, source)
    if "group" in answers.columns:
        out["group"] = _labels(answers, "group", source)
        _check_one_group_each(out, source)
    repeated = out.duplicated(["participant", "system", "item"], keep="first")
    if repeated.any():
        row = out[repeated].iloc[0]
        raise AnalysisInputError(
            f"{source}: participant {row['participant']!r} rated item {row['item']!r} for system "
            f"{row['system']!r} more than once (data row {int(row.name) + 1})"
        )
    return out


def check_same_groups(trials: pd.DataFrame, answers: pd.DataFrame) -> None:
    """Both tables must put each participant in the same group."""
    if "group" not in answers.columns:
        return
    trial_groups = trials.drop_duplicates("participant").set_index("participant")["group"]
    answer_groups = answers.drop_duplicates("participant").set_index("participant")["group"]
    shared = trial_groups.index.intersection(answer_groups.index)
    differ = trial_groups[shared] != answer_groups[shared]
    if differ.any():
        who = differ[differ].index[0]
        raise AnalysisInputError(
            f"participant {who!r} is in group {trial_groups[who]!r} in the trials table but in group "
            f"{answer_groups[who]!r} in the questionnaire table (column 'group')"
        )


def is_simulated(table: pd.DataFrame | None) -> bool:
    """True when any row of the table is flagged as simulated."""
    return table is not None and "simulated" in table.columns and bool(table["simulated"].any())


def withdrawn(table: pd.DataFrame | None) -> set[str]:
    """Participants flagged as withdrawn (their data stay in the log, out of the analysis)."""
    if table is None or "withdrawn" not in table.columns:
        return set()
    return set(table.loc[table["withdrawn"], "participant"])


def exclude_stages(trials: pd.DataFrame, stages: Sequence[str]) -> pd.DataFrame:
    """Trials outside the named stages (e.g. training, which only one group does)."""
    if "stage" not in trials.columns or not stages:
        return trials
    named = trials["stage"].astype(str).str.lower().isin([s.lower() for s in stages])
    return trials[~named]


def participant_cells(
    trials: pd.DataFrame, dv: str, within: str = "object", subject: str = "participant"
) -> pd.DataFrame:
    """One value per participant, group, system and object: the mean over that cell's trials.

    Completion time uses completed tasks only (an unfinished task has no time, not a zero); attempts
    use every task with a recorded count, finished or not, since a drop is a drop.
    """
    rows = trials
    if dv == "time_s" and "completed" in trials.columns:
        rows = trials[trials["completed"]]
    rows = rows[rows[dv].notna()]
    keys = [subject, "group", "system", within]
    return rows.groupby(keys, observed=True, sort=True)[dv].mean().reset_index()


def complete_cases(
    cells: pd.DataFrame, dv: str, within: str, subject: str, levels: Sequence[str] | None = None
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Keep the participants with a value in every level of ``within``; list the others and why.

    Returns (complete cells, dropped) where dropped has the columns participant and reason.
    """
    levels = sorted(cells[within].unique()) if levels is None else list(levels)
    present = cells[cells[dv].notna()].groupby(subject, observed=True)[within].agg(set)
    missing = {who: [lv for lv in levels if lv not in have] for who, have in present.items()}
    every = cells[subject].unique()
    reasons = {
        who: f"no {dv} for {within} {', '.join(map(str, missing.get(who, levels)))}"
        for who in every
        if missing.get(who, levels)
    }
    dropped = pd.DataFrame({"participant": list(reasons), "reason": list(reasons.values())})
    kept = cells[~cells[subject].isin(list(reasons)) & cells[within].isin(levels)]
    return kept.reset_index(drop=True), dropped


def stars(p: float) -> str:
    """Significance marks: * p < .05, ** p < .01, *** p < .001."""
    if not np.isfinite(p):
        return ""
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else ""


def _require_columns(table: pd.DataFrame, columns: Sequence[str], source: str) -> None:
    for column in columns:
        if column not in table.columns:
            raise AnalysisInputError(
                f"{source}: missing column {column!r} (columns present: {', '.join(map(str, table.columns))})"
            )


def _labels(table: pd.DataFrame, column: str, source: str) -> pd.Series:
    values = table[column]
    _require(table, column, values.isna() | (values.astype(str).str.strip() == ""), source, "is empty")
    return values.astype(str)


def _numbers(table: pd.DataFrame, column: str, source: str) -> pd.Series:
    raw = table[column]
    if pd.api.types.is_bool_dtype(raw):
        _require(table, column, pd.Series(True, index=raw.index), source, "is not a number")
    numbers = pd.to_numeric(raw, errors="coerce").astype(float)
    blank = raw.isna() | (raw.astype(str).str.strip() == "")
    _require(table, column, numbers.isna() & ~blank, source, "is not a number")
    return numbers


def _flags(table: pd.DataFrame, column: str, source: str) -> pd.Series:
    raw = table[column]
    if pd.api.types.is_bool_dtype(raw):
        return raw.astype(bool)
    words = {"true": True, "false": False, "1": True, "0": False, "1.0": True, "0.0": False}
    mapped = raw.astype(str).str.strip().str.lower().map(words)
    _require(table, column, mapped.isna(), source, "is not True or False")
    return mapped.astype(bool)


def _require(table: pd.DataFrame, column: str, bad: pd.Series, source: str, what: str) -> None:
    if not bad.any():
        return
    row = int(np.flatnonzero(bad.to_numpy())[0])
    where = f"data row {row + 1}"
    if "participant" in table.columns and column != "participant":
        where += f", participant {table['participant'].iloc[row]!r}"
    value = table[column].iloc[row]
    value = value.item() if isinstance(value, np.generic) else value
    raise AnalysisInputError(f"{source}: column {column!r} value {value!r} {what} ({where})")


def _check_one_group_each(table: pd.DataFrame, source: str) -> None:
    groups = table.groupby("participant", observed=True)["group"].unique()
    several = groups[groups.map(len) > 1]
    if len(several):
        who = several.index[0]
        names = " and ".join(repr(g) for g in sorted(several.iloc[0]))
        raise AnalysisInputError(f"{source}: participant {who!r} appears in groups {names} (column 'group')")


def _require_levels(table: pd.DataFrame, column: str, source: str, why: str) -> None:
    levels = table[column].unique()
    if len(levels) < 2:
        raise AnalysisInputError(f"{source}: column {column!r} has the single value {levels[0]!r}; {why}")
