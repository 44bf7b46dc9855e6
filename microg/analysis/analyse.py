"""The whole analysis of one study's tables (the paper's section 4.3 and Table 1), as one bundle of
tidy DataFrames."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from microg.analysis.anova import (
    ANOVA_COLUMNS,
    CORRECTION_COLUMNS,
    mixed_anova,
    sphericity_correction,
)
from microg.analysis.art import ART_COLUMNS, ART_CONTRAST_COLUMNS, art_anova, art_contrasts
from microg.analysis.assumptions import ASSUMPTION_COLUMNS, assumption_checks
from microg.analysis.counts import COUNT_MODEL_COLUMNS, count_model
from microg.analysis.describe import CELL_MEANS_COLUMNS, cell_means
from microg.analysis.likert import (
    LIKERT_TEST_COLUMNS,
    likert_summary,
    likert_tests,
    unpaired_raters,
)
from microg.analysis.mixed_model import (
    COEFFICIENT_COLUMNS,
    MODEL_ANOVA_COLUMNS,
    RANDOM_COLUMNS,
    trial_model,
)
from microg.analysis.paired import (
    INTERACTIONS_COLUMNS,
    compare_interactions,
    unpaired_participants,
)
from microg.analysis.posthoc import (
    POSTHOC_COLUMNS,
    SIMPLE_EFFECT_COLUMNS,
    posthoc,
    simple_effects,
)
from microg.analysis.tables import (
    AnalysisInputError,
    check_questionnaire,
    check_same_groups,
    check_trials,
    complete_cases,
    exclude_phases,
    incomplete_cases,
    is_simulated,
    participant_cells,
    QUESTIONNAIRE_TEXT,
    TRIAL_TEXT,
    drop_repeated_rows,
    read_table,
    text_columns,
    withdrawn,
)
from microg.schema import PICK_AND_PLACE as PICK_AND_PLACE_INFO, KindInfo

DEFAULT_INTERACTION = "impulse_penetration"
DEFAULT_BASELINE = "soft_hand"
EXCLUDED_PHASES = ("training",)
PRACTICE = "task_index"
"""The export's column of a task's place in the participant's session: the trial model's practice."""
TRIAL_MODEL_COLUMNS = ("formula", "n_trials", "n_subjects", "note")
ALPHA = 0.05
"""Significance level of every test the report words as significant or not (Box's M: .001)."""
MIN_PAIRS = 3
KEYS = ("interaction", "measure")
KIND_COLUMN = "task_kind"
"""The export's column of a task's kind; a table without it holds pick-and-place tasks only."""
PICK_AND_PLACE = "pick_and_place"


@dataclass(frozen=True)
class StudyAnalysis:
    """Every table of a study's analysis, each a tidy DataFrame.

    Tables computed per interaction model and measure start with the columns ``interaction`` and
    ``measure`` (the interaction model's code and the measure's column name); :meth:`table` selects
    one. ``sample`` holds the number of participants per group in the data (analysis "data") and in
    each analysis (the effective N); ``dropped`` who was left out of which analysis and why;
    ``conditions`` each interaction model's label and role. A table with no rows means the analysis
    did not apply (no baseline, no questionnaire); ``warnings`` says why.

    The trial model of a measure (``trial_anova``, ``trial_coefficients``, ``trial_random``,
    ``trial_models``: every finished task of every interaction model, :func:`trial_model`) has the
    interaction "" (all of them). The questionnaire's ART (``likert_art``, ``likert_art_contrasts``)
    has one row set per item, in the column ``item``.

    ``kind`` is the task kind analysed (None: every task, as a pick-and-place study); its
    ``description`` holds the cell means of every interaction model and measure per group and
    ``within`` level, whether or not an ANOVA could be made; ``proportions`` are the measures
    that are yes or no per task (a cell's value is a proportion).
    """

    interaction: str
    baseline: str | None
    interactions: tuple[str, ...]
    objects: tuple[str, ...]
    measures: tuple[str, ...]
    counts: tuple[str, ...]
    subject: str
    group: str
    within: str
    ss_type: int
    alpha: float
    excluded_phases: tuple[str, ...]
    simulated_trials: bool
    simulated_ratings: bool
    conditions: pd.DataFrame
    sample: pd.DataFrame
    cells: pd.DataFrame
    cell_means: pd.DataFrame
    anova: pd.DataFrame
    corrections: pd.DataFrame
    posthoc: pd.DataFrame
    simple_effects: pd.DataFrame
    simple_pairs: pd.DataFrame
    assumptions: pd.DataFrame
    count_model: pd.DataFrame
    comparison: pd.DataFrame
    likert_summary: pd.DataFrame
    likert_tests: pd.DataFrame
    likert_art: pd.DataFrame
    likert_art_contrasts: pd.DataFrame
    trial_anova: pd.DataFrame
    trial_coefficients: pd.DataFrame
    trial_random: pd.DataFrame
    trial_models: pd.DataFrame
    dropped: pd.DataFrame
    warnings: tuple[str, ...]
    practice: str | None = None
    interaction_column: str = "interaction"
    kind: str | None = None
    proportions: tuple[str, ...] = ()
    description: pd.DataFrame | None = None
    kind_info: KindInfo = PICK_AND_PLACE_INFO
    """The analysed kind as the tables know it: its title, what its attempts count, its measures."""

    def table(self, name: str, interaction: str, measure: str) -> pd.DataFrame:
        """The rows of table ``name`` (e.g. "anova") for one interaction and measure, without the keys."""
        frame = getattr(self, name)
        rows = frame[(frame["interaction"] == interaction) & (frame["measure"] == measure)]
        return rows.drop(columns=list(KEYS)).reset_index(drop=True)

    def label(self, interaction: str) -> str:
        """How a reader sees an interaction: its label when the tables give one, else its code."""
        return self.conditions.set_index("interaction")["label"].get(interaction, interaction)

    def analysed(self) -> list[tuple[str, str]]:
        """The (interaction, measure) pairs that have an ANOVA, in the report's order."""
        keys = self.anova[list(KEYS)].drop_duplicates()
        return list(keys.itertuples(index=False, name=None))


def choose_interactions(
    interactions: Sequence[str], interaction: str | None, baseline: str | None, column: str = "interaction"
) -> tuple[str, str | None]:
    """The interaction model under test and its baseline.

    As asked; else impulse_penetration and soft_hand when present; else the first listed and the
    next one (no baseline when there is a single interaction model).

    Parameters
    ----------
    interactions : sequence of str
        The interaction models in the data, in order of appearance.
    interaction, baseline : str, optional
        The user's choice.
    column : str
        The interaction column's name, for the error message.

    Returns
    -------
    tuple of (str, str or None)
        The interaction model under test and the baseline.

    Raises
    ------
    AnalysisInputError
        When a chosen interaction model is not in the data, or it and the baseline are the same.

    Examples
    --------
    >>> from microg.analysis import choose_interactions
    >>> choose_interactions(["soft_hand", "impulse_penetration"], None, None)
    ('impulse_penetration', 'soft_hand')
    >>> choose_interactions(["a", "b", "c"], "c", None)
    ('c', 'a')
    """
    listed = list(dict.fromkeys(interactions))
    for name in (interaction, baseline):
        if name is not None and name not in listed:
            raise AnalysisInputError(f"column {column!r} has no value {name!r} (values: {', '.join(listed)})")
    if interaction is None:
        interaction = DEFAULT_INTERACTION if DEFAULT_INTERACTION in listed else listed[0]
    others = [name for name in listed if name != interaction]
    if baseline is None:
        baseline = DEFAULT_BASELINE if DEFAULT_BASELINE in others else (others[0] if others else None)
    if baseline == interaction:
        raise AnalysisInputError(f"interaction and baseline are both {interaction!r}")
    return interaction, baseline


def analyse_study(
    trials: pd.DataFrame | str | Path,
    questionnaire: pd.DataFrame | str | Path | None = None,
    interaction: str | None = None,
    baseline: str | None = None,
    ss_type: int = 3,
    excluded_phases: Sequence[str] = EXCLUDED_PHASES,
    *,
    subject: str = "participant",
    group: str = "group",
    within: str = "object",
    interaction_column: str = "interaction",
    dv: Sequence[str] = ("time_s", "attempts"),
    counts: Sequence[str] = ("attempts",),
    completed: str = "completed",
    phase: str = "phase",
    label: str = "interaction_label",
    item: str = "item",
    rating: str = "rating",
    alpha: float = ALPHA,
    drop_duplicates: bool = False,
    practice: str = PRACTICE,
    kind: str | None = None,
    kind_column: str = KIND_COLUMN,
    kinds: Mapping[str, KindInfo] | None = None,
) -> StudyAnalysis:
    """Mixed ANOVA, post hoc tests, simple effects, assumption checks and count models per interaction
    model and measure; a linear mixed model of every task per measure; interaction model vs
    baseline; the Likert analysis with the aligned rank transform ANOVA of group x interaction model.

    Parameters
    ----------
    trials : pandas.DataFrame, str or Path
        One row per task (a table, or a CSV/Parquet file); checked by :func:`check_trials`.
    questionnaire : pandas.DataFrame, str or Path, optional
        One row per participant, interaction model and item.
    interaction, baseline : str, optional
        The interaction model under test and its baseline (see :func:`choose_interactions`).
    ss_type : {3, 2}
        Sums-of-squares type of the ANOVA.
    excluded_phases : sequence of str
        Trials of these phases are left out (training, which only one group does).
    subject, group, within, interaction_column : str
        Columns of the participant, the between factor, the within factor and the interaction model.
    dv : sequence of str
        The measures. A measure that is not in ``counts`` uses completed tasks only (when the
        ``completed`` column exists); a count uses every task with a value.
    counts : sequence of str
        Measures that count events: whole numbers, analysed also with :func:`count_model`.
    completed, phase, label, item, rating : str
        Columns of the finished-task flag, the phase, each interaction model's label for readers
        (optional), the questionnaire item and the rating.
    alpha : float
        Level at which a test counts as significant (and simple effects are read).
    drop_duplicates : bool
        Rows that repeat an earlier row of their table in every column are refused (a row given twice
        counts twice); with True they are dropped, and ``warnings`` says which.
    practice : str
        Column of a task's place in the participant's session (the export's ``task_index``): the
        trial model's practice term and random slope, when the table has it.
    kind : str, optional
        Analyse only the tasks of this kind (column ``kind_column``; a table without it holds
        pick-and-place tasks), with the kind's own measures after ``dv`` (its ``kinds`` entry). A
        kind other than pick_and_place needs no mixed design: with one group or one ``within``
        level it is described, and ``warnings`` says why there is no ANOVA. A measure that is yes
        or no per task (``KindMeasure.proportion``, True/False in the table) is the proportion of a
        participant's tasks with yes, of every task with a value, and has no trial model. A measure
        that may be negative (``KindMeasure.signed``) is let through the check of negative values.
    kind_column : str
        Column of the task's kind.
    kinds : mapping of str to microg.schema.KindInfo, optional
        The task kinds as the tables know them (the study's registry: ``microg.study.kind_infos``);
        a kind not in it is analysed by time and attempts alone.

    Returns
    -------
    StudyAnalysis
        Every table; withdrawn participants (flag ``withdrawn``) are left out and listed.

    Examples
    --------
    >>> import pingouin as pg
    >>> from microg.analysis import analyse_study
    >>> data = pg.read_dataset("mixed_anova").assign(tool="s", done=True)
    >>> study = analyse_study(data, subject="Subject", group="Group", within="Time", interaction_column="tool",
    ...                       dv=["Scores"], counts=[], completed="done")
    >>> study.table("anova", "s", "Scores")[["source", "F", "p_unc"]].round(3)
           source      F  p_unc
    0       Group  5.052  0.028
    1        Time  4.027  0.020
    2  Group:Time  2.728  0.070
    """
    columns = {"subject": subject, "group": group, "within": within, "interaction": interaction_column}
    info = kind_info(kind, kinds)
    own = {m.name: m for m in info.measures} if kind else {}
    dv = (*dv, *own)
    proportions = tuple(m for m in dv if m in own and own[m].proportion)
    keep = None if kind is None and not proportions else (lambda table: _of_kind(table, kind, kind_column,
                                                                                   proportions))
    trials, dropped_rows = _checked(trials, check_trials, TRIAL_TEXT, "trials table", drop_duplicates, keep=keep,
                                    **columns, dv=dv, counts=counts, completed=completed, label=label,
                                    design=kind in (None, PICK_AND_PLACE),
                                    signed=tuple(m for m in dv if m in own and own[m].signed))  # fmt: skip
    trials = exclude_phases(trials, excluded_phases, phase)
    if questionnaire is not None:
        questionnaire, dropped_answers = _checked(questionnaire, check_questionnaire, QUESTIONNAIRE_TEXT,
                                                  "questionnaire table", drop_duplicates, subject=subject, group=group,
                                                  interaction=interaction_column, item=item, rating=rating,
                                                  label=label)  # fmt: skip
        dropped_rows += dropped_answers
        check_same_groups(trials, questionnaire, subject, group)
    gone = sorted(withdrawn(trials, subject) | withdrawn(questionnaire, subject))
    trials = trials[~trials[subject].isin(gone)]
    if questionnaire is not None:
        questionnaire = questionnaire[~questionnaire[subject].isin(gone)]
    interaction, baseline = choose_interactions(trials[interaction_column], interaction, baseline, interaction_column)
    interactions = tuple(dict.fromkeys([interaction, *([baseline] if baseline else []), *trials[interaction_column]]))
    conditions = _conditions(interactions, interaction, baseline, [trials, questionnaire], interaction_column, label)
    names = dict(zip(conditions["interaction"], conditions["label"]))
    design = _Design(subject, group, within, interaction_column, tuple(dv), tuple(counts), completed, ss_type, alpha,
                     names, proportions)

    per_interaction = _per_interaction(trials, interactions, design)
    pairs = _versus_baseline(trials, interaction, baseline, design)
    likert = _likert(questionnaire, interaction, baseline, design, item, rating)
    art = _likert_art(questionnaire, trials, design, item, rating)
    practised = practice if practice in trials.columns and pd.api.types.is_numeric_dtype(trials[practice]) else None
    models = _trial_models(trials, design, practised)
    withdrew = pd.DataFrame({"analysis": "all", "interaction": "", "measure": "", subject: gone,
                             "reason": "withdrew from the study"})  # fmt: skip
    parts = (per_interaction, models, pairs, likert, art)
    in_data = trials.drop_duplicates(subject).groupby(group, observed=True).size()
    data_sample = pd.DataFrame({"analysis": "data", "interaction": "", "measure": "", group: in_data.index,
                                "n": in_data.to_numpy()})  # fmt: skip
    return StudyAnalysis(
        interaction=interaction,
        baseline=baseline,
        interactions=interactions,
        objects=tuple(sorted(trials[within].unique())),
        measures=tuple(dv),
        counts=tuple(m for m in dv if m in counts),
        subject=subject,
        group=group,
        within=within,
        ss_type=ss_type,
        alpha=alpha,
        excluded_phases=tuple(excluded_phases),
        simulated_trials=is_simulated(trials),
        simulated_ratings=is_simulated(questionnaire),
        conditions=conditions,
        sample=pd.concat([data_sample, *(part.tables["sample"] for part in parts)], ignore_index=True),
        dropped=pd.concat([withdrew, *(part.dropped for part in parts)], ignore_index=True)[
            ["analysis", "interaction", "measure", subject, "reason"]
        ],
        warnings=tuple(dropped_rows) + tuple(note for part in parts for note in part.notes),
        **{name: per_interaction.tables[name] for name in PER_INTERACTION},
        comparison=pairs.tables["comparison"],
        likert_summary=likert.tables["likert_summary"],
        likert_tests=likert.tables["likert_tests"],
        likert_art=art.tables["likert_art"],
        likert_art_contrasts=art.tables["likert_art_contrasts"],
        **{name: models.tables[name] for name in TRIAL_TABLES},
        practice=practised,
        interaction_column=interaction_column,
        kind=kind,
        proportions=proportions,
        description=_description(trials, interactions, design),
        kind_info=info,
    )


def kind_info(kind: str | None, kinds: Mapping[str, KindInfo] | None = None) -> KindInfo:
    """How the tables know ``kind`` (None: the pick-and-place): its ``kinds`` entry, else its name
    alone (time and attempts, no measures of its own)."""
    kind = kind or PICK_AND_PLACE
    known = {PICK_AND_PLACE: PICK_AND_PLACE_INFO, **(kinds or {})}
    return known.get(kind, KindInfo(kind, kind.replace("_", " ").capitalize(), "attempts"))


def kinds_present(trials: pd.DataFrame, excluded_phases: Sequence[str] = EXCLUDED_PHASES, phase: str = "phase",
                  kind_column: str = KIND_COLUMN) -> tuple[str, ...]:
    """The task kinds of a trials table's analysed tasks, pick_and_place first, then in order of appearance.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task; without ``kind_column`` every task is a pick-and-place.
    excluded_phases, phase : sequence of str, str
        Tasks of these phases (column ``phase``) are not analysed, so their kinds do not count.
    kind_column : str
        Column of the task's kind.

    Returns
    -------
    tuple of str
        The kinds; pick_and_place alone for a table without ``kind_column``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import kinds_present
    >>> trials = pd.DataFrame({"phase": ["training", "stage1", "stage2"],
    ...                        "task_kind": ["pick_and_place", "twirl", "toss"]})
    >>> kinds_present(trials)
    ('twirl', 'toss')
    """
    if kind_column not in trials.columns:
        return (PICK_AND_PLACE,)
    kinds = list(dict.fromkeys(exclude_phases(trials, excluded_phases, phase)[kind_column].dropna()))
    return tuple(sorted(kinds, key=lambda kind: kind != PICK_AND_PLACE))


def _of_kind(table: pd.DataFrame, kind: str | None, kind_column: str, proportions: Sequence[str]) -> pd.DataFrame:
    """The tasks of ``kind`` (every task for None; a table without ``kind_column`` is pick-and-place),
    with the yes/no ``proportions`` as 1.0/0.0 (empty stays empty)."""
    if kind is not None:
        kinds = table[kind_column] if kind_column in table.columns else pd.Series(PICK_AND_PLACE, index=table.index)
        table = table[kinds == kind].reset_index(drop=True)
    words = {True: 1.0, False: 0.0, "true": 1.0, "false": 0.0, "True": 1.0, "False": 0.0}
    mapped = {m: table[m].map(words) for m in proportions if m in table.columns}
    # a value that is neither stays as it is, for check_trials to refuse by name
    return table.assign(**{m: values.where(table[m].isna() | values.notna(), table[m]) for m, values in mapped.items()})


def _description(trials: pd.DataFrame, interactions: Sequence[str], design: _Design) -> pd.DataFrame:
    """Cell means of every interaction model and measure per group and ``within`` level, of every
    participant with a value (not only the complete cases an ANOVA needs)."""
    d = design
    found = [_keyed(cell_means(d.cells(trials[trials[d.interaction] == name], dv), dv, d.within, d.group),
                    {"interaction": name, "measure": dv})
             for name in interactions for dv in d.measures]  # fmt: skip
    found = [frame for frame in found if len(frame)]
    return _concat(found, (d.group, d.within, *CELL_MEANS_COLUMNS))


TRIAL_TABLES = ("trial_anova", "trial_coefficients", "trial_random", "trial_models")
PER_INTERACTION = ("cells", "cell_means", "anova", "corrections", "posthoc", "simple_effects", "simple_pairs",
                   "assumptions", "count_model")  # fmt: skip
"""The tables computed per interaction and measure."""


@dataclass(frozen=True)
class _Design:
    subject: str
    group: str
    within: str
    interaction: str
    measures: tuple[str, ...]
    counts: tuple[str, ...]
    completed: str
    ss_type: int
    alpha: float
    labels: dict[str, str]
    proportions: tuple[str, ...] = ()

    def cells(self, trials: pd.DataFrame, dv: str) -> pd.DataFrame:
        """Participant-level cells of ``dv`` by the rules for counts and proportions (every task with a
        value) and for measures of finished tasks."""
        every_task = dv in self.counts or dv in self.proportions
        finished = self.completed if not every_task and self.completed in trials.columns else None
        return participant_cells(trials, dv, self.subject, self.group, self.interaction, self.within, finished)


@dataclass(frozen=True)
class _Part:
    """One part of the analysis: its tables, who it left out and why, and what the reader must know."""

    tables: dict[str, pd.DataFrame]
    dropped: pd.DataFrame
    notes: list[str]


def _per_interaction(trials: pd.DataFrame, interactions: Sequence[str], design: _Design) -> _Part:
    d = design
    tables: dict[str, list[pd.DataFrame]] = {name: [] for name in (*PER_INTERACTION, "sample")}
    notes, dropped = [], []
    for name in interactions:
        rows = trials[trials[d.interaction] == name]
        levels = sorted(rows[d.within].unique())
        for dv in d.measures:
            cells = d.cells(rows, dv)
            missing = incomplete_cases(cells, dv, d.within, d.subject, levels)
            absent = sorted(set(rows[d.subject]) - set(cells[d.subject]))
            missing = pd.concat([missing, pd.DataFrame({d.subject: absent, "reason": f"no {dv} at all"})])
            dropped.append(missing.assign(analysis="ANOVA", interaction=name, measure=dv))
            complete = complete_cases(cells, dv, d.within, d.subject, levels)
            try:
                anova = mixed_anova(complete, dv, d.within, d.group, d.subject, d.ss_type)
            except AnalysisInputError as error:
                notes.append(f"No {dv} ANOVA for {d.labels[name]}: {error}.")
                continue
            keys = {"interaction": name, "measure": dv}
            post = posthoc(complete, dv, d.within, d.group, d.subject, within_by_group=True)
            by_group = post["at"].notna() & (post["factor"] == d.within)
            results = {
                "cells": complete.drop(columns=[d.interaction]).rename(columns={dv: "value"}),
                "cell_means": cell_means(complete, dv, d.within, d.group),
                "anova": anova,
                "corrections": sphericity_correction(anova, d.alpha),
                "posthoc": post[~by_group],
                "simple_effects": simple_effects(complete, dv, d.within, d.group, d.subject),
                "simple_pairs": post[by_group],
                "assumptions": assumption_checks(complete, dv, d.within, d.group, d.subject, d.alpha),
                "sample": _group_sizes(complete, d, "ANOVA"),
            }
            if dv in d.counts:
                tasks = rows[rows[d.subject].isin(complete[d.subject]) & rows[d.within].isin(levels)]
                results["count_model"] = count_model(tasks, dv, d.within, d.group, d.subject)
            for piece, frame in results.items():
                tables[piece].append(_keyed(frame.reset_index(drop=True), keys))
            notes.extend(_anova_notes(d.labels[name], dv, complete, anova, d))
    empty = {  # the columns of a table no interaction has
        "cells": (d.subject, d.group, d.within, "value"),
        "cell_means": (d.group, d.within, *CELL_MEANS_COLUMNS),
        "anova": ANOVA_COLUMNS,
        "corrections": CORRECTION_COLUMNS,
        "posthoc": POSTHOC_COLUMNS,
        "simple_effects": SIMPLE_EFFECT_COLUMNS,
        "simple_pairs": POSTHOC_COLUMNS,
        "assumptions": ASSUMPTION_COLUMNS,
        "count_model": COUNT_MODEL_COLUMNS,
        "sample": ("analysis", d.group, "n"),
    }
    frames = {piece: _concat(found, empty[piece]) for piece, found in tables.items()}
    return _Part(frames, pd.concat(dropped, ignore_index=True), notes)


def _versus_baseline(trials: pd.DataFrame, interaction: str, baseline: str | None, design: _Design) -> _Part:
    d = design
    nobody = pd.DataFrame(columns=["analysis", "interaction", "measure", d.subject, "reason"])
    sample_columns = ("analysis", d.group, "n")
    if baseline is None:
        return _Part({"comparison": pd.DataFrame(columns=INTERACTIONS_COLUMNS), "sample": _concat([], sample_columns)},
                     nobody, [])  # fmt: skip
    rows, notes, dropped, sample = [], [], [], []
    versus = f"{d.labels[interaction]} vs {d.labels[baseline]}"
    for dv in d.measures:
        cells = d.cells(trials, dv)
        named = cells.assign(**{d.interaction: cells[d.interaction].map(d.labels)})  # the reasons name labels
        missing = unpaired_participants(named, dv, d.labels[interaction], d.labels[baseline], d.within, d.subject,
                                        d.interaction)
        dropped.append(missing.assign(analysis="pairs", interaction=interaction, measure=dv))
        paired = cells[~cells[d.subject].isin(missing[d.subject])]
        if paired[d.subject].nunique() < MIN_PAIRS:
            notes.append(f"No {versus} comparison of {dv}: {paired[d.subject].nunique()} complete pair(s).")
            continue
        row = compare_interactions(paired, dv, interaction, baseline, d.within, d.subject, d.interaction)
        rows.append(row)
        sample.append(_keyed(_group_sizes(paired[paired[d.interaction] == interaction], d, "pairs"),
                             {"interaction": interaction, "measure": dv}))  # fmt: skip
        p_shapiro = row["p_shapiro"].iloc[0]
        if p_shapiro < d.alpha:
            notes.append(
                f"The paired differences of {dv} ({d.labels[interaction]} - {d.labels[baseline]}) are far from normal "
                f"(Shapiro-Wilk p = {p_shapiro:.3g}): read the Wilcoxon signed-rank test, not the t-test."
            )
    comparison = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=INTERACTIONS_COLUMNS)
    tables = {"comparison": comparison, "sample": _concat(sample, sample_columns)}
    return _Part(tables, pd.concat(dropped, ignore_index=True), notes)


