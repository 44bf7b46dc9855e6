"""Effects estimated from a pilot study's trials, and the participant values a design reads from any
study's trials (a pilot's, or an in-silico study's).

How the estimates are made (also printed by ``microg power --pilot`` and written to its output):

1. Each participant's value in a cell is the mean of the measure over the cell's tasks, as the
   report computes it: completed tasks only for a time (an unfinished task has no time), every
   task for a count (attempts); training and withdrawn participants are left out. For the interaction
   design, a participant's value per interaction model is the mean over the objects.
2. Participants without a value in every level are left out (complete cases, as the report).
3. Means: the mean per group and level. Covariance: the pooled within-group covariance of the
   participants' values (residuals from their group's means, N - groups degrees of freedom): the
   covariance the report's ANOVA model estimates; it is used for every group. Its SDs and
   correlations are shown; no compound symmetry is imposed, so a pilot's departure from sphericity
   carries into the Monte Carlo power (where the report's Greenhouse-Geisser correction applies).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from microg.power.design import Design, PowerInputError
from microg.power.effects import Effects

COUNTS = ("attempts",)
"""Measures that count events: every task counts, finished or not (the report's rule)."""
EXCLUDED_PHASES = ("training",)
SUBJECT = "participant"


@dataclass(frozen=True)
class PilotEstimate:
    """Effects from a pilot, with what they were estimated from.

    ``cells``: one row per group and level (n, mean, SD within the group); ``covariance``: the pooled
    covariance (levels x levels); ``method``: how, in words.
    """

    effects: Effects
    cells: pd.DataFrame
    covariance: pd.DataFrame
    method: str

    @property
    def correlations(self) -> pd.DataFrame:
        sd = np.sqrt(np.diag(self.covariance.to_numpy()))
        return self.covariance / np.outer(sd, sd)

    def describe(self) -> str:
        """The estimates as text: how, cell means and SDs, the pooled SDs and correlations."""
        sd = pd.Series(np.sqrt(np.diag(self.covariance.to_numpy())), index=self.covariance.index, name="pooled SD")
        return "\n".join([
            self.method, "",
            self.cells.to_string(index=False, float_format=lambda v: f"{v:.4g}"), "",
            sd.to_frame().T.to_string(float_format=lambda v: f"{v:.4g}"), "",
            "pooled correlations:", self.correlations.to_string(float_format=lambda v: f"{v:.3f}"),
        ])  # fmt: skip


def design_cells(trials: pd.DataFrame, design: Design, measure: str, interaction: str, source: str) -> pd.DataFrame:
    """Each participant's value per level of the design (steps 1-2 of the module docstring).

    Parameters
    ----------
    trials : pandas.DataFrame
        An exported trials table (group and object codes as the protocol gives them).
    design : Design
        The design; its codes map the table's groups and objects to names.
    measure : str
        The measure column (``time_s`` or ``attempts``).
    interaction : str
        The interaction model whose tasks are read (``within="object"``); the interaction design reads
        every phase's.
    source : str
        How messages name the table.

    Returns
    -------
    pandas.DataFrame
        Columns ``participant``, ``design.between``, ``design.within``, ``value`` (names, not codes),
        complete cases only.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> from microg.power import design_from_protocol
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> trials = pd.DataFrame({"participant": ["P1"] * 3 + ["P2"] * 3, "group": ["V"] * 3 + ["B"] * 3,
    ...                        "interaction": "impulse_penetration", "object": ["C", "F", "L"] * 2,
    ...                        "completed": True, "time_s": [40.0, 50, 60, 45, 55, 65], "attempts": 0})
    >>> design_cells(trials, design, "time_s", "impulse_penetration", "trials.csv").head(3)
      participant    group       object  value
    0          P1  veteran         cube   40.0
    1          P1  veteran  flat_cuboid   50.0
    2          P1  veteran  long_cuboid   60.0
    """
    from microg.analysis import check_trials, complete_cases, participant_cells
    from microg.analysis.tables import exclude_phases, withdrawn

    d = design
    checked = check_trials(trials, source, dv=[measure], counts=[m for m in COUNTS if m == measure])
    checked = exclude_phases(checked, EXCLUDED_PHASES)
    checked = checked[~checked[SUBJECT].isin(withdrawn(checked, SUBJECT))]
    checked = checked.assign(group=_names(checked, "group", d.group_codes, source, "group"),
                             object=_names(checked, "object", d.level_codes, source, "object")
                             if d.within == "object" else checked["object"])  # fmt: skip
    if interaction not in set(checked["interaction"]):
        raise PowerInputError(f"{source}: column 'interaction' has no value {interaction!r} "
                              f"(values: {', '.join(sorted(set(checked['interaction'])))})")
    finished = "completed" if measure not in COUNTS and "completed" in checked.columns else None
    if d.within == "object":
        rows = checked[checked["interaction"] == interaction]
        cells = participant_cells(rows, measure, completed=finished)
    else:
        # only to refuse an interaction model the protocol lacks
        _names(checked, "interaction", d.level_codes, source, "interaction")
        per_object = participant_cells(checked, measure, completed=finished)
        objects = sorted(checked["object"].unique())
        complete = per_object.groupby([SUBJECT, "interaction"])["object"].transform("nunique") == len(objects)
        cells = (per_object[complete].groupby([SUBJECT, "group", "interaction"], observed=True)[measure].mean()
                 .reset_index())
    cells = complete_cases(cells, measure, d.within, SUBJECT, d.levels)
    cells = cells.rename(columns={measure: "value"})[[SUBJECT, "group", d.within, "value"]]
    order = {level: i for i, level in enumerate(d.levels)}
    return cells.sort_values([SUBJECT, d.within], key=lambda c: c.map(order) if c.name == d.within else c,
                             ignore_index=True)  # fmt: skip


def pilot_effects(path: str | Path, design: Design, measure: str = "time_s",
                  interaction: str | None = None) -> PilotEstimate:
    """Estimate the effects from a pilot: an exported trials table (CSV or Parquet) or a study
    folder (read with ``microg.study.export.read_tables``).

    Parameters
    ----------
    path : str or Path
        The pilot's trials file, study folder or export folder.
    design : Design
        The design to estimate for.
    measure : str
        The measure (``time_s`` or ``attempts``).
    interaction : str, optional
        The interaction model whose tasks are read (default: the first phase's, the one under test); the
        interaction design reads every interaction model's.

    Returns
    -------
    PilotEstimate

    Raises
    ------
    PowerInputError
        When the pilot has groups or objects the protocol does not know, or too few complete
        participants to estimate a covariance (N - groups must reach the number of levels).
    """
    from microg.analysis.tables import AnalysisInputError, read_table
    from microg.study.export import read_tables

    path = Path(path)
    try:
        text = (SUBJECT, "group", "object", "interaction")
        trials = read_tables(path)[0] if path.is_dir() else read_table(path, text=text)
    except (AnalysisInputError, FileNotFoundError) as error:
        raise PowerInputError(f"--pilot {path}: {error}") from None
    d = design
    interaction = interaction or d.interactions[0]
    try:
        cells = design_cells(trials, d, measure, interaction, str(path))
    except AnalysisInputError as error:
        raise PowerInputError(str(error)) from None
    wide = cells.pivot_table(index=[d.between, SUBJECT], columns=d.within, values="value", observed=True)
    wide = wide[list(d.levels)]
    members = wide.index.get_level_values(d.between)
    k, g = len(d.levels), len(d.groups)
    counts = [int(np.sum(members == group)) for group in d.groups]
    if min(counts) < 1 or sum(counts) - g < k:
        listed = ", ".join(f"{group}: {c}" for group, c in zip(d.groups, counts))
        raise PowerInputError(f"--pilot {path}: {sum(counts)} complete participants ({listed}) with {measure} in "
                              f"every {d.within}: estimating a {k} x {k} covariance needs at least {g + k}, "
                              "with one in each group")
    values = wide.to_numpy(float)
    means = np.array([values[members == group].mean(axis=0) for group in d.groups])
    residuals = values - means[[d.groups.index(m) for m in members]]
    covariance = residuals.T @ residuals / (len(values) - g)
    if np.linalg.eigvalsh(covariance).min() <= 1e-12 * np.trace(covariance):
        raise PowerInputError(f"--pilot {path}: the pooled covariance of {measure} over {d.within}s is singular "
                              "(values that do not vary, or levels that move in lockstep)")
    table = cells.groupby([d.between, d.within], observed=True)["value"].agg(["size", "mean", "std"]).reset_index()
    table = table.rename(columns={"size": "n", "std": "sd"})
    table = table.set_index([d.between, d.within]).loc[[(a, b) for a in d.groups for b in d.levels]].reset_index()
    sample = ", ".join(f"{group}: {c}" for group, c in zip(d.groups, counts))
    read = (f"interaction model {interaction}" if d.within == "object"
            else "every interaction model, averaged over objects")
    tasks = "every task, finished or not" if measure in COUNTS else "completed tasks only"
    method = (f"Estimated from the pilot {path} ({measure}, {read}; complete participants {sample}): cell means "
              f"per group and {d.within}; the pooled within-group covariance (N - {g} degrees of freedom) for every "
              f"group. A participant's value is the mean over the cell's tasks ({tasks}); training and withdrawn "
              "participants left out; participants missing a level left out.")
    effects = Effects(d, means, np.array([covariance] * g), f"pilot {path}")
    return PilotEstimate(effects, table, pd.DataFrame(covariance, index=list(d.levels), columns=list(d.levels)),
                         method)


def _names(table: pd.DataFrame, column: str, codes: dict, source: str, what: str) -> pd.Series:
    """The column's codes as the protocol's names; a value that is neither is an error."""
    known = {**codes, **{name: name for name in codes.values()}}
    unknown = sorted(set(table[column]) - set(known))
    if unknown:
        raise PowerInputError(f"{source}: column {column!r} value {unknown[0]!r}: no {what} of that code or name in "
                              f"the protocol ({', '.join(f'{c} = {n}' for c, n in codes.items())})")
    return table[column].map(known)
