"""Every instrument's key against hand-computed vectors from the primary sources, through ``microg
questionnaire score``: all-minimum, all-maximum, a mixed vector (with the reversed items where the
instrument has them) and a missing item, which is reported and never counted as zero.

The expected scores are worked out here by hand from the published keys (the comments show the
arithmetic), not by calling the scorer:
- SSQ (Kennedy et al. 1993): nausea = 9.54 x sum(1, 6, 7, 8, 9, 15, 16), oculomotor = 7.58 x sum(1,
  2, 3, 4, 5, 9, 11), disorientation = 13.92 x sum(5, 8, 10, 11, 12, 13, 14), total = 3.74 x the sum
  of the three sums; ratings 0-3.
- IPQ (igroup.org): ratings 0-6, SP2, INV3 and REAL1 reversed (6 - rating), subscale means.
- NASA-TLX (Hart & Staveland 1988): raw = mean of the six ratings; weighted = sum(rating x times
  chosen in the 15 pairs) / 15.
- SUS (Brooke 1996): odd items rating - 1, even items 5 - rating, sum x 2.5.
"""

from __future__ import annotations

import math

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.analysis.scoring import SCORE_COLUMNS, score_answers
from microg.analysis.tables import AnalysisInputError
from microg.cli import main

SSQ = [f"ssq{k:02d}" for k in range(1, 17)]
IPQ = ["G1", "SP1", "SP2", "SP3", "SP4", "SP5", "INV1", "INV2", "INV3", "INV4", "REAL1", "REAL2", "REAL3", "REAL4"]
TLX = ["mental", "physical", "temporal", "performance", "effort", "frustration"]
PAIRS = [(a, b) for k, a in enumerate(TLX) for b in TLX[k + 1:]]
SUS = [f"sus{k:02d}" for k in range(1, 11)]

# The mixed TLX vector's pairwise choices: mental beats everything, then effort, temporal,
# frustration, performance, physical; so mental is chosen 5 times, effort 4, temporal 3,
# frustration 2, performance 1, physical 0 (15 in all).
RANK = ["mental", "effort", "temporal", "frustration", "performance", "physical"]
MIXED_PAIRS = {f"pair_{a}_{b}": min((a, b), key=RANK.index) for a, b in PAIRS}