def _likert(questionnaire, interaction: str, baseline: str | None, design: _Design, item: str, rating: str) -> _Part:
    d = design
    nobody = pd.DataFrame(columns=["analysis", "interaction", "measure", d.subject, "reason"])
    no_tests = pd.DataFrame(columns=LIKERT_TEST_COLUMNS)
    sample_columns = ("analysis", d.group, "n")
    no_sample = _concat([], sample_columns)
    if questionnaire is None:
        return _Part({"likert_summary": pd.DataFrame(), "likert_tests": no_tests, "sample": no_sample}, nobody, [])
    summary = likert_summary(questionnaire, item, d.interaction, rating)
    if baseline is None or not {interaction, baseline} <= set(questionnaire[d.interaction]):
        note = (f"The questionnaire does not rate both {d.labels[interaction]} and {d.labels.get(baseline)}: "
                "no Likert test.")
        return _Part({"likert_summary": summary, "likert_tests": no_tests, "sample": no_sample}, nobody, [note])
    tests = likert_tests(questionnaire, interaction, baseline, d.subject, item, d.interaction, rating)
    named = questionnaire.assign(
        **{d.interaction: questionnaire[d.interaction].map(lambda code: d.labels.get(code, code))})
    unpaired = unpaired_raters(named, d.labels[interaction], d.labels[baseline], d.subject, item, d.interaction)
    sample = []
    for name, answers in questionnaire.groupby(item, sort=True):
        raters = answers[answers[d.interaction].isin([interaction, baseline])]
        both = raters.groupby(d.subject)[d.interaction].nunique() == 2
        rated = raters[raters[d.subject].isin(both[both].index) & (raters[d.interaction] == interaction)]
        if d.group not in rated.columns:
            rated = rated.assign(**{d.group: "all"})
        sample.append(_keyed(_group_sizes(rated, d, "Likert"), {"interaction": interaction, "measure": name}))
    tables = {"likert_summary": summary, "likert_tests": tests, "sample": _concat(sample, sample_columns)}
    return _Part(tables, unpaired.assign(analysis="Likert", interaction=interaction, measure=""), [])


