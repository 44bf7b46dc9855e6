"""Instrument files: the shipped ones state the published instruments; bad files fail naming the file,
the key and the value."""

from __future__ import annotations

import pytest

from microg.instruments import InstrumentError, load_instrument, shipped_instruments
from microg.paths import INSTRUMENTS


def test_the_shipped_instruments_are_the_published_ones():
    assert shipped_instruments() == ["ipq", "paper", "ssq", "sus", "tlx"]
    ssq = load_instrument("ssq")
    assert [i.id for i in ssq.items] == [f"ssq{k:02d}" for k in range(1, 17)]
    assert [i.text for i in ssq.items][7] == "Nausea" and ssq.items[-1].text == "Burping"
    assert {i.response.describe() for i in ssq.items} == {"0-3"} and not any(i.reversed for i in ssq.items)
    assert ssq.item("ssq01").words == ((0, "None"), (1, "Slight"), (2, "Moderate"), (3, "Severe"))
    assert {s.name: s.weight for s in ssq.scales} == {"nausea": 9.54, "oculomotor": 7.58, "disorientation": 13.92,
                                                      "total": 3.74}
    assert all(len(s.items) == 7 for s in ssq.scales[:3]) and ssq.scale("total").scales == (
        "nausea", "oculomotor", "disorientation")

    ipq = load_instrument("ipq")
    assert [i.id for i in ipq.items] == ["G1", "SP1", "SP2", "SP3", "SP4", "SP5", "INV1", "INV2", "INV3", "INV4",
                                         "REAL1", "REAL2", "REAL3", "REAL4"]
    assert [i.id for i in ipq.items if i.reversed] == ["SP2", "INV3", "REAL1"]
    assert {i.response.describe() for i in ipq.items} == {"0-6"}
    assert {s.name: s.score for s in ipq.scales} == dict.fromkeys(["general", "spatial", "involvement", "realism"],
                                                                  "mean")
    tlx = load_instrument("tlx")
    subscales = ["mental", "physical", "temporal", "performance", "effort", "frustration"]
    assert [i.id for i in tlx.items[:6]] == subscales and tlx.item("mental").response.describe() == \
        "0-100 in steps of 5"
    pairs = [i for i in tlx.items if i.response.kind == "choice"]
    assert len(pairs) == 15 and {frozenset(i.choices) for i in pairs} == {
        frozenset((a, b)) for k, a in enumerate(subscales) for b in subscales[k + 1:]}
    assert all(i.id == f"pair_{i.choices[0]}_{i.choices[1]}" for i in pairs)
    assert [s.name for s in tlx.scales] == ["raw", "weighted", *subscales]
    assert tlx.item("performance").words == ((0, "Perfect"), (100, "Failure"))
    sus = load_instrument("sus")
    assert [i.id for i in sus.items if i.reversed] == ["sus02", "sus04", "sus06", "sus08", "sus10"]
    assert (sus.scale("sus").weight, sus.scale("sus").from_minimum) == (2.5, True)
    paper = load_instrument("paper")
    assert paper.likert and not any(load_instrument(n).likert for n in ("ssq", "ipq", "tlx", "sus"))
    assert [s.name for s in paper.scales] == ["naturalness", "efficiency"]


@pytest.mark.parametrize("value, read", [("2", 2), (3, 3), ("0.0", 0), (" 1 ", 1)])
def test_an_answer_on_the_scale_reads_as_a_point_of_it(value, read):
    assert load_instrument("ssq").item("ssq05").read(value) == read


@pytest.mark.parametrize("item, value, message", [
    ("ssq05", "4", "is off the scale 0-3"),
    ("ssq05", "1.5", "is off the scale 0-3"),
    ("ssq05", "severe", "is not a number on the scale 0-3"),
    ("ssq05", True, "is not a number"),
])
def test_an_answer_off_the_scale_is_refused_saying_the_scale(item, value, message):
    with pytest.raises(ValueError, match=message):
        load_instrument("ssq").item(item).read(value)


def test_a_tlx_rating_is_a_step_of_5_and_a_comparison_one_of_its_pair():
    tlx = load_instrument("tlx")
    assert tlx.item("effort").read("85") == 85
    with pytest.raises(ValueError, match=r"is off the scale 0-100 in steps of 5"):
        tlx.item("effort").read("82")
    assert tlx.item("pair_mental_effort").read("effort") == "effort"
    with pytest.raises(ValueError, match=r"is not one of the choices \['mental', 'effort'\]"):
        tlx.item("pair_mental_effort").read("physical")


def instrument(tmp_path, text: str, name: str = "mine"):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


MINE = '''title = "Comfort"
source = "This lab (2026)."
response = "seven"

[responses.seven]
min = 1
max = 7
anchors = { 1 = "Not at all", 7 = "Very much" }

[responses.pick]
kind = "choice"

[[items]]
id = "c1"
text = "How comfortable was the headset?"

[[items]]
id = "c2"
text = "How tired are your arms?"
reversed = true

[[items]]
id = "which"
text = "Which felt better?"
response = "pick"
choices = ["c1", "c2"]

[[scales]]
name = "comfort"
items = ["c1", "c2"]
score = "mean"
'''


