"""The questionnaires in the report: per instrument, its scores per interaction model and administration,
the paired comparison between interaction models, the change between administrations (SSQ's post
minus pre), and internal consistency, each a tidy DataFrame from the scores of
:func:`microg.analysis.scoring.score_answers`.

The test that fits the scale: a single item of at most 11 points is ordinal, and two of its scores
are compared by the Wilcoxon signed-rank test; a score made of several items (a sum or a mean) is
compared by the paired t-test, unless the Shapiro-Wilk test rejects normal paired differences at
``alpha``, when the Wilcoxon signed-rank test is read instead. Both tests are in the table; ``test``
and ``p`` say which one is read, ``p_bonf`` corrects it over the instrument's scales compared
together (Bonferroni).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pingouin as pg

from microg.analysis.anova import CONFIDENCE
from microg.analysis.paired import compare_interactions
from microg.analysis.scoring import check_answers, instruments_for, score_answers
from microg.analysis.tables import stars
from microg.instruments import Instrument

SUMMARY_COLUMNS = ("instrument", "scale", "administration", "interaction", "n", "mean", "sd", "median", "q1", "q3",
                   "iqr")  # fmt: skip
COMPARISON_COLUMNS = (
    "instrument", "scale", "compared", "first", "second", "held", "test", "n", "mean_first", "sd_first",
    "mean_second", "sd_second", "median_first", "median_second", "mean_diff", "diff_ci_low", "diff_ci_high", "T",
    "dof", "p_t", "d_z", "d_z_ci_low", "d_z_ci_high", "V", "p_wilcoxon", "rbc", "rbc_ci_low", "rbc_ci_high",
    "p_shapiro", "p", "p_bonf", "stars",
)  # fmt: skip
"""``compared``: ``interaction`` (first = the interaction model under test, second = the baseline, held = the
administration) or ``administration`` (first = a later administration, second = the first one, held = the
interaction model, "" for none); differences are first - second."""
CONSISTENCY_COLUMNS = ("instrument", "scale", "administration", "interaction", "n", "items", "alpha", "alpha_ci_low",
                       "alpha_ci_high")  # fmt: skip
WILCOXON, PAIRED_T = "Wilcoxon signed-rank", "paired t"
MIN_PAIRS = 3
ORDINAL_POINTS = 11
"""A single item with at most this many points is ordinal (the paper's 0-10 ratings have 11)."""


def score_summary(scores: pd.DataFrame) -> pd.DataFrame:
    """Mean, SD, median and quartiles of each scale per instrument, administration and interaction model.

    Parameters
    ----------
    scores : pandas.DataFrame
        :func:`microg.analysis.scoring.score_answers` (``participant, instrument, administration,
        interaction, scale, score``).

    Returns
    -------
    pandas.DataFrame
        Columns SUMMARY_COLUMNS, in the order the scores list them; quartiles by linear interpolation
        (R's default); n counts the scored participants (an unscored scale is left out).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.questionnaires import score_summary
    >>> scores = pd.DataFrame({"participant": ["a", "b", "c"], "instrument": "sus", "administration": "end",
    ...                        "interaction": "s", "scale": "sus", "score": [50.0, 75.0, 90.0]})
    >>> score_summary(scores)[["scale", "n", "mean", "median", "iqr"]]
      scale  n       mean  median   iqr
    0   sus  3  71.666667    75.0  20.0
    """
    rows = []
    keys = ["instrument", "scale", "administration", "interaction"]
    for key, group in scores.dropna(subset=["score"]).groupby(keys, sort=False):
        values = group["score"].to_numpy(float)
        q1, median, q3 = np.percentile(values, [25, 50, 75])
        rows.append((*key, len(values), values.mean(), values.std(ddof=1) if len(values) > 1 else np.nan, median,
                     q1, q3, q3 - q1))
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))