def _trial_models(trials: pd.DataFrame, design: _Design, practice: str | None) -> _Part:
    """A linear mixed model of every finished task per measure that is neither a count (counts have
    their GEE) nor a proportion: group x within x interaction model (each when it has several
    levels) + practice, log-transformed when every value is positive."""
    d = design
    tables: dict[str, list[pd.DataFrame]] = {name: [] for name in TRIAL_TABLES}
    notes = []
    for dv in (m for m in d.measures if m not in d.counts and m not in d.proportions):
        finished = trials[trials[d.completed].astype(bool)] if d.completed in trials.columns else trials
        rows = finished[finished[dv].notna()]
        crossed = [factor for factor in (d.group, d.within, d.interaction) if rows[factor].nunique() > 1]
        fixed = " + ".join([" * ".join(crossed)] * bool(crossed) + [practice] * bool(practice))
        if not fixed:
            notes.append(f"No trial model of {dv}: one {d.group}, one {d.within} and one interaction model.")
            continue
        transform = "log" if len(rows) and (rows[dv] > 0).all() else None
        try:
            model = trial_model(rows, dv, fixed, d.subject, transform, slope=practice)
        except AnalysisInputError as error:
            notes.append(f"No trial model of {dv}: {error}.")
            continue
        keys = {"interaction": "", "measure": dv}
        summary = pd.DataFrame([(model.formula, model.n_trials, model.n_subjects, model.note)],
                               columns=list(TRIAL_MODEL_COLUMNS))  # fmt: skip
        for name, frame in (("trial_anova", model.anova), ("trial_coefficients", model.coefficients),
                            ("trial_random", model.random), ("trial_models", summary)):  # fmt: skip
            tables[name].append(_keyed(frame, keys))
        if "singular fit" in model.note:
            notes.append(f"The trial model of {dv} is a singular fit (the participants' variance is estimated at 0).")
    empty = {"trial_anova": MODEL_ANOVA_COLUMNS, "trial_coefficients": COEFFICIENT_COLUMNS,
             "trial_random": RANDOM_COLUMNS, "trial_models": TRIAL_MODEL_COLUMNS}  # fmt: skip
    nobody = pd.DataFrame(columns=["analysis", "interaction", "measure", d.subject, "reason"])
    frames = {name: _concat(found, empty[name]) for name, found in tables.items()}
    frames["sample"] = _concat([], ("analysis", d.group, "n"))
    return _Part(frames, nobody, notes)


