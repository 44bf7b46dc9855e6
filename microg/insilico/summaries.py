"""Summary statistics of a study's trials table: the numbers a population is calibrated to.

One function (``summarise``) computes them, for a pilot's trials and for every simulated study
alike. Each number is a ``Statistic``: a measure of a task, where it is read (a selection of
group, phase, interaction model and object), and what is taken over the participants:

- ``mean`` and ``sd``: the mean and the SD (ddof 1) over participants of each participant's mean
  of the measure over the selected tasks;
- ``ratio``: the mean over participants in the selection over the mean in ``versus`` (an effect:
  beginners over veterans, the flat cuboid over the cube);
- ``paired``: the same ratio over the same people: the participants with tasks in both selections
  only (a training program's retest over its post-test: the trainees' own change across the gap,
  free of most of the differences between them);
- ``slope``: the practice curve, the mean over participants of the slope of log time against
  log(1 + tasks done before) over their completed tasks (the power law of practice: -rate).

The measures: ``time_s`` (completed tasks only, as the report reads it), ``attempts`` (every task
that ran) and ``completed`` (the fraction of tasks that ran and were completed). Withdrawn
participants and tasks that never ran are left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

MEASURES = ("time_s", "attempts", "completed")
STATISTICS = ("mean", "sd", "ratio", "paired", "slope")
WHERE = ("group", "session", "phase", "interaction", "object")
"""The columns a selection may name, in the order keys show them."""
RESOLUTION = {"time_s": 0.5, "attempts": 0.05, "completed": 0.02, "slope": 0.02, "ratio": 0.02}
"""The smallest standard error a fitted number is given (its unit; ratios on the log scale): a
difference below it does not matter, and a number that does not vary in the data (every task
completed, no drop at all) still weighs in the fit."""


@dataclass(frozen=True)
class Statistic:
    """One summary number of a trials table (see the module docstring)."""

    measure: str
    statistic: str
    where: tuple[tuple[str, str], ...] = ()
    """(column, value) pairs of the selection; empty: every task."""
    versus: tuple[tuple[str, str], ...] = ()
    """A ratio's denominator selection."""

    @property
    def compares(self) -> bool:
        """Whether it is a ratio of two selections (``ratio`` or ``paired``), compared on the log scale."""
        return self.statistic in ("ratio", "paired")

    @property
    def key(self) -> str:
        """How calibration.csv, the printout and ``--hold-out`` name it, e.g.
        ``time_s.mean[group=V,phase=stage1,object=C]`` or ``attempts.ratio[group=B]/[group=V]``."""
        text = f"{self.measure}.{self.statistic}[{_selection(self.where)}]"
        return text + (f"/[{_selection(self.versus)}]" if self.compares else "")


def _selection(where: tuple[tuple[str, str], ...]) -> str:
    return ",".join(f"{column}={value}" for column, value in where)


def participant_cells(trials: pd.DataFrame) -> pd.DataFrame:
    """Each participant's tasks as they count: one row per task that ran, with the participant's
    group, the task's session (a training program's; ``main`` otherwise) and its place among the
    participant's sessions (``session_index``, from 1; without that column, the order in which the
    sessions first appear in the table), phase, interaction model, object, ``tasks_done`` (tasks
    before it in the session) and its ``time_s`` (NaN unless completed), ``attempts`` and
    ``completed`` (0 or 1).

    Examples
    --------
    >>> import pandas as pd
    >>> trials = pd.DataFrame({"participant": ["P1", "P1"], "group": ["B", "B"], "phase": ["stage1"] * 2,
    ...                        "interaction": ["m", "m"], "object": ["C", "F"], "completed": [True, False],
    ...                        "time_s": [20.0, None], "attempts": [0, 2], "status": ["completed", "timeout"],
    ...                        "task_index": [0, 1], "withdrawn": [False, False]})
    >>> participant_cells(trials)[["object", "time_s", "attempts", "completed"]].to_string(index=False)
    'object  time_s  attempts  completed\\n     C    20.0       0.0        1.0\\n     F     NaN       2.0        0.0'
    """
    ran = trials
    if "withdrawn" in ran:
        ran = ran[~ran["withdrawn"].fillna(False).astype(bool)]
    if "status" in ran:
        ran = ran[~ran["status"].isin(["not_run", "skipped"])]
    completed = ran["completed"].fillna(False).astype(bool)
    session = ran["session"].astype(str) if "session" in ran else pd.Series("main", index=ran.index)
    order = (pd.to_numeric(ran["session_index"]).astype(float) if "session_index" in ran
             else session.map({name: i + 1.0 for i, name in enumerate(session.unique())}))
    return pd.DataFrame({
        "participant": ran["participant"].astype(str),
        "group": ran["group"].astype(str),
        "session": session,
        "session_index": order,
        "phase": ran["phase"].astype(str),
        "interaction": ran["interaction"].astype(str),
        "object": ran["object"].astype(str),
        "tasks_done": pd.to_numeric(ran["task_index"]).astype(float),
        "time_s": pd.to_numeric(ran["time_s"]).astype(float).where(completed),
        "attempts": pd.to_numeric(ran["attempts"]).astype(float),
        "completed": completed.astype(float),
    }).reset_index(drop=True)  # fmt: skip