def compare_scores(scores: pd.DataFrame, instruments: Mapping[str, Instrument], interaction: str, baseline: str,
                   alpha: float = 0.05) -> pd.DataFrame:
    """Each scale of ``interaction`` against ``baseline`` on the same participants, per instrument and
    administration, by the test that fits the scale (module docstring).

    Parameters
    ----------
    scores : pandas.DataFrame
        :func:`microg.analysis.scoring.score_answers`.
    instruments : mapping of str to Instrument
        The instruments of the scores, by id.
    interaction, baseline : str
        The interaction models compared (values of ``interaction``); differences are interaction - baseline.
    alpha : float
        Level of the Shapiro-Wilk test that chooses the Wilcoxon test for a multi-item score.

    Returns
    -------
    pandas.DataFrame
        Columns COMPARISON_COLUMNS with ``compared`` = ``interaction``; scales with fewer than 3
        participants scored for both are left out.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.questionnaires import compare_scores
    >>> from microg.instruments import load_instrument
    >>> scores = pd.DataFrame({"participant": [f"P{i}" for i in range(5)] * 2, "instrument": "sus",
    ...                        "administration": "end", "interaction": ["s"] * 5 + ["b"] * 5, "scale": "sus",
    ...                        "score": [80, 72.5, 90, 65, 85, 60, 70, 75, 50, 62.5]})
    >>> row = compare_scores(scores, {"sus": load_instrument("sus")}, "s", "b").iloc[0]
    >>> row["test"], int(row["n"]), float(row["mean_diff"]), round(float(row["p"]), 4)  # t(4) = 15 / (7.71 / sqrt 5)
    ('paired t', 5, 15.0, 0.0121)
    """
    rows = []
    chosen = scores[scores["interaction"].isin([interaction, baseline])]
    for (name, administration), group in chosen.groupby(["instrument", "administration"], sort=False):
        for scale in instruments[name].scales:
            values = group[group["scale"] == scale.name]
            row = _paired(values, "interaction", interaction, baseline, instruments[name], scale.name, alpha)
            if row is not None:
                rows.append({**row, "compared": "interaction", "held": administration})
    return _corrected(rows)


def score_changes(scores: pd.DataFrame, instruments: Mapping[str, Instrument], alpha: float = 0.05) -> pd.DataFrame:
    """Each later administration of an instrument against its first on the same participants (SSQ's
    post minus pre), per interaction model asked about ("" for none), by the test that fits the scale.

    Parameters
    ----------
    scores, instruments, alpha
        As for :func:`compare_scores`.

    Returns
    -------
    pandas.DataFrame
        Columns COMPARISON_COLUMNS with ``compared`` = ``administration``, first = the later
        administration, second = the first (in the order the scores list them).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.questionnaires import score_changes
    >>> from microg.instruments import load_instrument
    >>> scores = pd.DataFrame({"participant": [f"P{i}" for i in range(6)] * 2, "instrument": "ssq",
    ...                        "administration": ["pre"] * 6 + ["post"] * 6, "interaction": "", "scale": "total",
    ...                        "score": [0, 3.74, 7.48, 0, 3.74, 0, 11.22, 18.7, 7.48, 29.92, 14.96, 3.74]})
    >>> row = score_changes(scores, {"ssq": load_instrument("ssq")}).iloc[0]
    >>> row["first"], row["second"], row["test"], round(float(row["mean_diff"]), 2)  # (86.02 - 14.96) / 6
    ('post', 'pre', 'paired t', 11.84)
    """
    rows = []
    for (name, about), group in scores.groupby(["instrument", "interaction"], sort=False):
        order = list(dict.fromkeys(group["administration"]))
        for later in order[1:]:
            for scale in instruments[name].scales:
                values = group[group["scale"] == scale.name]
                row = _paired(values, "administration", later, order[0], instruments[name], scale.name, alpha)
                if row is not None:
                    rows.append({**row, "compared": "administration", "held": about})
    return _corrected(rows)