def _likert_art(questionnaire, trials: pd.DataFrame, design: _Design, item: str, rating: str) -> _Part:
    """Per item, the aligned rank transform ANOVA of group x interaction model and its ART-C contrasts,
    on the participants who rated every interaction model of the item (the groups taken from the
    trials when the questionnaire has none)."""
    d = design
    nobody = pd.DataFrame(columns=["analysis", "interaction", "measure", d.subject, "reason"])
    tables = {"likert_art": [], "likert_art_contrasts": [], "sample": []}
    dropped, notes = [], []
    if questionnaire is not None:
        answers = questionnaire
        if d.group not in answers.columns:
            groups = trials.drop_duplicates(d.subject).set_index(d.subject)[d.group]
            answers = answers.assign(**{d.group: answers[d.subject].map(groups)}).dropna(subset=[d.group])
        for name, ratings in answers.groupby(item, sort=True):
            if ratings[d.group].nunique() < 2 or ratings[d.interaction].nunique() < 2:
                continue
            missing = incomplete_cases(ratings, rating, d.interaction, d.subject)
            dropped.append(missing.assign(analysis="ART", interaction="", measure=name))
            complete = complete_cases(ratings, rating, d.interaction, d.subject)
            keys = {item: name}
            try:
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", message="dropped")
                    anova = art_anova(complete, rating, d.interaction, d.group, d.subject, d.ss_type)
                    terms = (d.group, d.interaction, f"{d.group}:{d.interaction}")
                    contrasts = pd.concat([art_contrasts(complete, rating, d.interaction, d.group, d.subject, term)
                                           for term in terms], ignore_index=True)  # fmt: skip
            except AnalysisInputError as error:
                notes.append(f"No aligned rank transform ANOVA of {name}: {error}.")
                continue
            tables["likert_art"].append(_keyed(anova, keys))
            tables["likert_art_contrasts"].append(_keyed(contrasts, keys))
            tables["sample"].append(_keyed(_group_sizes(complete, d, "ART"), {"interaction": "", "measure": name}))
    frames = {
        "likert_art": pd.concat(tables["likert_art"], ignore_index=True) if tables["likert_art"]
        else pd.DataFrame(columns=[item, *ART_COLUMNS]),
        "likert_art_contrasts": pd.concat(tables["likert_art_contrasts"], ignore_index=True)
        if tables["likert_art_contrasts"] else pd.DataFrame(columns=[item, *ART_CONTRAST_COLUMNS]),
        "sample": _concat(tables["sample"], ("analysis", d.group, "n")),
    }  # fmt: skip
    return _Part(frames, pd.concat(dropped, ignore_index=True) if dropped else nobody, notes)