def test_a_researchers_own_instrument_is_a_file_of_the_same_form(tmp_path):
    mine = load_instrument(instrument(tmp_path, MINE))
    assert mine.id == "mine" and [i.id for i in mine.items] == ["c1", "c2", "which"]
    assert mine.item("c2").keyed(2) == 6 and mine.item("c1").keyed(2) == 2
    vas = load_instrument(instrument(tmp_path, MINE.replace("min = 1\nmax = 7", "min = 0\nmax = 100")
                                     .replace('{ 1 = "Not at all", 7 =', '{ 0 = "Not at all", 100 ='), "vas"))
    assert vas.item("c1").read("63") == 63 and vas.item("c1").response.describe() == "0-100"


@pytest.mark.parametrize("old, new, expected", [
    ('[[items]]\nid = "c1"\n', '[[items]]\nid = "c1"\nresponse = "likert9"\n',
     ["items[0].response = 'likert9'", "no such response", "['pick', 'seven']"]),
    ('reversed = true\n\n[[items]]\nid = "which"\ntext = "Which felt better?"\n',
     '\n[[items]]\nid = "which"\ntext = "Which felt better?"\nreversed = true\n',
     ["items[2].reversed = True", "'which' is a choice", "only a rating has ends to swap"]),
    ('{ 1 = "Not at all", 7 = "Very much" }', '{ 1 = "Not at all", 9 = "Very much" }',
     ["responses.seven.anchors.9 = 'Very much'", "9 is off the scale 1-7"]),
    ('items = ["c1", "c2"]', 'items = ["c1", "c3"]', ["scales[0].items = ['c1', 'c3']", "names item 'c3'",
                                                        "does not have"]),
    ('items = ["c1", "c2"]', 'items = ["c1", "which"]', ["scales[0].items", "'which' is a choice"]),
    ('score = "mean"', 'score = "median"', ["scales[0].score = 'median'", "['sum', 'mean', 'weighted']"]),
    ('score = "mean"', 'score = "mean"\nweight = 0', ["scales[0].weight = 0.0", "positive"]),
    ("min = 1\nmax = 7", "min = 1\nmax = 7\nstep = 4", ["responses.seven.step = 4.0", "divide max - min = 6"]),
    ("min = 1\nmax = 7", "min = 7\nmax = 1", ["responses.seven.max = 1.0", "must exceed min = 7"]),
    ('id = "c2"', 'id = "c1"', ["items = ", "item id 'c1' appears twice"]),
    ('text = "How tired are your arms?"', 'text = "How tired are your arms?"\ntxet = "typo"',
     ["unknown key items[1].txet"]),
    ('title = "Comfort"\n', "", ["missing key title"]),
    ('choices = ["c1", "c2"]', 'choices = ["c1"]', ["items[2].choices = ['c1']", "two or more"]),
    ('choices = ["c1", "c2"]\n\n[[scales]]\nname = "comfort"\nitems = ["c1", "c2"]\nscore = "mean"',
     'choices = ["c1", "no"]\n\n[[scales]]\nname = "comfort"\nitems = ["c1", "c2"]\nscore = "weighted"',
     ["scales[0].score = 'weighted'", "the instrument has none"]),
    ('min = 1', 'min = 1 1', ["not valid TOML"]),
    ("min = 1\nmax = 7", "min = 0\nmax = 1000000000000000000", ["responses.seven.max = 1000000000000000000",
                                                              "offers 1e+18 answers; at most 101"]),
    ("min = 1\nmax = 7", f"min = 1\nmax = {10 ** 400}", ["responses.seven.max = 1000", "must be a number"]),
])
def test_a_bad_instrument_file_is_refused_naming_file_key_and_value(tmp_path, old, new, expected):
    assert old in MINE, old
    path = instrument(tmp_path, MINE.replace(old, new, 1))
    with pytest.raises(InstrumentError) as error:
        load_instrument(path)
    message = str(error.value)
    assert message.startswith(str(path)), message
    for part in expected:
        assert part in message, (part, message)


def test_an_unknown_instrument_name_lists_the_shipped_ones():
    with pytest.raises(InstrumentError, match=r"no instrument 'ssq2': shipped instruments are \['ipq', 'paper'"):
        load_instrument("ssq2")
    assert (INSTRUMENTS / "ssq.toml").is_file()


def test_a_duplicate_item_among_many_is_named_without_the_whole_list(tmp_path):
    """An instrument of 20,000 items with one id twice: the message names the id and shows the list's
    start, not 20,000 ids (the check reads the list once)."""
    items = "".join(f'[[items]]\nid = "c{k}"\ntext = "Item {k}"\n\n' for k in range(20_000))
    text = MINE.split("[[items]]")[0] + items + '[[items]]\nid = "c7"\ntext = "Again"\n'
    with pytest.raises(InstrumentError) as error:
        load_instrument(instrument(tmp_path, text))
    message = str(error.value)
    assert "item id 'c7' appears twice" in message and "... 20001 in all" in message and len(message) < 500


@pytest.mark.parametrize("typed", ["1_0", "nan", "inf", "0x3", "3e400", "--3"])
def test_an_answer_python_would_read_as_a_number_but_nobody_writes_so_is_refused(typed):
    from microg.study.questionnaire import RatingError, parse_answer, questions
    from microg.study.protocol import load_protocol
    from tests.study.conftest import PROTOCOLS

    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    question = next(q for phase in protocol.timeline if phase.instruments for q in questions(protocol, phase))
    assert question.item.response.describe() == "0-10"
    with pytest.raises(RatingError, match="is not a whole number"):
        parse_answer(question, typed)
    with pytest.raises(ValueError, match="is not a number on the scale 0-10"):
        question.item.read(typed)
    assert parse_answer(question, " ７ ") == 7  # a digit of another script is a digit