def internal_consistency(answers: pd.DataFrame, instruments: Mapping[str, Instrument]) -> pd.DataFrame:
    """Cronbach's alpha (pingouin) with its 95 % CI of every scale made of two or more items, per
    administration and interaction model, on the participants who answered all its items.

    Parameters
    ----------
    answers : pandas.DataFrame
        :func:`microg.analysis.scoring.check_answers` of the answers (values read by their items).
    instruments : mapping of str to Instrument
        The instruments, by id.

    Returns
    -------
    pandas.DataFrame
        Columns CONSISTENCY_COLUMNS; reversed items count reversed. NASA-TLX's weighted score is
        not a sum of items and has none; fewer than 3 complete participants give none.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.questionnaires import internal_consistency
    >>> from microg.instruments import load_instrument
    >>> # each participant rates the five spatial items alike once SP2 is reversed (6 - rating): alpha is 1
    >>> ratings = {"P1": [1, 5, 1, 1, 1], "P2": [3, 3, 3, 3, 3], "P3": [5, 1, 5, 5, 5], "P4": [2, 4, 2, 2, 2]}
    >>> answers = pd.DataFrame([(who, "ipq", "after", "s", f"SP{k + 1}", v) for who, row in ratings.items()
    ...                         for k, v in enumerate(row)], columns=["participant", "instrument", "administration",
    ...                                                               "interaction", "item", "value"])
    >>> internal_consistency(answers, {"ipq": load_instrument("ipq")})[["scale", "n", "items", "alpha"]]
         scale  n  items  alpha
    0  spatial  4      5    1.0
    """
    rows = []
    keys = ["instrument", "administration", "interaction"]
    for (name, administration, about), group in answers.groupby(keys, sort=False):
        instrument = instruments[name]
        for scale in instrument.scales:
            items = instrument.scale_items(scale)
            if scale.score == "weighted" or len(items) < 2:
                continue
            wide = group[group["item"].isin(items)].pivot(index="participant", columns="item", values="value")
            wide = wide.reindex(columns=list(items)).dropna().astype(float)
            for item_id in items:
                wide[item_id] = wide[item_id].map(instrument.item(item_id).keyed)
            if len(wide) < MIN_PAIRS:
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                value, (low, high) = pg.cronbach_alpha(data=wide, ci=CONFIDENCE)
            rows.append((name, scale.name, administration, about, len(wide), len(items), value, low, high))
    return pd.DataFrame(rows, columns=list(CONSISTENCY_COLUMNS))


def fitting_test(instrument: Instrument, scale: str, p_shapiro: float, alpha: float = 0.05) -> str:
    """The test read for a scale (module docstring): ``Wilcoxon signed-rank`` or ``paired t``."""
    items = instrument.scale_items(instrument.scale(scale))
    single = len(items) == 1 and len(instrument.item(items[0]).response.points) <= ORDINAL_POINTS
    return WILCOXON if single or (np.isfinite(p_shapiro) and p_shapiro < alpha) else PAIRED_T


def _paired(values: pd.DataFrame, column: str, first: str, second: str, instrument: Instrument, scale: str,
            alpha: float) -> dict | None:
    """One comparison row (without the family's correction), or None below MIN_PAIRS pairs."""
    wide = values.pivot(index="participant", columns=column, values="score")
    if first not in wide.columns or second not in wide.columns:
        return None
    wide = wide[[first, second]].dropna()
    if len(wide) < MIN_PAIRS:
        return None
    cells = wide.stack().rename("score").reset_index().assign(object="all")
    result = compare_interactions(cells, "score", first, second, "object", "participant", column).iloc[0]
    test = fitting_test(instrument, scale, result["p_shapiro"], alpha)
    return {"instrument": instrument.id, "scale": scale, "first": first, "second": second, "test": test,
            "n": int(result["n"]), "mean_first": result["mean_interaction"], "sd_first": result["sd_interaction"],
            "mean_second": result["mean_baseline"], "sd_second": result["sd_baseline"],
            "median_first": wide[first].median(), "median_second": wide[second].median(),
            **{k: result[k] for k in ("mean_diff", "diff_ci_low", "diff_ci_high", "T", "dof", "p_t", "d_z",
                                      "d_z_ci_low", "d_z_ci_high", "V", "p_wilcoxon", "rbc", "rbc_ci_low",
                                      "rbc_ci_high", "p_shapiro")},
            "p": result["p_wilcoxon"] if test == WILCOXON else result["p_t"]}


