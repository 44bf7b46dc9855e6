"""The whole analysis of one study's exported tables (the paper's section 4.3 and Table 1)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from microg.analysis.anova import SPHERICITY_ALPHA, mixed_anova, sphericity_correction
from microg.analysis.likert import likert_summary, likert_tests, unpaired_raters
from microg.analysis.paired import compare_systems, paired_means
from microg.analysis.posthoc import posthoc
from microg.analysis.tables import (
    MEASURES,
    AnalysisInputError,
    check_questionnaire,
    check_same_groups,
    check_trials,
    complete_cases,
    exclude_stages,
    is_simulated,
    participant_cells,
    read_questionnaire,
    read_trials,
    withdrawn,
)

DEFAULT_SYSTEM = "impulse_penetration"
DEFAULT_BASELINE = "soft_hand"
EXCLUDED_STAGES = ("training",)
NORMALITY_ALPHA = 0.05
MIN_PAIRS = 3
_NOBODY = pd.DataFrame(columns=["analysis", "participant", "reason"])
WITHIN, BETWEEN, SUBJECT = "object", "group", "participant"


@dataclass(frozen=True)
class StudyAnalysis:
    """Every table of the report, keyed by (system, measure) where the analysis is per system."""

    system: str
    baseline: str | None
    systems: tuple[str, ...]
    objects: tuple[str, ...]
    ss_type: int
    group_sizes: dict[str, int]
    anova: dict[tuple[str, str], pd.DataFrame]
    corrections: dict[tuple[str, str], pd.DataFrame]
    posthoc: dict[tuple[str, str], pd.DataFrame]
    cells: dict[tuple[str, str], pd.DataFrame]
    comparison: pd.DataFrame | None
    likert_summary: pd.DataFrame | None
    likert_tests: pd.DataFrame | None
    dropped: pd.DataFrame
    warnings: tuple[str, ...]
    simulated_trials: bool
    simulated_ratings: bool
    excluded_stages: tuple[str, ...]


def choose_systems(systems: Sequence[str], system: str | None, baseline: str | None) -> tuple[str, str | None]:
    """The system under test and its baseline: as asked, else impulse_penetration and soft_hand when
    present, else the first listed and the next one."""
    listed = list(dict.fromkeys(systems))
    for name in (system, baseline):
        if name is not None and name not in listed:
            raise AnalysisInputError(f"column 'system' has no value {name!r} (values: {', '.join(listed)})")
    if system is None:
        system = DEFAULT_SYSTEM if DEFAULT_SYSTEM in listed else listed[0]
    others = [name for name in listed if name != system]
    if baseline is None:
        baseline = DEFAULT_BASELINE if DEFAULT_BASELINE in others else (others[0] if others else None)
    if baseline == system:
        raise AnalysisInputError(f"system and baseline are both {system!r}")
    return system, baseline


def analyse_study(
    trials: pd.DataFrame | str | Path,
    questionnaire: pd.DataFrame | str | Path | None = None,
    system: str | None = None,
    baseline: str | None = None,
    ss_type: int = 3,
    excluded_stages: Sequence[str] = EXCLUDED_STAGES,
) -> StudyAnalysis:
    """Mixed ANOVA and post hoc per system and measure, system vs baseline, and the Likert analysis.

    The tables (DataFrames, or CSV/Parquet files) are checked here; errors name the file, column and
    value. Trials of ``excluded_stages`` (training, which only one group does) and withdrawn
    participants are left out.
    """
    trials = exclude_stages(_checked(trials, read_trials, check_trials), excluded_stages)
    if questionnaire is not None:
        questionnaire = _checked(questionnaire, read_questionnaire, check_questionnaire)
        check_same_groups(trials, questionnaire)
    gone = sorted(withdrawn(trials) | withdrawn(questionnaire))
    trials = trials[~trials[SUBJECT].isin(gone)]
    if questionnaire is not None:
        questionnaire = questionnaire[~questionnaire[SUBJECT].isin(gone)]
    system, baseline = choose_systems(trials["system"], system, baseline)
    systems = tuple(dict.fromkeys([system, *([baseline] if baseline else []), *trials["system"]]))
    all_cells = {dv: participant_cells(trials, dv, WITHIN, SUBJECT) for dv in MEASURES}
    withdrew = pd.DataFrame({"analysis": "all", "participant": gone, "reason": "withdrew from the study"})
    per_system = _per_system(trials, all_cells, systems, ss_type)
    comparison = _versus_baseline(all_cells, system, baseline)
    likert = _likert(questionnaire, system, baseline)
    anova, corrections, post, cells = per_system.tables
    summary, tests = likert.tables
    parts = (per_system, comparison, likert)
    dropped = pd.concat([withdrew, *(part.dropped for part in parts)], ignore_index=True)
    notes = [note for part in parts for note in part.notes]

    group_sizes = trials.drop_duplicates(SUBJECT)[BETWEEN].value_counts().sort_index()
    return StudyAnalysis(
        system=system,
        baseline=baseline,
        systems=systems,
        objects=tuple(sorted(trials[WITHIN].unique())),
        ss_type=ss_type,
        group_sizes={str(g): int(n) for g, n in group_sizes.items()},
        anova=anova,
        corrections=corrections,
        posthoc=post,
        cells=cells,
        comparison=comparison.tables,
        likert_summary=summary,
        likert_tests=tests,
        dropped=dropped[["analysis", "participant", "reason"]],
        warnings=tuple(notes),
        simulated_trials=is_simulated(trials),
        simulated_ratings=is_simulated(questionnaire),
        excluded_stages=tuple(excluded_stages),
    )


@dataclass(frozen=True)
class _Part:
    """One part of the analysis: its tables, who it left out and why, and what the reader must know."""

    tables: object
    dropped: pd.DataFrame
    notes: list[str]


def _per_system(trials: pd.DataFrame, all_cells: dict, systems: Sequence[str], ss_type: int) -> _Part:
    anova, corrections, post, cells = {}, {}, {}, {}
    notes, dropped = [], []
    for name in systems:
        objects = sorted(trials.loc[trials["system"] == name, WITHIN].unique())
        for dv in MEASURES:
            rows = all_cells[dv][all_cells[dv]["system"] == name]
            complete, missing = complete_cases(rows, dv, WITHIN, SUBJECT, objects)
            absent = sorted(set(trials.loc[trials["system"] == name, SUBJECT]) - set(rows[SUBJECT]))
            missing = pd.concat([missing, pd.DataFrame({"participant": absent, "reason": f"no {dv} at all"})])
            dropped.append(missing.assign(analysis=f"ANOVA {dv}, {name}"))
            key = (name, dv)
            try:
                anova[key] = mixed_anova(complete, dv, WITHIN, BETWEEN, SUBJECT, ss_type)
            except AnalysisInputError as error:
                notes.append(f"No {dv} ANOVA for {name}: {error}.")
                continue
            cells[key] = complete
            corrections[key] = sphericity_correction(anova[key], SPHERICITY_ALPHA)
            post[key] = posthoc(complete, dv, WITHIN, BETWEEN, SUBJECT)
            notes.extend(_anova_notes(name, dv, complete, anova[key], ss_type))
    return _Part((anova, corrections, post, cells), pd.concat(dropped, ignore_index=True), notes)


def _versus_baseline(all_cells: dict, system: str, baseline: str | None) -> _Part:
    if baseline is None:
        return _Part(None, _NOBODY, [])
    rows, notes, dropped = [], [], []
    for dv in MEASURES:
        pairs, missing = paired_means(all_cells[dv], dv, system, baseline, WITHIN, SUBJECT)
        dropped.append(missing.assign(analysis=f"{system} vs {baseline}, {dv}"))
        if len(pairs) < MIN_PAIRS:
            notes.append(f"No {system} vs {baseline} comparison of {dv}: {len(pairs)} complete pair(s).")
            continue
        paired = all_cells[dv][~all_cells[dv][SUBJECT].isin(missing[SUBJECT])]
        row = compare_systems(paired, dv, system, baseline, WITHIN, SUBJECT)
        rows.append(row)
        p_shapiro = row["p_shapiro"].iloc[0]
        if p_shapiro < NORMALITY_ALPHA:
            notes.append(
                f"The paired differences of {dv} ({system} - {baseline}) are far from normal "
                f"(Shapiro-Wilk p = {p_shapiro:.3g}): read the Wilcoxon signed-rank test, not the t-test."
            )
    table = pd.concat(rows, ignore_index=True) if rows else None
    return _Part(table, pd.concat(dropped, ignore_index=True), notes)


def _likert(questionnaire: pd.DataFrame | None, system: str, baseline: str | None) -> _Part:
    if questionnaire is None:
        return _Part((None, None), _NOBODY, [])
    summary = likert_summary(questionnaire)
    if baseline is None or not {system, baseline} <= set(questionnaire["system"]):
        note = f"The questionnaire does not rate both {system} and {baseline}: no Likert test."
        return _Part((summary, None), _NOBODY, [note])
    tests = likert_tests(questionnaire, system, baseline, SUBJECT)
    dropped = unpaired_raters(questionnaire, system, baseline).assign(analysis="Likert")
    return _Part((summary, tests), dropped, [])


def _checked(table, read, check) -> pd.DataFrame:
    return check(table) if isinstance(table, pd.DataFrame) else read(table)


def _anova_notes(system: str, dv: str, complete: pd.DataFrame, anova: pd.DataFrame, ss_type: int) -> list[str]:
    notes = []
    sizes = complete.drop_duplicates(SUBJECT)[BETWEEN].value_counts().sort_index()
    if sizes.nunique() > 1:
        listed = ", ".join(f"{g}: {n}" for g, n in sizes.items())
        notes.append(
            f"Unbalanced design in the {dv} ANOVA of {system} ({listed}): type {ss_type} sums of squares"
            + (" (afex's default; equal weight per group)." if ss_type == 3 else " (groups weighted by size).")
        )
    violated = anova[anova["p_mauchly"] < SPHERICITY_ALPHA]
    if len(violated):
        row = violated.iloc[0]
        notes.append(
            f"Sphericity violated for {' and '.join(violated['source'])} in the {dv} ANOVA of {system} "
            f"(Mauchly W = {row['W_mauchly']:.3f}, p = {row['p_mauchly']:.3g}): Greenhouse-Geisser correction "
            f"applied (epsilon = {row['eps_GG']:.3f})."
        )
    return notes