def _conditions(interactions, interaction, baseline, tables, interaction_column: str, label: str) -> pd.DataFrame:
    labels: dict[str, str] = {}
    for table in tables:
        if table is None or label not in table.columns:
            continue
        pairs = table.drop_duplicates(interaction_column)[[interaction_column, label]]
        for code, name in pairs.itertuples(index=False):
            if labels.setdefault(code, name) != name:
                raise AnalysisInputError(
                    f"{interaction_column} {code!r} is labelled {labels[code]!r} in one table and {name!r} in another "
                    f"(column {label!r})"
                )
    roles = {interaction: "interaction model under test", baseline: "baseline"}
    return pd.DataFrame(
        {
            "interaction": list(interactions),
            "label": [labels.get(name, name) for name in interactions],
            "role": [roles.get(name, "also analysed") for name in interactions],
        }
    )


def _group_sizes(cells: pd.DataFrame, design: _Design, analysis: str) -> pd.DataFrame:
    sizes = cells.drop_duplicates(design.subject).groupby(design.group, observed=True).size()
    return pd.DataFrame({"analysis": analysis, design.group: sizes.index, "n": sizes.to_numpy()})


def _keyed(frame: pd.DataFrame, keys: dict) -> pd.DataFrame:
    return frame.assign(**keys)[[*keys, *frame.columns]]


