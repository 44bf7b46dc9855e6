"""What a calibration fits: numbers (``Target``) taken from a pilot's trials or from a file of
published summary numbers (``read_targets``), each with its standard error.

A targets file (``microg participant calibrate --targets FILE.toml``)::

    protocol = "paper"          # the protocol whose study is simulated (a name, or a file relative
                                # to this one); --protocol overrides it
    source = "Zhou et al., Table 1 and Fig. 11"
    n_per_group = 15            # participants per group the numbers come from

    [[targets]]                 # time with the paper's model: mean and SD over participants
    measure = "time_s"          # time_s, attempts or completed
    interaction = "impulse_penetration"   # where: group, phase, interaction, object (omitted: all)
    mean = 51.7                 # se = sd / sqrt(N) (N: the participants in the selection)
    sd = 19.4                   # se = sd / sqrt(2 (N - 1))

    [[targets]]                 # an effect: beginners make about twice the attempts of veterans
    measure = "attempts"
    group = "B"
    versus = { group = "V" }    # a ratio of means: this selection over the same with these keys changed
    ratio = 2.0
    se = 0.25                   # a ratio's standard error is on the log scale (0.25: about 25 %)
    held_out = true             # reported in the predictive check, not fitted

    [[targets]]                 # a direction: the flat cuboid takes longer than the cube
    measure = "time_s"
    object = "F"
    versus = { object = "C" }
    above = 1.0                 # (or below = ...): any ratio beyond the bound fits exactly
    se = 0.1

Every number of a target (``mean``, ``sd``, ``ratio``, ``above``, ``below``, ``slope``) is one
target. ``se`` may be given for a single number and is required where it cannot be derived (a
mean without its SD, a ratio, a direction, a slope). Errors name the file, the key and the value.
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from microg.study.protocol import Protocol

from .summaries import MEASURES, WHERE, Statistic, bootstrap_se, participant_cells, study_statistics, summarise

MISSING_Z = 10.0
"""How many standard errors off a number counts when a simulated study cannot show it (no
completed task in a cell): far, but finite, so that every simulated study has a distance."""
NUMBERS = ("mean", "sd", "ratio", "above", "below", "slope")
TARGET_KEYS = ("measure", *WHERE, "versus", *NUMBERS, "se", "n", "held_out")
FILE_KEYS = ("protocol", "source", "n_per_group", "targets")
MIN_ERROR = 1e-9
"""The smallest standard error a target may have: a gap in standard errors (``Target.z``) beyond
1e150 squares to infinity, and no measurement is exact to 1e-9."""


class TargetError(ValueError):
    """Data or a targets file that cannot be fitted; the message names the file, key and value."""


@dataclass(frozen=True)
class Target:
    """One number to fit: a statistic, its value and standard error, whether it is held out."""

    statistic: Statistic
    value: float
    se: float
    """Standard error (for ratios and directions on the log scale)."""
    held_out: bool = False
    direction: str | None = None
    """``above`` or ``below``: the ratio need only lie beyond ``value``; None: equal it."""

    @property
    def key(self) -> str:
        sign = {"above": ">", "below": "<"}.get(self.direction, "")
        return self.statistic.key + (f"{sign}{self.value:g}" if sign else "")

    def z(self, simulated: float) -> float:
        """How many standard errors the simulated value is from the target (0: on target)."""
        if not math.isfinite(simulated) or (self.statistic.compares and simulated <= 0):
            return MISSING_Z
        if not self.statistic.compares:
            return (simulated - self.value) / self.se
        gap = math.log(simulated) - math.log(self.value)
        if self.direction == "above":
            gap = min(gap, 0.0)
        elif self.direction == "below":
            gap = max(gap, 0.0)
        return gap / self.se


def data_targets(trials: pd.DataFrame, source: str, seed: int) -> tuple[list[Target], list[str]]:
    """The targets a pilot's trials show (``summaries.study_statistics``), their values and
    bootstrap standard errors; and what of the table is not used, in words.

    Raises TargetError when a group has fewer than two participants (no SD between people)."""
    cells = participant_cells(trials)
    if cells.empty:
        raise TargetError(f"{source}: no task that ran; nothing to calibrate to")
    people = cells.groupby("group")["participant"].nunique()
    for group, count in people.items():
        if count < 2:
            raise TargetError(f"{source}: group = {group!r}: {count} participant; a calibration needs at least two "
                              "per group (an SD between people)")
    statistics = study_statistics(trials)
    values = summarise(trials, statistics)["value"].to_numpy()
    se = bootstrap_se(trials, statistics, seed)
    targets = [Target(s, float(v), float(e)) for s, v, e in zip(statistics, values, se)]
    unused = ["the questionnaire", "each task's order position and clock times",
              "cells with fewer than two participants"]
    left = set(trials["participant"]) - set(cells["participant"])
    if left:
        unused.append(f"withdrawn participants or ones without a task that ran: {', '.join(sorted(map(str, left)))}")
    return targets, unused


@dataclass(frozen=True)
class TargetsFile:
    """A parsed targets file."""

    targets: tuple[Target, ...]
    protocol: str | None
    source: str
    n_per_group: int


def read_targets(path: str | Path) -> dict:
    """The parsed TOML of a targets file (checked with ``targets_from_dict`` once the protocol is known)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise TargetError(f"{path}: no such targets file") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise TargetError(f"{path}: cannot be read as TOML: {error}") from None
    unknown = sorted(set(data) - set(FILE_KEYS))
    if unknown:
        raise TargetError(f"{path}: {unknown[0]}: unknown key (known: {', '.join(FILE_KEYS)})")
    protocol = data.get("protocol")
    if protocol is not None and not isinstance(protocol, str):
        raise TargetError(f"{path}: protocol = {protocol!r}: must be a protocol name or file")
    return data