def _corrected(rows: list[dict]) -> pd.DataFrame:
    """The rows with p Bonferroni-corrected over each instrument's scales compared together."""
    table = pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))
    if table.empty:
        return table
    family = ["instrument", "compared", "first", "second", "held"]
    size = table.groupby(family, sort=False)["p"].transform(lambda p: p.notna().sum())
    table["p_bonf"] = np.minimum(table["p"] * size, 1.0)
    table["stars"] = table["p_bonf"].map(stars)
    return table.reset_index(drop=True)


@dataclass(frozen=True)
class QuestionnaireAnalysis:
    """The report's questionnaire tables, each tidy; ``instruments`` are those analysed here, in the
    order they were asked (the paper's kind of 0-10 items are the Likert analysis's instead)."""

    instruments: tuple[Instrument, ...]
    scores: pd.DataFrame
    summary: pd.DataFrame
    comparisons: pd.DataFrame
    changes: pd.DataFrame
    consistency: pd.DataFrame
    simulated: bool

    def rows(self, name: str, instrument: str) -> pd.DataFrame:
        """The rows of table ``name`` (e.g. "summary") for one instrument."""
        frame = getattr(self, name)
        return frame[frame["instrument"] == instrument].reset_index(drop=True)


def analyse_questionnaires(answers: pd.DataFrame, instruments: Mapping[str, Instrument] | None, interaction: str,
                           baseline: str | None, alpha: float = 0.05) -> QuestionnaireAnalysis:
    """Every table of the report's questionnaire section, from an answers table.

    Parameters
    ----------
    answers : pandas.DataFrame
        One row per answer (:func:`microg.analysis.scoring.check_answers`); rows flagged ``withdrawn``
        are left out, rows flagged ``simulated`` mark the analysis as simulated.
    instruments : mapping of str to Instrument, optional
        The instruments by id (a study's own); the shipped ones serve the rest.
    interaction, baseline : str
        The interaction models compared (the report's: :func:`microg.analysis.choose_interactions`).
    alpha : float
        As for :func:`compare_scores`.

    Returns
    -------
    QuestionnaireAnalysis

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.questionnaires import analyse_questionnaires
    >>> answers = pd.DataFrame({"participant": "P1", "instrument": "sus", "administration": "end", "interaction": "s",
    ...                         "item": [f"sus{k:02d}" for k in range(1, 11)], "value": 3})
    >>> found = analyse_questionnaires(answers, None, "s", None)
    >>> [i.id for i in found.instruments], found.summary[["scale", "n", "mean"]].values.tolist()
    (['sus'], [['sus', 1, 50.0]])
    """
    if "withdrawn" in answers.columns:
        answers = answers[~answers["withdrawn"].astype(bool)]
    tidy = check_answers(answers, instruments)
    known = instruments_for(tidy, instruments)
    asked = tuple(known[name] for name in dict.fromkeys(tidy["instrument"]) if not known[name].likert)
    tidy = tidy[tidy["instrument"].isin([i.id for i in asked])]
    scores = score_answers(tidy, known)
    by_id = {i.id: i for i in asked}
    empty = pd.DataFrame(columns=list(COMPARISON_COLUMNS))
    return QuestionnaireAnalysis(
        instruments=asked,
        scores=scores,
        summary=score_summary(scores),
        comparisons=compare_scores(scores, by_id, interaction, baseline, alpha) if baseline else empty,
        changes=score_changes(scores, by_id, alpha),
        consistency=internal_consistency(tidy, by_id),
        simulated="simulated" in answers.columns and bool(answers["simulated"].astype(bool).any()),
    )