def _concat(frames: list[pd.DataFrame], columns) -> pd.DataFrame:
    if frames:
        return pd.concat(frames, ignore_index=True)
    return pd.DataFrame(columns=[*KEYS, *columns])


def _checked(table, check, text, source: str, drop_duplicates: bool, keep=None,
             **columns) -> tuple[pd.DataFrame, list[str]]:
    """An input table (a DataFrame, or a file read here) checked by ``check``; ``keep`` (a function of
    the table) chooses its rows first; with ``drop_duplicates`` its repeated rows dropped first, and
    the note that says so."""
    if not isinstance(table, pd.DataFrame):
        table, source = read_table(table, text=text_columns(text, columns)), str(table)
    if keep is not None:
        table = keep(table)
    notes = []
    if drop_duplicates:
        table, note = drop_repeated_rows(table, source)
        notes += [note] if note else []
    return check(table, source, **columns), notes


def _anova_notes(interaction: str, dv: str, complete: pd.DataFrame, anova: pd.DataFrame, design: _Design) -> list[str]:
    notes = []
    sizes = complete.drop_duplicates(design.subject)[design.group].value_counts().sort_index()
    if sizes.nunique() > 1:
        listed = ", ".join(f"{g}: {n}" for g, n in sizes.items())
        notes.append(
            f"Unbalanced design in the {dv} ANOVA of {interaction} ({listed}): type {design.ss_type} sums of squares"
            + (" (afex's default; equal weight per group)." if design.ss_type == 3 else " (groups weighted by size).")
        )
    violated = anova[anova["p_mauchly"] < design.alpha]
    if len(violated):
        row = violated.iloc[0]
        notes.append(
            f"Sphericity violated for {' and '.join(violated['source'])} in the {dv} ANOVA of {interaction} "
            f"(Mauchly W = {row['W_mauchly']:.3f}, p = {row['p_mauchly']:.3g}): Greenhouse-Geisser correction "
            f"applied (epsilon = {row['eps_GG']:.3f})."
        )
    if np.isclose(complete[dv].std(), 0):
        notes.append(f"The {dv} of {interaction} does not vary (every value is {complete[dv].iloc[0]:g}): "
                     "nothing to test.")
    return notes
