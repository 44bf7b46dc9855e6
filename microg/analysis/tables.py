"""Reading and checking tidy tables, and turning trials into participant-level cells.

Everything that comes from outside is checked here, once; the statistics modules trust what they
get. Every column name is a parameter; the defaults are the export's names (:mod:`microg.schema`).
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from microg.schema import ANSWERS, QUESTIONNAIRE, RATING_RANGE, TRIALS

LARGEST_VALUE = 1e12
"""Largest magnitude a measure may have. No task lasts 1e12 s (31 700 years) or has 1e12 drops; a
value near float64's limit (1e308) is a logging error, and its square overflows to infinity inside
the sums of squares."""
TEXT_COLUMNS = tuple(dict.fromkeys(c.name for c in (*TRIALS, *QUESTIONNAIRE, *ANSWERS) if c.dtype == "string"))
FLAG_COLUMNS = ("completed", "simulated", "withdrawn")
COLUMN_OPTIONS = ("subject", "group", "within", "interaction_column", "dv", "counts", "completed", "phase", "label",
                  "item", "rating", "practice")  # fmt: skip
"""The column names :func:`microg.analysis.analyse_study` takes; ``dv`` and ``counts`` are lists."""
TRIAL_TEXT = (("subject", "participant"), ("group", "group"), ("within", "object"), ("interaction", "interaction"))
QUESTIONNAIRE_TEXT = (("subject", "participant"), ("interaction", "interaction"), ("item", "item"))
"""The identifying columns read as text from a CSV file: (option, default name)."""
TASK_KEY = ("study", "session", "task_index")
"""Columns of an exported trials table that name one planned task (with the participant)."""


class AnalysisInputError(ValueError):
    """A table handed to the analysis is unusable; the message names the file, column, value and row."""


def read_table(path: str | Path, text: Sequence[str] = ()) -> pd.DataFrame:
    """Read a tidy table from CSV or Parquet (chosen by the file's suffix).

    Parameters
    ----------
    path : str or Path
        A ``.csv``, ``.parquet`` or ``.pq`` file.
    text : sequence of str
        Columns to read as text from a CSV file (besides the export's text columns), so that a
        participant id such as ``007`` stays ``"007"``.

    Returns
    -------
    pandas.DataFrame
        The table as stored.

    Raises
    ------
    AnalysisInputError
        For an unknown suffix, an empty file or a file that is not a table.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from microg.analysis.tables import read_table
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "t.csv"
    >>> _ = path.write_text("participant,time_s\\n007,12.5\\n")
    >>> read_table(path)["participant"].tolist()
    ['007']
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise AnalysisInputError(f"{path}: unknown table format {suffix!r} (expected .csv or .parquet)")
    if path.stat().st_size == 0:
        raise AnalysisInputError(f"{path}: the file is empty (no header, no rows)")
    try:
        if suffix == ".csv":
            encoding = _csv_encoding(path)
            header = pd.read_csv(path, nrows=0, encoding=encoding).columns
            texts = {column: str for column in (*TEXT_COLUMNS, *text) if column in header}
            return pd.read_csv(path, dtype=texts, encoding=encoding)
        return pd.read_parquet(path)
    except UnicodeDecodeError as error:
        raise AnalysisInputError(f"{path}: not UTF-8 text ({error.reason}: byte 0x{error.object[error.start]:02x}); "
                                 "save the table as UTF-8 (a spreadsheet's \"CSV UTF-8\")") from None
    except (ValueError, OSError) as error:
        raise AnalysisInputError(f"{path}: not a readable {suffix[1:]} table ({error})") from None


def _csv_encoding(path: Path) -> str:
    """UTF-16 where the file begins with its byte order mark (a spreadsheet's "Unicode text"), else
    UTF-8, with or without its mark."""
    with open(path, "rb") as stream:
        start = stream.read(2)
    return "utf-16" if start in (b"\xff\xfe", b"\xfe\xff") else "utf-8-sig"


def read_columns(path: str | Path) -> dict:
    """Column names from a small TOML mapping file, for :func:`microg.analysis.analyse_study`.

    Parameters
    ----------
    path : str or Path
        A TOML file with any of the keys COLUMN_OPTIONS, e.g. ``subject = "pid"`` and
        ``dv = ["rt", "errors"]``.

    Returns
    -------
    dict
        The mapping, ``dv`` and ``counts`` as lists.

    Raises
    ------
    AnalysisInputError
        Naming the file and the key for an unknown key, a value of the wrong type, or a file that
        is not TOML.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from microg.analysis.tables import read_columns
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "columns.toml"
    >>> _ = path.write_text('subject = "pid"\\ndv = ["rt", "errors"]\\ncounts = "errors"\\n')
    >>> read_columns(path)
    {'subject': 'pid', 'dv': ['rt', 'errors'], 'counts': ['errors']}
    """
    try:
        mapping = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise AnalysisInputError(f"{path}: not a readable TOML file of column names ({error})") from None
    except RecursionError:
        raise AnalysisInputError(f"{path}: not a TOML file of column names: nested too deeply") from None
    for key, value in mapping.items():
        if key not in COLUMN_OPTIONS:
            raise AnalysisInputError(f"{path}: unknown key {key!r} (known: {', '.join(COLUMN_OPTIONS)})")
        listed = key in ("dv", "counts")
        names = [value] if listed and isinstance(value, str) else value
        if not (
            all(isinstance(n, str) for n in names) if listed and isinstance(names, list) else isinstance(value, str)
        ):
            kind = "a column name or a list of them" if listed else "a column name"
            raise AnalysisInputError(f"{path}: key {key!r} must be {kind}, not {value!r}")
        mapping[key] = names
    return mapping


def read_trials(path: str | Path, **columns) -> pd.DataFrame:
    """Read and check a trials table.

    Parameters
    ----------
    path : str or Path
        A CSV or Parquet file (:func:`read_table`).
    **columns
        Column names and rules passed to :func:`check_trials` (subject, group, within, interaction, dv,
        counts, completed, label).

    Returns
    -------
    pandas.DataFrame
        The checked table; errors name this file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from microg.analysis import read_trials
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "trials.csv"
    >>> _ = path.write_text("participant,group,interaction,object,time_s,attempts\\n"
    ...                     "P1,V,s,cube,inf,0\\nP2,B,s,ball,3.0,1\\n")
    >>> read_trials(path)
    Traceback (most recent call last):
    ...
    microg.analysis.tables.AnalysisInputError: ...trials.csv: column 'time_s' value inf is not finite (data row 1, ...)
    """
    return check_trials(read_table(path, text=text_columns(TRIAL_TEXT, columns)), source=str(path), **columns)


def read_questionnaire(path: str | Path, **columns) -> pd.DataFrame:
    """Read and check a questionnaire table.

    Parameters
    ----------
    path : str or Path
        A CSV or Parquet file (:func:`read_table`).
    **columns
        Column names passed to :func:`check_questionnaire` (subject, group, interaction, item, rating,
        label).

    Returns
    -------
    pandas.DataFrame
        The checked table; errors name this file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from microg.analysis import read_questionnaire
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "answers.csv"
    >>> _ = path.write_text("participant,interaction,item,rating\\nP1,s,ease,7\\n")
    >>> read_questionnaire(path)["rating"].tolist()
    [7]
    """
    return check_questionnaire(read_table(path, text=text_columns(QUESTIONNAIRE_TEXT, columns)), source=str(path),
                               **columns)


def text_columns(keys: Sequence[tuple[str, str]], columns: dict) -> list[str]:
    """The names of the identifying columns (``TRIAL_TEXT``, ``QUESTIONNAIRE_TEXT``) under ``columns``."""
    return [columns.get(key, default) for key, default in keys]


def repeated_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The rows that repeat an earlier row in every column, and the row each repeats.

    Parameters
    ----------
    table : pandas.DataFrame
        Any table (empty values count as equal).

    Returns
    -------
    pandas.DataFrame
        Columns ``row`` and ``copy_of``: data rows, 1 being the first row after the header.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.tables import repeated_rows
    >>> repeated_rows(pd.DataFrame({"p": ["a", "b", "a"], "t": [1.5, 2.0, 1.5]}))
       row  copy_of
    0    3        1
    """
    table = table.reset_index(drop=True)
    repeats = np.flatnonzero(table.duplicated(keep="first").to_numpy()) if len(table.columns) else []
    first: dict[int, int] = {}
    for row, value in enumerate(pd.util.hash_pandas_object(table, index=False).to_numpy() if len(repeats) else ()):
        first.setdefault(value, row)
    hashes = pd.util.hash_pandas_object(table.iloc[repeats], index=False).to_numpy() if len(repeats) else []
    return pd.DataFrame({"row": np.asarray(repeats, dtype=int) + 1,
                         "copy_of": np.array([first[h] for h in hashes], dtype=int) + 1})


def drop_repeated_rows(table: pd.DataFrame, source: str, drop: bool = True) -> tuple[pd.DataFrame, str | None]:
    """The table without the rows that repeat an earlier row in every column (a table pasted in twice,
    a row copied), and a sentence for the reader naming them; with ``drop`` False such rows are refused.

    Parameters
    ----------
    table : pandas.DataFrame
        A table as read (rows in file order).
    source : str
        How the messages name the table (its file).
    drop : bool
        Drop the repeated rows (True) or refuse them (False).

    Returns
    -------
    tuple of (pandas.DataFrame, str or None)
        The rows kept (index 0..n-1) and what was dropped (None when nothing was).

    Raises
    ------
    AnalysisInputError
        With ``drop`` False, naming the repeated rows and the rows they repeat.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.tables import drop_repeated_rows
    >>> kept, note = drop_repeated_rows(pd.DataFrame({"p": ["a", "b", "a"], "t": [1.5, 2.0, 1.5]}), "t.csv")
    >>> len(kept), note
    (2, 't.csv: 1 row repeated an earlier row in every column and was dropped (data row 3 repeats row 1)')
    """
    table = table.reset_index(drop=True)
    repeats = repeated_rows(table)
    if repeats.empty:
        return table, None
    n = len(repeats)
    listed = ", ".join(f"data row {r} repeats row {c}" for r, c in repeats.head(10).itertuples(index=False))
    listed += f" and {n - 10} more" if n > 10 else ""
    if not drop:
        raise AnalysisInputError(
            f"{source}: {n} row(s) repeat an earlier row in every column: {listed}. A row given twice counts twice "
            "in every mean and test; remove the copies, or drop them (microg report --drop-duplicates)"
        )
    kept = table.drop(index=repeats["row"] - 1).reset_index(drop=True)
    if n == 1:
        return kept, f"{source}: 1 row repeated an earlier row in every column and was dropped ({listed})"
    return kept, f"{source}: {n} rows repeated earlier rows in every column and were dropped ({listed})"


def check_trials(
    trials: pd.DataFrame,
    source: str = "trials table",
    *,
    subject: str = "participant",
    group: str = "group",
    within: str = "object",
    interaction: str = "interaction",
    dv: Sequence[str] = ("time_s", "attempts"),
    counts: Sequence[str] = ("attempts",),
    completed: str = "completed",
    label: str = "interaction_label",
    design: bool = True,
    signed: Sequence[str] = (),
) -> pd.DataFrame:
    """Check a trials table and return a copy with numeric measures, text labels and boolean flags.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task: ``subject``, ``group``, ``interaction``, ``within`` and the ``dv`` columns;
        optionally ``completed``, ``simulated``, ``withdrawn`` (True/False), ``phase`` and ``label``.
    source : str
        How the error messages name the table (its file).
    subject, group, within, interaction : str
        Columns of the participant id, the between factor, the within factor and the interaction model.
    dv : sequence of str
        The measures. Each must be empty or a finite number, 0 or more and at most
        ``LARGEST_VALUE``.
    counts : sequence of str
        The measures that count events (drops): whole numbers.
    completed : str
        Flag of finished tasks; a finished task must have a value of every measure that is not a
        count (an unfinished task has no completion time).
    label : str
        Optional column of each interaction model's label for readers; one label per interaction model.
    design : bool
        Require the mixed design: two groups or more and two ``within`` levels or more. A table
        that is only described (a task kind's, whose analysis says what it cannot test) passes
        with False.
    signed : sequence of str
        Measures that may be negative (a difference from the right value, as a send's
        ``release_speed_error``).

    Returns
    -------
    pandas.DataFrame
        The checked copy (index 0..n-1).

    Raises
    ------
    AnalysisInputError
        Naming the source, column, value and data row (1 = the first row after the header): a
        missing column, no rows, an empty label, a measure that is not a number, not finite, negative
        or absurdly large, a fractional count, a finished task without a measure, a participant in two
        groups, an interaction with two labels, fewer than two groups or fewer than two ``within`` levels
        (with ``design``);
        rows that repeat an earlier row in every column (:func:`drop_repeated_rows` drops them first
        where that is wanted), and two different rows of one exported task (same participant,
        ``session`` and ``task_index``).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import check_trials
    >>> trials = pd.DataFrame({"pid": ["a", "b"], "cond": ["x", "y"], "tool": "s", "shape": "cube",
    ...                        "rt": [1.5, 1e308]})
    >>> check_trials(trials, subject="pid", group="cond", interaction="tool", within="shape", dv=["rt"], counts=[])
    Traceback (most recent call last):
    ...
    microg.analysis.tables.AnalysisInputError: trials table: column 'rt' value 1e+308 is larger than 1e+12 ...
    """
    trials, _ = drop_repeated_rows(trials, source, drop=False)
    _require_columns(trials, [subject, group, interaction, within, *dv], source)
    if trials.empty:
        raise AnalysisInputError(f"{source}: no trials (the table has a header but no rows)")
    key = [subject] + [column for column in TASK_KEY if column in trials.columns]
    if {"session", "task_index"} <= set(key):
        twice = trials.duplicated(key, keep=False)
        if twice.any():
            rows = np.flatnonzero(twice.to_numpy())
            first = trials.iloc[rows[0]]
            same = twice & (trials[key] == first[key]).all(axis=1)
            numbers = " and ".join(str(r + 1) for r in np.flatnonzero(same.to_numpy()))
            task = ", ".join(f"{column} {_plain(first[column])!r}" for column in key)
            raise AnalysisInputError(
                f"{source}: data rows {numbers} are the same task ({task}) with different values: each planned task "
                "has one row; keep the right one"
            )
    out = trials.copy()
    for column in (subject, group, interaction, within):
        out[column] = _labels(trials, column, source, subject)
    for measure in dv:
        out[measure] = _measure(trials, measure, source, subject, whole=measure in counts, signed=measure in signed)
    for flag in FLAG_COLUMNS:
        if flag in trials.columns:
            out[flag] = _flags(trials, flag, source, subject)
    if completed in out.columns:
        for measure in (m for m in dv if m not in counts):
            untimed = out[completed] & out[measure].isna()
            _require(out, completed, untimed, source, f"is True but {measure} is empty", subject)
    if label in trials.columns:
        out[label] = _labels(trials, label, source, subject)
        _check_one_each(out, interaction, label, source)
    _check_one_each(out, subject, group, source)
    if design:
        _require_levels(out, group, source, "a mixed ANOVA needs at least two groups")
        _require_levels(out, within, source, "a within-participant comparison needs at least two levels")
    return out


def check_training(
    trials: pd.DataFrame,
    source: str = "trials table",
    *,
    subject: str = "participant",
    session: str = "session",
    session_index: str = "session_index",
    task_index: str = "task_index",
    task_in_phase: str = "task_in_phase",
    criterion: str = "criterion_met",
) -> pd.DataFrame:
    """Check a training program's session columns of a trials table (checked by :func:`check_trials`)
    and return a copy with them typed.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task with ``session`` (the session's name), ``session_index`` (its 1-based
        order for the participant) and ``task_index``; optionally ``task_in_phase`` (the task's
        1-based place in its phase) and ``criterion`` (True, False, or empty for a phase without a
        criterion).
    source : str
        How the error messages name the table (its file).
    subject, session, session_index, task_index, task_in_phase, criterion : str
        The column names.

    Returns
    -------
    pandas.DataFrame
        The checked copy: ``session`` text, ``session_index`` and ``task_in_phase`` integers,
        ``criterion`` nullable booleans.

    Raises
    ------
    AnalysisInputError
        Naming the source, column, value and data row: a missing column, an empty session name, a
        session index or a place in the phase that is not a whole number of 1 or more, a criterion
        that is not True, False or empty, a participant's session with two indexes or an index
        with two sessions.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.tables import check_training
    >>> trials = pd.DataFrame({"participant": "P1", "session": ["pre", "train1"], "session_index": [1, 0],
    ...                        "task_index": [0, 0]})
    >>> check_training(trials)
    Traceback (most recent call last):
    ...
    microg.analysis.tables.AnalysisInputError: trials table: column 'session_index' value 0 is not a whole number \
of 1 or more (data row 2, participant 'P1')
    """
    trials = trials.reset_index(drop=True)
    _require_columns(trials, [subject, session, session_index, task_index], source)
    out = trials.copy()
    out[session] = _labels(trials, session, source, subject)
    for column in (session_index, task_in_phase):
        if column not in trials.columns:
            continue
        values = _numbers(trials, column, source, subject)
        bad = values.isna() | (values < 1) | (values != np.round(values))
        _require(trials, column, bad, source, "is not a whole number of 1 or more", subject)
        out[column] = values.astype(int)
    out[task_index] = _numbers(trials, task_index, source, subject)
    _require(trials, task_index, out[task_index].isna(), source, "is empty", subject)
    if criterion in trials.columns:
        raw = trials[criterion]
        blank = raw.isna() | (raw.astype(str).str.strip() == "")
        words = {"true": True, "false": False, "1": True, "0": False, "1.0": True, "0.0": False}
        mapped = raw.astype(str).str.strip().str.lower().map(words)
        _require(trials, criterion, mapped.isna() & ~blank, source, "is not True, False or empty", subject)
        out[criterion] = mapped.where(~blank).astype("boolean")
    for key, column in ((session, session_index), (session_index, session)):
        per_participant = out.groupby([subject, key], observed=True)[column].nunique()
        several = per_participant[per_participant > 1]
        if len(several):
            who, value = several.index[0]
            names = " and ".join(repr(_plain(v)) for v in sorted(out.loc[(out[subject] == who) & (out[key] == value),
                                                                          column].unique()))
            raise AnalysisInputError(f"{source}: {subject} {who!r} has {names} in column {column!r} for {key} "
                                     f"{_plain(value)!r}; one is allowed")
    return out


def check_questionnaire(
    answers: pd.DataFrame,
    source: str = "questionnaire table",
    *,
    subject: str = "participant",
    group: str = "group",
    interaction: str = "interaction",
    item: str = "item",
    rating: str = "rating",
    label: str = "interaction_label",
) -> pd.DataFrame:
    """Check a questionnaire table and return a copy with integer ratings in 0-10.

    Parameters
    ----------
    answers : pandas.DataFrame
        One row per participant, interaction model and item: ``subject``, ``interaction``, ``item``, ``rating``;
        optionally ``group``, ``label``, ``simulated`` and ``withdrawn``.
    source : str
        How the error messages name the table (its file).
    subject, group, interaction, item, rating, label : str
        The column names.

    Returns
    -------
    pandas.DataFrame
        The checked copy.

    Raises
    ------
    AnalysisInputError
        For a missing column, no rows, an empty label, a rating that is not an integer in 0-10, an
        item rated twice by one participant for one interaction model, a participant in two groups or
        an interaction with two labels.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import check_questionnaire
    >>> answers = pd.DataFrame({"participant": ["P1"], "interaction": ["s"], "item": ["ease"], "rating": [11]})
    >>> check_questionnaire(answers)
    Traceback (most recent call last):
    ...
    microg.analysis.tables.AnalysisInputError: questionnaire table: column 'rating' value 11 is not an integer ...
    """
    answers = answers.reset_index(drop=True)
    _require_columns(answers, [subject, interaction, item, rating], source)
    if answers.empty:
        raise AnalysisInputError(f"{source}: no ratings (the table has a header but no rows)")
    out = answers.copy()
    for column in (subject, interaction, item):
        out[column] = _labels(answers, column, source, subject)
    values = _numbers(answers, rating, source, subject)
    _require(out, rating, values.isna(), source, "is empty", subject)
    low, high = RATING_RANGE
    invalid = (values < low) | (values > high) | (values != np.round(values))
    _require(out, rating, invalid, source, f"is not an integer rating in {low}-{high}", subject)
    out[rating] = values.astype(int)
    for flag in FLAG_COLUMNS:
        if flag in answers.columns:
            out[flag] = _flags(answers, flag, source, subject)
    for column, key in ((group, subject), (label, interaction)):
        if column in answers.columns:
            out[column] = _labels(answers, column, source, subject)
            _check_one_each(out, key, column, source)
    repeated = out.duplicated([subject, interaction, item], keep="first")
    if repeated.any():
        row = out[repeated].iloc[0]
        raise AnalysisInputError(
            f"{source}: {subject} {row[subject]!r} rated {item} {row[item]!r} for {interaction} "
            f"{row[interaction]!r} more than once (data row {int(row.name) + 1})"
        )
    return out


def check_same_groups(trials: pd.DataFrame, answers: pd.DataFrame, subject: str = "participant", group: str = "group"):
    """Refuse tables that put a participant in different groups (both tables checked already)."""
    if group not in answers.columns:
        return
    trial_groups = trials.drop_duplicates(subject).set_index(subject)[group]
    answer_groups = answers.drop_duplicates(subject).set_index(subject)[group]
    shared = trial_groups.index.intersection(answer_groups.index)
    differ = trial_groups[shared] != answer_groups[shared]
    if differ.any():
        who = differ[differ].index[0]
        raise AnalysisInputError(
            f"{subject} {who!r} is in {group} {trial_groups[who]!r} in the trials table but in {group} "
            f"{answer_groups[who]!r} in the questionnaire table (column {group!r})"
        )


def is_simulated(table: pd.DataFrame | None) -> bool:
    """True when any row of the table is flagged as simulated."""
    return table is not None and "simulated" in table.columns and bool(table["simulated"].any())


def withdrawn(table: pd.DataFrame | None, subject: str = "participant") -> set[str]:
    """Participants flagged as withdrawn (their data stay in the log, out of the analysis)."""
    if table is None or "withdrawn" not in table.columns:
        return set()
    return set(table.loc[table["withdrawn"], subject])


def exclude_phases(trials: pd.DataFrame, phases: Sequence[str], phase: str = "phase") -> pd.DataFrame:
    """Trials outside the named phases (e.g. training, which only one group does); case-insensitive.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.tables import exclude_phases
    >>> exclude_phases(pd.DataFrame({"phase": ["training", "stage1"]}), ["Training"])["phase"].tolist()
    ['stage1']
    """
    if phase not in trials.columns or not phases:
        return trials
    named = trials[phase].astype(str).str.lower().isin([p.lower() for p in phases])
    return trials[~named]


def participant_cells(
    trials: pd.DataFrame,
    dv: str,
    subject: str = "participant",
    group: str = "group",
    interaction: str = "interaction",
    within: str = "object",
    completed: str | None = None,
) -> pd.DataFrame:
    """One value per participant, group, interaction model and ``within`` level: the mean over that cell's trials.

    Parameters
    ----------
    trials : pandas.DataFrame
        Checked trials (:func:`check_trials`).
    dv : str
        The measure.
    subject, group, interaction, within : str
        The columns that identify a cell.
    completed : str, optional
        A flag column: only tasks flagged True count. Give it for a measure of finished tasks
        (completion time: an unfinished task has no time, not a zero); leave it out for a measure
        every task has (drops: a drop is a drop, finished or not).

    Returns
    -------
    pandas.DataFrame
        Columns ``subject, group, interaction, within, dv``; rows without a value are left out.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import participant_cells
    >>> trials = pd.DataFrame({"participant": "P1", "group": "V", "interaction": "s", "object": "cube",
    ...                        "completed": [True, False, True], "time_s": [10.0, None, 20.0]})
    >>> participant_cells(trials, "time_s", completed="completed")
      participant group interaction object  time_s
    0          P1     V           s   cube    15.0
    """
    rows = trials if completed is None else trials[trials[completed].astype(bool)]
    rows = rows[rows[dv].notna()]
    keys = [subject, group, interaction, within]
    return rows.groupby(keys, observed=True, sort=True)[dv].mean().reset_index()


def complete_cases(
    cells: pd.DataFrame, dv: str, within: str, subject: str, levels: Sequence[str] | None = None
) -> pd.DataFrame:
    """The cells of the participants with a value of ``dv`` in every level of ``within``.

    Parameters
    ----------
    cells : pandas.DataFrame
        Long table, one row per participant and level.
    dv, within, subject : str
        Measure, within factor and participant columns.
    levels : sequence of str, optional
        The levels required (default: every level present in ``cells``).

    Returns
    -------
    pandas.DataFrame
        The complete participants' rows of those levels. :func:`incomplete_cases` says who is left
        out and why.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import complete_cases
    >>> cells = pd.DataFrame({"p": ["a", "a", "b"], "o": ["x", "y", "x"], "v": [1.0, 2.0, 3.0]})
    >>> complete_cases(cells, "v", "o", "p")["p"].tolist()
    ['a', 'a']
    """
    left_out = incomplete_cases(cells, dv, within, subject, levels)[subject]
    levels = sorted(cells[within].unique()) if levels is None else list(levels)
    kept = cells[~cells[subject].isin(left_out) & cells[within].isin(levels)]
    return kept.reset_index(drop=True)


def incomplete_cases(
    cells: pd.DataFrame, dv: str, within: str, subject: str, levels: Sequence[str] | None = None
) -> pd.DataFrame:
    """The participants without a value of ``dv`` in some level of ``within``, and why.

    Parameters
    ----------
    cells, dv, within, subject, levels
        As for :func:`complete_cases`.

    Returns
    -------
    pandas.DataFrame
        Columns ``subject`` and ``reason`` (e.g. "no v for o y").

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import incomplete_cases
    >>> cells = pd.DataFrame({"p": ["a", "a", "b"], "o": ["x", "y", "x"], "v": [1.0, 2.0, 3.0]})
    >>> incomplete_cases(cells, "v", "o", "p")
       p       reason
    0  b  no v for o y
    """
    levels = sorted(cells[within].unique()) if levels is None else list(levels)
    present = cells[cells[dv].notna()].groupby(subject, observed=True)[within].agg(set)
    reasons = {}
    for who in cells[subject].unique():
        missing = [str(level) for level in levels if level not in present.get(who, set())]
        if missing:
            reasons[who] = f"no {dv} for {within} {', '.join(missing)}"
    return pd.DataFrame({subject: list(reasons), "reason": list(reasons.values())})


def stars(p: float) -> str:
    """Significance marks: * p < .05, ** p < .01, *** p < .001.

    Examples
    --------
    >>> from microg.analysis.tables import stars
    >>> stars(0.004), stars(0.2)
    ('**', '')
    """
    if not np.isfinite(p):
        return ""
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else ""


def _require_columns(table: pd.DataFrame, columns: Sequence[str], source: str) -> None:
    for column in columns:
        if column not in table.columns:
            present = ", ".join(map(str, table.columns))
            raise AnalysisInputError(f"{source}: missing column {column!r} (columns present: {present})")


def _labels(table: pd.DataFrame, column: str, source: str, subject: str) -> pd.Series:
    values = table[column]
    _require(table, column, values.isna() | (values.astype(str).str.strip() == ""), source, "is empty", subject)
    return values.astype(str)


def _numbers(table: pd.DataFrame, column: str, source: str, subject: str) -> pd.Series:
    raw = table[column]
    if pd.api.types.is_bool_dtype(raw):
        _require(table, column, pd.Series(True, index=raw.index), source, "is not a number", subject)
    numbers = pd.to_numeric(raw, errors="coerce").astype(float)
    blank = raw.isna() | (raw.astype(str).str.strip() == "")
    _require(table, column, numbers.isna() & ~blank, source, "is not a number", subject)
    return numbers


def _measure(table: pd.DataFrame, column: str, source: str, subject: str, whole: bool, signed: bool) -> pd.Series:
    values = _numbers(table, column, source, subject)
    _require(table.assign(**{column: values}), column, np.isinf(values), source, "is not finite", subject)
    too_large = values.abs() > LARGEST_VALUE
    _require(table, column, too_large, source, f"is larger than {LARGEST_VALUE:g}", subject)
    if not signed:
        _require(table, column, values < 0, source, "is negative", subject)
    if whole:
        fractional = values.notna() & (values != np.round(values))
        _require(table, column, fractional, source, "is not a count (a whole number)", subject)
    return values


def _flags(table: pd.DataFrame, column: str, source: str, subject: str) -> pd.Series:
    raw = table[column]
    if pd.api.types.is_bool_dtype(raw) and not raw.isna().any():
        return raw.astype(bool)
    words = {"true": True, "false": False, "1": True, "0": False, "1.0": True, "0.0": False}
    mapped = raw.astype(str).str.strip().str.lower().map(words)
    _require(table, column, mapped.isna(), source, "is not True or False", subject)
    return mapped.astype(bool)


def _require(table: pd.DataFrame, column: str, bad: pd.Series, source: str, what: str, subject: str) -> None:
    if not bad.any():
        return
    row = int(np.flatnonzero(bad.to_numpy())[0])
    where = f"data row {row + 1}"
    if subject in table.columns and column != subject:
        where += f", {subject} {table[subject].iloc[row]!r}"
    raise AnalysisInputError(f"{source}: column {column!r} value {_plain(table[column].iloc[row])!r} {what} ({where})")


def _plain(value):
    """A table's value as Python writes it (5, not np.int64(5))."""
    return value.item() if isinstance(value, np.generic) else value


def _check_one_each(table: pd.DataFrame, key: str, column: str, source: str) -> None:
    values = table.groupby(key, observed=True)[column].unique()
    several = values[values.map(len) > 1]
    if len(several):
        who = several.index[0]
        names = " and ".join(repr(v) for v in sorted(several.iloc[0]))
        raise AnalysisInputError(f"{source}: {key} {who!r} has {names} in column {column!r}; one is allowed")


def _require_levels(table: pd.DataFrame, column: str, source: str, why: str) -> None:
    levels = table[column].unique()
    if len(levels) < 2:
        raise AnalysisInputError(f"{source}: column {column!r} has the single value {levels[0]!r}; {why}")