def targets_from_dict(data: dict, protocol: Protocol, where: str) -> TargetsFile:
    """The targets of a parsed targets file, checked against ``protocol`` (the groups, phases,
    interaction models and objects it names must be the protocol's)."""
    n = data.get("n_per_group")
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise TargetError(f"{where}: n_per_group = {n!r}: must be a whole number of at least 2 (the participants "
                          "per group the numbers come from)")
    entries = data.get("targets")
    if not isinstance(entries, list) or not entries:
        raise TargetError(f"{where}: targets = {entries!r}: give at least one [[targets]] table")
    known = _known_values(protocol)
    targets, given = [], {}
    for i, entry in enumerate(entries):
        at = f"{where}: targets[{i}]"
        if not isinstance(entry, dict):
            raise TargetError(f"{at} = {entry!r}: must be a table")
        for target in _entry_targets(entry, at, known, n, len(protocol.groups)):
            if target.key in given:
                raise TargetError(f"{at}: {target.key} is given already by {given[target.key]}; give each number once")
            given[target.key] = f"targets[{i}]"
            targets.append(target)
    source = data.get("source", where)
    return TargetsFile(tuple(targets), data.get("protocol"), str(source), n)


def _known_values(protocol: Protocol) -> dict[str, dict[str, str]]:
    """For each selection column, the values it may take: code or name -> code."""
    groups = {g.code: g.code for g in protocol.groups} | {g.name: g.code for g in protocol.groups}
    objects = protocol.objects + (protocol.training.objects if protocol.training else ())
    phases = [p.name for p in protocol.phases] + (["training"] if protocol.training else [])
    interactions = [p.interaction for p in protocol.phases] + ([protocol.training.interaction] if protocol.training else [])
    return {
        "group": groups,
        "session": {plan.name: plan.name for plan in protocol.sessions},
        "phase": {p: p for p in phases},
        "interaction": {i: i for i in interactions},
        "object": {o.code: o.code for o in objects} | {o.name: o.code for o in objects},
    }


def _selection(entry: dict, at: str, known: dict) -> tuple[tuple[str, str], ...]:
    where = []
    for column in WHERE:
        if column not in entry:
            continue
        value = entry[column]
        if not isinstance(value, str) or value not in known[column]:
            raise TargetError(f"{at}.{column} = {value!r}: unknown {column} (known: "
                              f"{', '.join(sorted(set(known[column].values())))})")
        where.append((column, known[column][value]))
    return tuple(where)


def _versus(where, changed) -> tuple[tuple[str, str], ...]:
    """A ratio's denominator: the selection ``where`` with the keys of ``changed`` changed (a phase
    names its interaction model, so changing one of the two drops the other), in ``WHERE``'s order."""
    keys = dict(changed)
    linked = {"phase", "interaction"}
    kept = {column: value for column, value in where if not (column in linked and linked & keys.keys())}
    merged = kept | keys
    return tuple((column, merged[column]) for column in WHERE if column in merged)


def _number(entry: dict, key: str, at: str, positive: bool = False) -> float:
    value = entry[key]
    signed = key == "slope"
    number = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    if not number or (positive and value <= 0) or (not signed and value < 0):
        kind = "a positive number" if positive else "a finite number" + ("" if signed else " >= 0")
        raise TargetError(f"{at}.{key} = {value!r}: must be {kind}")
    return float(value)