def participant_values(cells: pd.DataFrame, statistics) -> pd.DataFrame:
    """One row per participant (index), one column per number a statistic averages over
    participants (``Statistic.key``, and ``KEY/versus`` for a ratio's denominator); NaN where the
    participant has no task in the selection."""
    people, person = np.unique(cells["participant"].to_numpy(dtype=str), return_inverse=True)
    masks: dict = {}

    def selected(where) -> np.ndarray:
        chosen = np.ones(len(cells), dtype=bool)
        for pair in where:
            if pair not in masks:
                masks[pair] = (cells[pair[0]] == pair[1]).to_numpy()
            chosen &= masks[pair]
        return chosen

    def means(where, measure: str) -> np.ndarray:
        values = cells[measure].to_numpy()
        chosen = selected(where) & ~np.isnan(values)
        count = np.bincount(person[chosen], minlength=len(people))
        total = np.bincount(person[chosen], weights=values[chosen], minlength=len(people))
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(count > 0, total / count, np.nan)

    columns = {}
    for s in statistics:
        if s.statistic == "slope":
            columns[s.key] = _slopes(cells[selected(s.where)]).reindex(people).to_numpy()
            continue
        columns[s.key] = means(s.where, s.measure)
        if s.compares:
            columns[f"{s.key}/versus"] = means(s.versus, s.measure)
    return pd.DataFrame(columns, index=pd.Index(people, name="participant"))


def _slopes(cells: pd.DataFrame) -> pd.Series:
    """Each participant's least-squares slope of log time on log(1 + tasks done), over completed
    tasks (NaN with fewer than two distinct points)."""
    done = cells.dropna(subset=["time_s"])
    done = done[done["time_s"] > 0]
    x, y = np.log1p(done["tasks_done"].to_numpy()), np.log(done["time_s"].to_numpy())
    frame = pd.DataFrame({"participant": done["participant"].to_numpy(), "x": x, "y": y})
    slopes = {}
    for person, rows in frame.groupby("participant"):
        dx = rows["x"] - rows["x"].mean()
        spread = float((dx * dx).sum())
        slopes[person] = float((dx * (rows["y"] - rows["y"].mean())).sum()) / spread if spread > 0 else np.nan
    return pd.Series(slopes, dtype=float)


def aggregate(values: pd.DataFrame, statistics) -> np.ndarray:
    """Each statistic's value from ``participant_values`` (NaN where it is undefined: no
    participant, or fewer than two for an SD)."""
    out = np.full(len(statistics), np.nan)
    for i, s in enumerate(statistics):
        column = values[s.key].dropna()
        if s.statistic == "sd":
            out[i] = column.std(ddof=1) if len(column) >= 2 else np.nan
        elif s.compares:
            denominator = values[f"{s.key}/versus"].dropna()
            if s.statistic == "paired":
                both = column.index.intersection(denominator.index)
                column, denominator = column[both], denominator[both]
            if len(column) and len(denominator) and denominator.mean() > 0:
                out[i] = column.mean() / denominator.mean()
        elif len(column):
            out[i] = column.mean()
    return out


def summarise(trials: pd.DataFrame, statistics) -> pd.DataFrame:
    """The summary statistics of a trials table.

    Parameters
    ----------
    trials : pandas.DataFrame
        A trials table (the columns of ``microg.schema.TRIALS``: participant, group, phase,
        interaction, object, completed, time_s, attempts, task_index; status and withdrawn when
        present).
    statistics : sequence of Statistic
        What to compute.

    Returns
    -------
    pandas.DataFrame
        One row per statistic: ``key``, ``measure``, ``statistic``, ``value`` (NaN where undefined)
        and ``n`` (participants it was computed from).

    Examples
    --------
    >>> import pandas as pd
    >>> trials = pd.DataFrame({"participant": ["P1", "P2", "P3"], "group": ["B", "B", "V"],
    ...                        "phase": "stage1", "interaction": "m", "object": "C", "completed": True,
    ...                        "time_s": [20.0, 30.0, 10.0], "attempts": [1, 0, 0], "task_index": 0})
    >>> wanted = [Statistic("time_s", "mean", (("group", "B"),)), Statistic("time_s", "sd", (("group", "B"),)),
    ...           Statistic("time_s", "ratio", (("group", "B"),), (("group", "V"),))]
    >>> summarise(trials, wanted)[["value", "n"]].round(3).to_dict("list")
    {'value': [25.0, 7.071, 2.5], 'n': [2, 2, 2]}
    """
    statistics = list(statistics)
    values = participant_values(participant_cells(trials), statistics)
    return pd.DataFrame({
        "key": [s.key for s in statistics],
        "measure": [s.measure for s in statistics],
        "statistic": [s.statistic for s in statistics],
        "value": aggregate(values, statistics),
        "n": [int(values[s.key].notna().sum()) for s in statistics],
    })  # fmt: skip