VECTORS = {
    # participant: (instrument, {item: value}, {scale: expected score, None: not scored})
    "ssqmin": ("ssq", dict.fromkeys(SSQ, 0), {"nausea": 0, "oculomotor": 0, "disorientation": 0, "total": 0}),
    # every subscale 7 x 3 = 21: 21 x 9.54, 21 x 7.58, 21 x 13.92; total (21 + 21 + 21) x 3.74
    "ssqmax": ("ssq", dict.fromkeys(SSQ, 3), {"nausea": 200.34, "oculomotor": 159.18, "disorientation": 292.32,
                                              "total": 235.62}),
    # general discomfort 1, fatigue 2, difficulty focusing 1, nausea 3, blurred vision 1, stomach awareness 2:
    # N = 1 + 3 + 2 = 6 -> 57.24; O = 1 + 2 + 1 + 1 = 5 -> 37.90; D = 1 + 3 + 1 = 5 -> 69.60; total 16 x 3.74
    "ssqmix": ("ssq", {**dict.fromkeys(SSQ, 0), "ssq01": 1, "ssq02": 2, "ssq05": 1, "ssq08": 3, "ssq11": 1,
                       "ssq15": 2},
               {"nausea": 57.24, "oculomotor": 37.90, "disorientation": 69.60, "total": 59.84}),
    # the same without nausea (ssq08): N, D and the total cannot be scored; O is whole
    "ssqgap": ("ssq", {**dict.fromkeys([i for i in SSQ if i != "ssq08"], 0), "ssq01": 1, "ssq02": 2, "ssq05": 1,
                       "ssq11": 1, "ssq15": 2},
               {"nausea": None, "oculomotor": 37.90, "disorientation": None, "total": None}),
    # all 0: the reversed SP2, INV3, REAL1 count 6: SP 6/5, INV 6/4, REAL 6/4
    "ipqmin": ("ipq", dict.fromkeys(IPQ, 0), {"general": 0, "spatial": 1.2, "involvement": 1.5, "realism": 1.5}),
    # all 6: the reversed count 0: SP 24/5, INV 18/4, REAL 18/4
    "ipqmax": ("ipq", dict.fromkeys(IPQ, 6), {"general": 6, "spatial": 4.8, "involvement": 4.5, "realism": 4.5}),
    # SP: 4, 6-1, 5, 3, 4 -> 21/5; INV: 2, 3, 6-5, 4 -> 10/4; REAL: 6-2, 3, 1, 0 -> 8/4
    "ipqmix": ("ipq", dict(zip(IPQ, [5, 4, 1, 5, 3, 4, 2, 3, 5, 4, 2, 3, 1, 0])),
               {"general": 5, "spatial": 4.2, "involvement": 2.5, "realism": 2.0}),
    "ipqgap": ("ipq", {k: v for k, v in zip(IPQ, [5, 4, 1, 5, 3, 4, 2, 3, 5, 4, 2, 3, 1, 0]) if k != "INV2"},
               {"general": 5, "spatial": 4.2, "involvement": None, "realism": 2.0}),
    "tlxmin": ("tlx", {**dict.fromkeys(TLX, 0), **MIXED_PAIRS},
               {"raw": 0, "weighted": 0, **dict.fromkeys(TLX, 0)}),
    "tlxmax": ("tlx", {**dict.fromkeys(TLX, 100), **MIXED_PAIRS},
               {"raw": 100, "weighted": 100, **dict.fromkeys(TLX, 100)}),
    # raw (70 + 20 + 55 + 30 + 65 + 40) / 6 = 280 / 6; weighted (70x5 + 20x0 + 55x3 + 30x1 + 65x4 + 40x2) / 15
    # = 885 / 15 = 59
    "tlxmix": ("tlx", {**dict(zip(TLX, [70, 20, 55, 30, 65, 40])), **MIXED_PAIRS},
               {"raw": 280 / 6, "weighted": 59.0, "mental": 70, "physical": 20, "temporal": 55,
                "performance": 30, "effort": 65, "frustration": 40}),
    # one comparison missing: no weighted score; the ratings are whole
    "tlxgap": ("tlx", {**dict(zip(TLX, [70, 20, 55, 30, 65, 40])),
                       **{k: v for k, v in MIXED_PAIRS.items() if k != "pair_mental_effort"}},
               {"raw": 280 / 6, "weighted": None, "mental": 70, "physical": 20, "temporal": 55,
                "performance": 30, "effort": 65, "frustration": 40}),
    # the raw TLX: no comparison asked, so no weighted score (and nothing missing)
    "tlxraw": ("tlx", dict(zip(TLX, [70, 20, 55, 30, 65, 40])),
               {"raw": 280 / 6, "mental": 70, "physical": 20, "temporal": 55, "performance": 30, "effort": 65,
                "frustration": 40}),
    # all 1: odd items 0 each, even items 5 - 1 = 4 each: 20 x 2.5
    "susmin": ("sus", dict.fromkeys(SUS, 1), {"sus": 50}),
    # all 5: odd items 4 each, even items 0: 20 x 2.5
    "susmax": ("sus", dict.fromkeys(SUS, 5), {"sus": 50}),
    # odd 4-1, 4-1, 3-1, 5-1, 4-1 = 15; even 5-2, 5-1, 5-2, 5-2, 5-3 = 15; 30 x 2.5
    "susmix": ("sus", dict(zip(SUS, [4, 2, 4, 1, 3, 2, 5, 2, 4, 3])), {"sus": 75}),
    "susgap": ("sus", {k: v for k, v in zip(SUS, [4, 2, 4, 1, 3, 2, 5, 2, 4, 3]) if k != "sus03"}, {"sus": None}),
    "papermix": ("paper", {"naturalness": 7, "efficiency": 3}, {"naturalness": 7, "efficiency": 3}),
}


def answers_table() -> pd.DataFrame:
    rows = [(who, instrument, item, value) for who, (instrument, items, _) in VECTORS.items()
            for item, value in items.items()]
    return pd.DataFrame(rows, columns=["participant", "instrument", "item", "value"])


def test_every_key_scores_the_hand_computed_vectors_through_the_command(tmp_path):
    answers = tmp_path / "answers.csv"
    answers_table().to_csv(answers, index=False)
    result = CliRunner().invoke(main, ["questionnaire", "score", str(answers), "--out",
                                       str(tmp_path / "out")])
    assert result.exit_code == 0, result.output + result.stderr
    scores = pd.read_csv(tmp_path / "out" / "scores.csv", dtype={"administration": str, "interaction": str},
                         keep_default_na=False, na_values=[""])
    assert tuple(scores.columns) == SCORE_COLUMNS
    for who, (instrument, _, expected) in VECTORS.items():
        rows = scores[scores.participant == who]
        assert list(rows.scale) == list(expected), who
        assert (rows.instrument == instrument).all()
        for scale, value in expected.items():
            got = rows.loc[rows.scale == scale, "score"].item()
            if value is None:
                assert math.isnan(got), (who, scale, got)
            else:
                assert got == pytest.approx(value, abs=1e-9), (who, scale)
    missing = pd.read_csv(tmp_path / "out" / "missing.csv")
    assert list(zip(missing.participant, missing["item"], missing.scales)) == [
        ("ssqgap", "ssq08", "nausea, disorientation, total"), ("ipqgap", "INV2", "involvement"),
        ("tlxgap", "pair_mental_effort", "weighted"), ("susgap", "sus03", "sus")]
    assert "missing: participant ssqgap, ssq: item ssq08 was not answered; nausea, disorientation, total not " \
           "scored" in result.stderr