def _entry_targets(entry: dict, at: str, known: dict, n_per_group: int, groups: int) -> list[Target]:
    unknown = sorted(set(entry) - set(TARGET_KEYS))
    if unknown:
        raise TargetError(f"{at}.{unknown[0]}: unknown key (known: {', '.join(TARGET_KEYS)})")
    measure = entry.get("measure")
    if measure not in MEASURES:
        raise TargetError(f"{at}.measure = {measure!r}: unknown measure (known: {', '.join(MEASURES)})")
    where = _selection(entry, at, known)
    given = [key for key in NUMBERS if key in entry]
    if not given:
        raise TargetError(f"{at}: no number to fit; give one of {', '.join(NUMBERS)}")
    ratios = [key for key in given if key in ("ratio", "above", "below")]
    if ratios and len(given) > 1:
        raise TargetError(f"{at}.{ratios[0]}: a ratio or direction is a target of its own (not with "
                          f"{', '.join(k for k in given if k != ratios[0])})")
    if "slope" in given and len(given) > 1:
        raise TargetError(f"{at}.slope: the practice slope is a target of its own")
    versus = ()
    if ratios:
        if not isinstance(entry.get("versus"), dict) or not entry["versus"]:
            raise TargetError(f"{at}.versus = {entry.get('versus')!r}: a {ratios[0]} needs the selection it is "
                              "compared with, e.g. versus = { group = \"V\" }")
        extra = sorted(set(entry["versus"]) - set(WHERE))
        if extra:
            raise TargetError(f"{at}.versus.{extra[0]}: unknown key (known: {', '.join(WHERE)})")
        versus = _versus(where, _selection(entry["versus"], f"{at}.versus", known))
        if versus == where:
            raise TargetError(f"{at}.versus = {entry['versus']!r}: compares the selection with itself")
    elif "versus" in entry:
        raise TargetError(f"{at}.versus: only a ratio, above or below compares with another selection")
    if "se" in entry and len(given) > 1:
        raise TargetError(f"{at}.se: give se only for a single number (mean and sd derive theirs from n)")
    held_out = entry.get("held_out", False)
    if not isinstance(held_out, bool):
        raise TargetError(f"{at}.held_out = {held_out!r}: must be true or false")
    selected_groups = 1 if any(column == "group" for column, _ in where) else groups
    people = _people(entry, at, n_per_group * selected_groups)
    se = _number(entry, "se", at, positive=True) if "se" in entry else None
    targets = []
    for key in given:
        value = _number(entry, key, at, positive=key in ("ratio", "above", "below"))
        if measure == "completed" and key in ("mean", "sd") and not 0.0 <= value <= 1.0:
            raise TargetError(f"{at}.{key} = {value!r}: a share of tasks completed lies from 0 to 1")
        if key == "mean":
            statistic = Statistic(measure, "mean", where)
            error = se if se is not None else _need_sd(entry, at) / math.sqrt(people)
        elif key == "sd":
            statistic = Statistic(measure, "sd", where)
            if se is None and people < 2:
                raise TargetError(f"{at}.n = {people}: an SD between people needs at least two (or give se)")
            error = se if se is not None else value / math.sqrt(2 * (people - 1))
        elif key == "slope":
            statistic = Statistic(measure, "slope", where)
            error = _need_se(se, at, key)
        else:
            statistic = Statistic(measure, "ratio", where, versus)
            error = _need_se(se, at, key)
        if error <= 0.0:
            raise TargetError(f"{at}.sd = {entry['sd']!r}: gives a standard error of 0, which would outweigh every "
                              "other number; give se")
        if error < MIN_ERROR:
            raise TargetError(f"{at}: a standard error of {error:g} (from {'se' if se is not None else 'sd and n'}) "
                              f"is below {MIN_ERROR:g}: no data are that exact, and the fit's distance would "
                              "overflow; give the number's real standard error")
        targets.append(Target(statistic, value, error, held_out, key if key in ("above", "below") else None))
    return targets


def _people(entry: dict, at: str, otherwise: int) -> int:
    """How many participants a target's numbers come from: its own ``n`` (a whole number), else the
    file's ``n_per_group`` times the groups selected."""
    if "n" not in entry:
        return otherwise
    n = _number(entry, "n", at, positive=True)
    if n != int(n):
        raise TargetError(f"{at}.n = {entry['n']!r}: must be a whole number of participants")
    return int(n)


def _need_sd(entry: dict, at: str) -> float:
    if "sd" not in entry:
        raise TargetError(f"{at}.mean: a mean without its sd needs se (its standard error)")
    return _number(entry, "sd", at)