def study_statistics(trials: pd.DataFrame) -> list[Statistic]:
    """The statistics a pilot's trials show: per group x phase x object the mean and SD of time and
    attempts, per group x phase the completion rate, and per group the practice slope (only where
    at least two participants have a value, so that every SD is defined). A training program's
    cells are per group x session x phase instead (over its objects): each session's level is what
    carries practice kept and lost across days; and a phase a group runs in several sessions gives
    its time in each session over its time in the session before, the same trainees' (``session_ratios``)."""
    cells = participant_cells(trials)
    program = cells["session"].nunique() > 1
    wanted = []
    fine = ["group", "session", "phase"] if program else ["group", "phase", "object"]
    for key, rows in cells.groupby(fine, sort=True):
        named = dict(zip(fine, key))
        where = tuple((column, named[column] if column != "interaction" else rows["interaction"].iloc[0])
                      for column in WHERE if column in named or column == "interaction")
        for measure in ("time_s", "attempts"):
            if rows.dropna(subset=[measure])["participant"].nunique() >= 2:
                wanted += [Statistic(measure, "mean", where), Statistic(measure, "sd", where)]
    if program:
        wanted += session_ratios(cells)
    else:
        for (group, phase), rows in cells.groupby(["group", "phase"], sort=True):
            if rows["participant"].nunique() >= 2:
                where = (("group", group), ("phase", phase), ("interaction", rows["interaction"].iloc[0]))
                wanted.append(Statistic("completed", "mean", where))
    for group, rows in cells.groupby("group", sort=True):
        if _slopes(rows).notna().sum() >= 2:
            wanted.append(Statistic("time_s", "slope", (("group", group),)))
    return wanted


def session_ratios(cells: pd.DataFrame) -> list[Statistic]:
    """For each group and each phase it runs in more than one session: the ``paired`` ratio of the
    phase's time in each session over its time in the group's session before that ran it (a
    retest over the post-test, a training day over the one before), where at least two participants
    have a time in both: the trainees' own change across the gap (how much practice they kept is
    the forgetting's signal), free of most of the differences between people that the sessions'
    levels carry."""
    done = cells.dropna(subset=["time_s"])
    wanted = []
    for (group, phase), rows in done.groupby(["group", "phase"], sort=True):
        order = rows.groupby("session")["session_index"].min().sort_values().index
        people = rows.groupby("session")["participant"].agg(set)
        interaction = rows["interaction"].iloc[0]
        for before, after in zip(order[:-1], order[1:]):
            if len(people[before] & people[after]) >= 2:
                cell = [(("group", group), ("session", session), ("phase", phase), ("interaction", interaction))
                        for session in (after, before)]
                wanted.append(Statistic("time_s", "paired", *cell))
    return wanted


def bootstrap_se(trials: pd.DataFrame, statistics, seed: int, resamples: int = 200) -> np.ndarray:
    """Each statistic's standard error: its SD over ``resamples`` resamplings of the participants
    (with replacement, within each group), floored at ``RESOLUTION``."""
    statistics = list(statistics)
    cells = participant_cells(trials)
    values = participant_values(cells, statistics)
    groups = cells.drop_duplicates("participant").set_index("participant")["group"].reindex(values.index)
    members = [np.flatnonzero((groups == g).to_numpy()) for g in sorted(groups.unique())]
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _BOOTSTRAP_STREAM]))
    draws = np.empty((resamples, len(statistics)))
    for b in range(resamples):
        rows = np.concatenate([rng.choice(m, size=len(m)) for m in members])
        draws[b] = aggregate(values.iloc[rows].reset_index(drop=True), statistics)
    kinds = [("ratio" if s.compares else "slope" if s.statistic == "slope" else s.measure) for s in statistics]
    logged = np.array([s.compares for s in statistics])
    with np.errstate(divide="ignore", invalid="ignore"):
        draws[:, logged] = np.log(draws[:, logged])
        spread = np.nanstd(draws, axis=0, ddof=1)
    floor = np.array([RESOLUTION[kind] for kind in kinds])
    return np.fmax(np.nan_to_num(spread, nan=0.0), floor)


_BOOTSTRAP_STREAM = 0x4253
