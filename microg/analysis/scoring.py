"""Questionnaire scores by the instruments' published keys, in one place: ``microg questionnaire
score``, the export's ``scores.csv`` and the report all call :func:`score_answers`.

The answers are a tidy table, one row per answer: ``participant, instrument, item, value`` and,
optionally, ``administration`` (when it was asked: ``pre``, ``post``, ...) and ``interaction`` (the
interaction model it is about). The scores are one row per participant, instrument, administration,
interaction model and scale: ``participant, instrument, administration, interaction, scale, score``.
A scale one of whose items was not answered is not scored (its score is empty) and
:func:`missing_items` lists the item; nothing missing ever counts as zero. NASA-TLX's weighted
score needs all 15 pairwise comparisons; when none of them was asked, the scale is left out.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from microg.analysis.tables import AnalysisInputError
from microg.instruments import Instrument, InstrumentError, Scale, load_instrument
from microg.schema import SCORE_COLUMNS

ANSWER_COLUMNS = ("participant", "instrument", "item", "value")
ANSWER_KEYS = ("administration", "interaction")
"""Optional columns of the answers table; absent or empty, an answer was asked once, about no interaction model."""
MISSING_COLUMNS = ("participant", "instrument", "administration", "interaction", "item", "scales")
GROUP = ("participant", "instrument", "administration", "interaction")
"""One filling-in of an instrument: its answers are scored together."""


def instruments_for(answers: pd.DataFrame, given: Mapping[str, Instrument] | None = None,
                    source: str = "answers table") -> dict[str, Instrument]:
    """The instruments the answers name: ``given`` ones (a study's own, by id), else the shipped ones."""
    known = dict(given or {})
    for row, name in enumerate(answers["instrument"].astype(str)):
        if name not in known:
            try:
                known[name] = load_instrument(name)
            except InstrumentError as error:
                raise AnalysisInputError(f"{source}: column 'instrument' value {name!r} (data row {row + 1}): "
                                         f"{error}") from None
    return known


def check_answers(answers: pd.DataFrame, instruments: Mapping[str, Instrument] | None = None,
                  source: str = "answers table") -> pd.DataFrame:
    """Check an answers table and return a tidy copy: the key columns as text (empty for an answer
    asked once, about no interaction model) and each value read as its item reads it.

    Parameters
    ----------
    answers : pandas.DataFrame
        Columns ``participant, instrument, item, value``; optionally ``administration`` and ``interaction``.
    instruments : mapping of str to Instrument, optional
        The instruments by id; the shipped ones are used for any other the table names.
    source : str
        How messages name the table (its file).

    Returns
    -------
    pandas.DataFrame
        The checked copy, with ``administration`` and ``interaction``.

    Raises
    ------
    AnalysisInputError
        For a missing column, an unknown instrument or item, a value off its item's scale (naming
        the participant, the item and the value) or an item answered twice.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.scoring import check_answers
    >>> check_answers(pd.DataFrame({"participant": ["P1"], "instrument": ["ssq"], "item": ["ssq03"], "value": ["5"]}))
    Traceback (most recent call last):
    ...
    microg.analysis.tables.AnalysisInputError: answers table: participant 'P1', ssq item ssq03: value '5' is off the scale 0-3 (data row 1)
    """
    missing = [c for c in ANSWER_COLUMNS if c not in answers.columns]
    if missing:
        raise AnalysisInputError(f"{source}: missing column {missing[0]!r} (columns present: "
                                 f"{', '.join(map(str, answers.columns))}; an answers table has "
                                 f"{', '.join(ANSWER_COLUMNS)} and optionally {', '.join(ANSWER_KEYS)})")
    out = answers.reset_index(drop=True).copy()
    for column in ANSWER_KEYS:
        out[column] = out[column] if column in out.columns else ""
    for column in (*GROUP, "item"):
        blank = out[column].isna() | (out[column].astype(str).str.strip() == "")
        if column in ANSWER_KEYS:
            out[column] = out[column].where(~blank, "")
        elif blank.any():
            raise AnalysisInputError(f"{source}: column {column!r} is empty (data row {int(np.argmax(blank)) + 1})")
        out[column] = out[column].astype(str).str.strip()
    known = instruments_for(out, instruments, source)
    values = []
    for row, answer in enumerate(out.itertuples(index=False)):
        instrument = known[answer.instrument]
        who = f"{source}: participant {answer.participant!r}, {instrument.id} item {answer.item}"
        if answer.item not in {i.id for i in instrument.items}:
            raise AnalysisInputError(f"{who}: no such item in {instrument.where} (items: "
                                     f"{', '.join(i.id for i in instrument.items)}) (data row {row + 1})")
        if pd.isna(answer.value) or str(answer.value).strip() == "":
            raise AnalysisInputError(f"{who}: the value is empty (data row {row + 1}); leave out an item that "
                                     "was not answered")
        try:
            values.append(instrument.item(answer.item).read(answer.value))
        except ValueError as error:
            raise AnalysisInputError(f"{who}: value {answer.value!r} {error} (data row {row + 1})") from None
    out["value"] = pd.Series(values, index=out.index, dtype=object)
    twice = out.duplicated([*GROUP, "item"])
    if twice.any():
        row = out[twice].iloc[0]
        raise AnalysisInputError(f"{source}: participant {row.participant!r} answered {row.instrument} item "
                                 f"{row['item']} twice (administration {row.administration!r}, interaction "
                                 f"{row.interaction!r}; data row {int(np.flatnonzero(twice)[0]) + 1})")
    return out


def score_answers(answers: pd.DataFrame, instruments: Mapping[str, Instrument] | None = None,
                  source: str = "answers table") -> pd.DataFrame:
    """Every scale of every filling-in of an instrument, scored by the instrument's key.

    Parameters
    ----------
    answers : pandas.DataFrame
        The answers (see :func:`check_answers`).
    instruments : mapping of str to Instrument, optional
        The instruments by id; the shipped ones are used for any other the table names.
    source : str
        How messages name the table.

    Returns
    -------
    pandas.DataFrame
        Columns SCORE_COLUMNS, one row per participant, instrument, administration, interaction model
        and scale (in the instrument's order); ``score`` is empty where an item is missing.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.scoring import score_answers
    >>> answers = pd.DataFrame({"participant": "P1", "instrument": "sus", "item": [f"sus{k:02d}" for k in range(1, 11)],
    ...                         "value": [4, 2, 4, 1, 3, 2, 5, 2, 4, 3]})
    >>> score_answers(answers)[["scale", "score"]]
      scale  score
    0   sus   75.0
    """
    tidy = check_answers(answers, instruments, source)
    known = instruments_for(tidy, instruments)
    rows = []
    for key, group in tidy.groupby(list(GROUP), sort=False):
        instrument = known[key[1]]
        given = dict(zip(group["item"], group["value"]))
        for scale in instrument.scales:
            if _asked(instrument, scale, given):
                rows.append((*key, scale.name, _score(instrument, scale, given)))
    return pd.DataFrame(rows, columns=list(SCORE_COLUMNS)).astype({"score": float})


def missing_items(answers: pd.DataFrame, instruments: Mapping[str, Instrument] | None = None,
                  source: str = "answers table") -> pd.DataFrame:
    """The items a scale needs that a filling-in of its instrument lacks, and the scales left unscored.

    Parameters
    ----------
    answers, instruments, source
        As for :func:`score_answers`.

    Returns
    -------
    pandas.DataFrame
        Columns MISSING_COLUMNS; ``scales`` lists the scales the item leaves unscored.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.scoring import missing_items
    >>> answers = pd.DataFrame({"participant": "P1", "instrument": "ipq", "item": ["G1", "SP1"], "value": [3, 4]})
    >>> missing_items(answers)[["item", "scales"]].head(2)
      item   scales
    0  SP2  spatial
    1  SP3  spatial
    """
    tidy = check_answers(answers, instruments, source)
    known = instruments_for(tidy, instruments)
    rows = []
    for key, group in tidy.groupby(list(GROUP), sort=False):
        instrument = known[key[1]]
        given = dict(zip(group["item"], group["value"]))
        lacking: dict[str, list[str]] = {}
        for scale in instrument.scales:
            if _asked(instrument, scale, given):
                for item in _needs(instrument, scale):
                    if item not in given:
                        lacking.setdefault(item, []).append(scale.name)
        rows += [(*key, item, ", ".join(scales)) for item, scales in lacking.items()]
    return pd.DataFrame(rows, columns=list(MISSING_COLUMNS))


def _needs(instrument: Instrument, scale: Scale) -> tuple[str, ...]:
    """The items a scale is scored from, and for a weighted scale the choices that weigh it."""
    weights = tuple(i.id for i in instrument.weights_of(scale)) if scale.score == "weighted" else ()
    return instrument.scale_items(scale) + weights


def _asked(instrument: Instrument, scale: Scale, given: dict) -> bool:
    """A weighted scale whose choices were none of them asked was not asked (the raw NASA-TLX)."""
    return scale.score != "weighted" or any(i.id in given for i in instrument.weights_of(scale))


def _score(instrument: Instrument, scale: Scale, given: dict) -> float:
    if any(item not in given for item in _needs(instrument, scale)):
        return float("nan")
    if scale.scales:
        return scale.weight * sum(_counted(instrument, instrument.scale(name), given).sum() for name in scale.scales)
    counted = _counted(instrument, scale, given)
    if scale.score == "sum":
        raw = counted.sum()
    elif scale.score == "mean":
        raw = counted.mean()
    else:
        chosen = [given[i.id] for i in instrument.weights_of(scale)]
        weights = np.array([chosen.count(item) for item in scale.items], dtype=float)
        raw = counted @ weights / weights.sum()
    return float(scale.weight * raw)


def _counted(instrument: Instrument, scale: Scale, given: dict) -> np.ndarray:
    """The scale's ratings as its key counts them: reversed where marked, from the scale's bottom when asked."""
    items = [instrument.item(item_id) for item_id in scale.items]
    return np.array([item.keyed(float(given[item.id])) - (item.response.low if scale.from_minimum else 0.0)
                     for item in items])