def _need_se(se: float | None, at: str, key: str) -> float:
    if se is None:
        raise TargetError(f"{at}.{key}: needs se (its standard error{', on the log scale' if key != 'slope' else ''})")
    return se


def simulated_values(trials: pd.DataFrame, targets) -> np.ndarray:
    """The targets' statistics in one simulated study (``summaries.summarise``)."""
    return summarise(trials, [t.statistic for t in targets])["value"].to_numpy()


@dataclass(frozen=True)
class Source:
    """What a calibration fits: the protocol to simulate, the targets, and where they came from."""

    protocol: Protocol
    targets: tuple[Target, ...]
    source: str
    digest: str
    """The SHA-256 of the data (the trials as CSV, or the file's bytes)."""
    participants: int
    """Participants per group of the data (the smallest group's)."""
    unused: tuple[str, ...] = ()


def study_source(study: str | Path, seed: int) -> Source:
    """The targets of a study folder's trials, with the study's own protocol."""
    from microg.study.export import trials_table
    from microg.study.store import open_study

    with open_study(study, readonly=True) as store:
        trials, protocol = trials_table(store), store.protocol
    return _trials_source(trials, protocol, str(study),
                          hashlib.sha256(trials.to_csv(index=False).encode()).hexdigest(), seed)


def trials_source(path: str | Path, protocol: Protocol, seed: int) -> Source:
    """The targets of an exported trials table (CSV or Parquet), simulated with ``protocol``."""
    from microg.analysis.tables import AnalysisInputError, check_trials, read_table

    path = Path(path)
    try:
        trials = read_table(path, text=("participant", "group", "phase", "interaction", "object"))
    except (AnalysisInputError, FileNotFoundError) as error:
        raise TargetError(f"--trials: {error}") from None
    missing = [c for c in ("participant", "group", "phase", "interaction", "object", "completed", "time_s",
                           "attempts", "task_index") if c not in trials]  # fmt: skip
    if missing:
        raise TargetError(f"{path}: no column {missing[0]!r} (a trials table as microg export writes it)")
    try:  # the report's checks: numbers where numbers belong, True/False flags, a time for every completed task
        trials = check_trials(trials, str(path), dv=("time_s", "attempts", "task_index"),
                              counts=("attempts", "task_index"), design=False)
    except AnalysisInputError as error:
        raise TargetError(str(error)) from None
    for column in ("phase", "task_index"):
        if trials[column].isna().any():
            row = int(trials[column].isna().to_numpy().argmax())
            raise TargetError(f"{path}: column {column!r} is empty (data row {row + 1}, participant "
                              f"{trials['participant'].iloc[row]!r})")
    return _trials_source(trials, protocol, str(path), hashlib.sha256(path.read_bytes()).hexdigest(), seed)


def _trials_source(trials: pd.DataFrame, protocol: Protocol, source: str, digest: str, seed: int) -> Source:
    known = _known_values(protocol)
    for column in (c for c in WHERE if c in trials or c != "session"):  # a table of one session may lack it
        values = set(trials[column].dropna().astype(str))
        strange = sorted(values - set(known[column].values()))
        if strange:
            raise TargetError(f"{source}: {column} = {strange[0]!r}: not in protocol {protocol.name!r} "
                              f"(known: {', '.join(sorted(set(known[column].values())))})")
    targets, unused = data_targets(trials, source, seed)
    people = participant_cells(trials).groupby("group")["participant"].nunique()
    return Source(protocol, tuple(targets), source, digest, int(people.min()), tuple(unused))


def file_source(path: str | Path, protocol: Protocol | None = None) -> Source:
    """The targets of a targets file, simulated with ``protocol`` (None: the file's ``protocol``,
    a name or a file relative to it; without one, the paper's)."""
    from microg.paths import protocol_file
    from microg.study.protocol import ProtocolError, load_protocol

    path = Path(path)
    data = read_targets(path)
    if protocol is None:
        named = data.get("protocol", "paper")
        beside = path.parent / named
        try:
            protocol = load_protocol(beside if beside.suffix == ".toml" and beside.exists() else protocol_file(named))
        except (ProtocolError, FileNotFoundError) as error:
            raise TargetError(f"{path}: protocol = {named!r}: {error}") from None
    parsed = targets_from_dict(data, protocol, str(path))
    return Source(protocol, parsed.targets, f"{parsed.source} ({path})", hashlib.sha256(path.read_bytes()).hexdigest(),
                  parsed.n_per_group, ("everything the file does not name",))