def test_a_filling_in_is_scored_per_administration_and_interaction_model():
    answers = pd.DataFrame({"participant": "P1", "instrument": "sus", "item": SUS * 2,
                            "value": [5, 1] * 5 + [3] * 10, "administration": "end",
                            "interaction": ["a"] * 10 + ["b"] * 10})
    scores = score_answers(answers)
    assert list(zip(scores.interaction, scores.score)) == [("a", 100.0), ("b", 50.0)]
    assert (scores.administration == "end").all()


@pytest.mark.parametrize("change, message", [
    ({"value": "4"}, "participant 'P1', ssq item ssq01: value '4' is off the scale 0-3 (data row 1)"),
    ({"value": "x"}, "participant 'P1', ssq item ssq01: value 'x' is not a number on the scale 0-3"),
    ({"item": "ssq17"}, "participant 'P1', ssq item ssq17: no such item"),
    ({"instrument": "ssq9"}, "column 'instrument' value 'ssq9' (data row 1): no instrument 'ssq9'"),
    ({"item": "ssq02"}, "participant 'P1' answered ssq item ssq02 twice"),
    ({"value": ""}, "participant 'P1', ssq item ssq01: the value is empty"),
    ({"value": "1_0"}, "participant 'P1', ssq item ssq01: value '1_0' is not a number on the scale 0-3"),
    ({"value": "0x2"}, "participant 'P1', ssq item ssq01: value '0x2' is not a number on the scale 0-3"),
])
def test_bad_answers_are_refused_naming_participant_item_and_value(tmp_path, change, message):
    answers = pd.DataFrame({"participant": "P1", "instrument": "ssq", "item": SSQ, "value": "1"})
    for column, value in change.items():
        answers.loc[0, column] = value
    path = tmp_path / "answers.csv"
    answers.to_csv(path, index=False)
    result = CliRunner().invoke(main, ["questionnaire", "score", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and f"Error: {path}: " in result.output, result.output
    assert message in result.output, result.output
    assert not (tmp_path / "out").exists()


def test_an_answers_table_without_the_value_column_is_refused():
    with pytest.raises(AnalysisInputError, match="missing column 'value'"):
        score_answers(pd.DataFrame({"participant": ["P1"], "instrument": ["ssq"], "item": ["ssq01"]}))


def test_a_researchers_own_instrument_is_scored_from_its_file(tmp_path):
    mine = tmp_path / "comfort.toml"
    mine.write_text('title = "Comfort"\nsource = "This lab."\n[responses.vas]\nmin = 0\nmax = 100\n'
                    '[[items]]\nid = "c1"\ntext = "Comfort"\nresponse = "vas"\n'
                    '[[items]]\nid = "c2"\ntext = "Strain"\nresponse = "vas"\nreversed = true\n'
                    '[[scales]]\nname = "comfort"\nitems = ["c1", "c2"]\nscore = "mean"\n')
    answers = tmp_path / "answers.csv"
    pd.DataFrame({"participant": ["P1", "P1"], "instrument": "comfort", "item": ["c1", "c2"],
                  "value": [80, 30]}).to_csv(answers, index=False)
    result = CliRunner().invoke(main, ["questionnaire", "score", str(answers), "--out", str(tmp_path / "out"),
                                       "--instrument", str(mine)])
    assert result.exit_code == 0, result.output
    # (80 + (100 - 30)) / 2
    assert pd.read_csv(tmp_path / "out" / "scores.csv").score.tolist() == [75.0]


@pytest.mark.parametrize("encoding", ["utf-16", "utf-8-sig", "latin-1"])
def test_an_answers_table_in_another_encoding_is_read_or_refused_naming_it(tmp_path, encoding):
    """A spreadsheet's "Unicode text" (UTF-16 with its mark) and UTF-8 with a mark read as UTF-8
    does; any other encoding is refused saying to save the table as UTF-8."""
    answers = pd.DataFrame({"participant": "Pé1", "instrument": "ssq", "item": SSQ, "value": "1"})
    path = tmp_path / "answers.csv"
    path.write_bytes(answers.to_csv(index=False).encode(encoding))
    result = CliRunner().invoke(main, ["questionnaire", "score", str(path), "--out", str(tmp_path / "out")])
    if encoding == "latin-1":
        assert result.exit_code == 1 and f"Error: {path}: not UTF-8 text" in result.output, result.output
        assert "save the table as UTF-8" in result.output and not (tmp_path / "out").exists()
    else:
        assert result.exit_code == 0, result.output
        assert pd.read_csv(tmp_path / "out" / "scores.csv")["participant"].unique().tolist() == ["Pé1"]
