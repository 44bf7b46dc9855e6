"""Questionnaire instruments as data: their items, how each item is answered, and the key that scores them.

An instrument is a TOML file (the shipped ones in ``protocols/instruments/``: ``ssq``, ``ipq``, ``tlx``,
``sus`` and ``paper``, the paper's two items; a study's own in ``instruments/`` next to its protocol)::

    title = "System Usability Scale (SUS)"
    source = "Brooke, J. (1996). ..."          # the citation of the key
    instructions = "How much do you agree ..." # shown above the items (optional)
    response = "agreement"                     # the items' response unless an item names its own

    [responses.agreement]                      # a rating: points min, min + step, ..., max
    min = 1
    max = 5
    step = 1                                   # (the default)
    anchors = { 1 = "Strongly disagree", 5 = "Strongly agree" }

    [responses.pair]                           # a choice among an item's ``choices``
    kind = "choice"

    [[items]]
    id = "sus02"
    text = "I found the system unnecessarily complex."   # as published
    reversed = true                            # scored as min + max - rating
    # also: response, anchors (the item's own, else its response's), title, choices

    [[scales]]                                 # what is scored: one row of scores.csv each
    name = "sus"
    items = ["sus01", ..., "sus10"]
    score = "sum"                              # sum, mean or weighted
    weight = 2.5                               # the score is multiplied by it
    from_minimum = true                        # each rating counts from the bottom of its scale

``score = "sum"`` adds the (reversed where marked) ratings; a scale may instead add other scales'
sums (``scales = [...]``: SSQ's total adds its three subscales' sums, so a symptom on two of them
counts twice). ``score = "mean"`` takes their mean. ``score = "weighted"`` weighs each rating by how
often its item was chosen in the instrument's choice items whose choices are the scale's items
(NASA-TLX's 15 pairwise comparisons) and divides by the number of choices made. Both then multiply
by ``weight``.

The rules for what an answer may be (``Item.read``) and how it is keyed (``Item.keyed``) are here,
once: the study asks by them and the analysis scores by them (``microg.analysis.scoring``), so this
module stands beside ``microg.schema`` on the ground floor, importing nothing of the rooms. Every
error names the file, the key and the value.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from microg.paths import INSTRUMENTS

RESPONSE_KINDS = ("rating", "choice")
SCORES = ("sum", "mean", "weighted")
IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
"""What an instrument, item or scale id must be: it names columns and rows of tables."""
STEP_TOLERANCE = 1e-9
MAX_POINTS = 101
"""Answers a rating may offer: a 0-100 visual analogue scale's (the page shows a button or a slider's step each)."""


class InstrumentError(ValueError):
    """An instrument file that cannot be used; the message names the file, the key and the value."""


@dataclass(frozen=True)
class Response:
    """How an item is answered: a rating on the points ``low``, ``low + step``, ..., ``high``, or a
    choice among the item's choices."""

    name: str
    kind: str = "rating"
    low: float = 0.0
    high: float = 0.0
    step: float = 1.0
    anchors: tuple[tuple[float, str], ...] = ()
    """(point, text) for the points that have words, in order."""

    @property
    def points(self) -> tuple[float, ...]:
        """Every point of a rating scale, in order."""
        count = round((self.high - self.low) / self.step)
        return tuple(_tidy(self.low + k * self.step) for k in range(count + 1))

    @property
    def whole(self) -> bool:
        """Every point is a whole number."""
        return all(float(p).is_integer() for p in (self.low, self.step))

    def describe(self) -> str:
        """The scale in words: ``0-3``, ``0-100 in steps of 5``."""
        span = f"{_tidy(self.low)}-{_tidy(self.high)}"
        return span if self.step == 1 else f"{span} in steps of {_tidy(self.step)}"

    def on_scale(self, value: float) -> bool:
        position = (value - self.low) / self.step
        return (self.low - STEP_TOLERANCE <= value <= self.high + STEP_TOLERANCE
                and abs(position - round(position)) <= STEP_TOLERANCE * max(1.0, abs(position)))


@dataclass(frozen=True)
class Item:
    id: str
    text: str
    response: Response
    reversed: bool = False
    anchors: tuple[tuple[float, str], ...] = ()
    """The item's own anchors (IPQ's G1: "not at all" .. "very much"), else its response's."""
    title: str = ""
    """A short name (NASA-TLX's subscale titles), shown for the choices that name this item."""
    choices: tuple[str, ...] = ()

    @property
    def words(self) -> tuple[tuple[float, str], ...]:
        """The anchors shown with the item."""
        return self.anchors or self.response.anchors

    def read(self, value) -> float | int | str:
        """``value`` (a number, or text as typed or read from a table) as an answer to this item: a
        number on a rating's scale (an int when the scale's points are whole numbers), one of a
        choice's choices. ValueError says why it is not one."""
        if self.response.kind == "choice":
            text = str(value).strip()
            if text not in self.choices:
                raise ValueError(f"is not one of the choices {list(self.choices)}")
            return text
        number = _number(value)
        if number is None:
            raise ValueError(f"is not a number on the scale {self.response.describe()}")
        if not self.response.on_scale(number):
            raise ValueError(f"is off the scale {self.response.describe()}")
        return int(round(number)) if self.response.whole else _tidy(number)

    def keyed(self, value: float) -> float:
        """A rating as the key counts it: reversed items as low + high - rating."""
        return self.response.low + self.response.high - value if self.reversed else value


@dataclass(frozen=True)
class Scale:
    """What the key scores (a row of ``scores.csv``): see the module docstring."""

    name: str
    items: tuple[str, ...]
    score: str
    weight: float = 1.0
    from_minimum: bool = False
    scales: tuple[str, ...] = ()
    """For a sum of other scales' sums (SSQ's total): their names; then ``items`` is empty."""


@dataclass(frozen=True)
class Instrument:
    id: str
    title: str
    source: str
    instructions: str
    items: tuple[Item, ...]
    scales: tuple[Scale, ...]
    where: str = field(compare=False)
    """The file it was read from, for messages."""
    text: str = field(repr=False, compare=False)
    """The file's text, kept with a study so that its answers are always scored by the same key."""

    def item(self, item_id: str) -> Item:
        return next(i for i in self.items if i.id == item_id)

    def scale(self, name: str) -> Scale:
        return next(s for s in self.scales if s.name == name)

    def scale_items(self, scale: Scale) -> tuple[str, ...]:
        """The items a scale is scored from (through the scales it adds up, too), each once."""
        if scale.scales:
            return tuple(dict.fromkeys(i for name in scale.scales for i in self.scale_items(self.scale(name))))
        return tuple(dict.fromkeys(scale.items))

    def choice_label(self, choice: str) -> str:
        """How a choice is shown: the title of the item it names (NASA-TLX's "Mental Demand"), else itself."""
        return next((i.title for i in self.items if i.id == choice and i.title), choice)

    def weights_of(self, scale: Scale) -> tuple[Item, ...]:
        """The choice items that weigh a ``weighted`` scale: those whose choices are its items."""
        return tuple(i for i in self.items if i.choices and set(i.choices) <= set(scale.items))

    @property
    def likert(self) -> bool:
        """Every scale one item on the 11-point 0-10 scale: the paper's kind of questionnaire, which the
        report analyses item by item as Likert ratings (``microg.analysis.likert``)."""
        eleven = all(i.response.kind == "rating" and (i.response.low, i.response.high, i.response.step)
                     == (0, 10, 1) for i in self.items)
        return eleven and all(len(self.scale_items(s)) == 1 for s in self.scales)


def _tidy(value: float) -> float | int:
    """A whole number as an int (so that 3.0 reads as 3 in tables and messages)."""
    return int(value) if float(value).is_integer() else float(value)


NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
"""A number as an answer is written: digits with a decimal point and an exponent, no more (Python's
own reading would take ``1_0`` for 10, ``nan`` and ``infinity`` as numbers)."""


def _number(value) -> float | None:
    if isinstance(value, bool):
        return None
    if not isinstance(value, (int, float)) and not NUMBER.fullmatch(str(value).strip()):
        return None
    try:
        number = float(value) if isinstance(value, (int, float)) else float(str(value).strip())
    except (ValueError, OverflowError):
        return None  # not a number, or an integer beyond a float
    return number if math.isfinite(number) else None


# ---------------------------------------------------------------- files


def instrument_file(name: str, folder: Path | None = None) -> Path | None:
    """The file of the instrument ``name``: ``instruments/NAME.toml`` in ``folder`` (a protocol's),
    else the shipped one; None when there is neither."""
    if not IDENTIFIER.fullmatch(name):
        return None
    for place in ([folder / "instruments"] if folder else []) + [INSTRUMENTS]:
        candidate = place / f"{name}.toml"
        if candidate.is_file():
            return candidate
    return None


def shipped_instruments() -> list[str]:
    return sorted(p.stem for p in INSTRUMENTS.glob("*.toml"))


def load_instrument(name_or_path: str | Path) -> Instrument:
    """An instrument from its file, or a shipped one by name (``ssq``, ``ipq``, ``tlx``, ``sus``, ``paper``).

    Examples
    --------
    >>> from microg.instruments import load_instrument
    >>> ssq = load_instrument("ssq")
    >>> len(ssq.items), [s.name for s in ssq.scales], ssq.scale("nausea").weight
    (16, ['nausea', 'oculomotor', 'disorientation', 'total'], 9.54)
    """
    path = Path(name_or_path)
    if path.suffix != ".toml" and not path.exists():
        found = instrument_file(str(name_or_path))
        if found is None:
            raise InstrumentError(f"no instrument {str(name_or_path)!r}: shipped instruments are "
                                  f"{shipped_instruments()}, or give an instrument file")
        path = found
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise InstrumentError(f"{path}: cannot read the instrument file: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        raise InstrumentError(f"{path}: not UTF-8 text (position {error.start}); save the instrument file as "
                              "UTF-8") from None
    return read_instrument(text, str(path), path.stem)


def read_instrument(text: str, where: str, name: str) -> Instrument:
    """The instrument ``name`` from its file's ``text``; errors name ``where``, the key and the value."""
    if not IDENTIFIER.fullmatch(name):
        raise InstrumentError(f"{where}: the instrument's name {name!r} (its file name) must be letters, digits "
                              "and _ , starting with a letter (it names rows of tables)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise InstrumentError(f"{where}: not valid TOML: {error}") from None
    top = _Table(where, data)
    title, source = top.text("title"), top.text("source")
    instructions = top.text("instructions", "")
    responses = _read_responses(top)
    default = top.text("response", "")
    if default and default not in responses:
        raise top.fail("response", default, f"no such response (responses: {sorted(responses)})")
    items = _read_items(top, responses, default)
    scales = _read_scales(top, items)
    top.done()
    instrument = Instrument(name, title, source, instructions, items, scales, where, text)
    for i, scale in enumerate(scales):
        if scale.score == "weighted" and not instrument.weights_of(scale):
            raise top.fail(f"scales[{i}].score", "weighted", f"scale {scale.name!r} is weighted by the choice items "
                           "whose choices are its items, and the instrument has none")
    return instrument


def _read_responses(top: _Table) -> dict[str, Response]:
    responses = {}
    table = top.table("responses")
    for name in list(table.data):
        r = table.table(name)
        if not IDENTIFIER.fullmatch(name):
            raise table.fail(name, r.data, "a response's name must be letters, digits and _")
        kind = r.text("kind", "rating", RESPONSE_KINDS)
        if kind == "choice":
            responses[name] = Response(name, kind)
        else:
            low, high = r.number("min"), r.number("max")
            if high <= low:
                raise r.fail("max", high, f"must exceed min = {_tidy(low)}")
            step = r.number("step", 1.0)
            if step <= 0 or abs((high - low) / step - round((high - low) / step)) > STEP_TOLERANCE:
                raise r.fail("step", step, f"must be positive and divide max - min = {_tidy(high - low)}")
            if round((high - low) / step) + 1 > MAX_POINTS:
                raise r.fail("max", _tidy(high), f"the scale from min = {_tidy(low)} in steps of {_tidy(step)} offers "
                             f"{round((high - low) / step) + 1:g} answers; at most {MAX_POINTS}")
            response = Response(name, kind, low, high, step)
            responses[name] = Response(name, kind, low, high, step, _anchors(r, response))
        r.done()
    return responses


def _anchors(table: _Table, response: Response) -> tuple[tuple[float, str], ...]:
    """The ``anchors`` of a rating: point -> words, each point on its scale."""
    given = table.table("anchors", {})
    anchors = []
    for key in list(given.data):
        point = _number(key)
        if point is None or not response.on_scale(point):
            raise given.fail(key, given.data[key], f"{key} is off the scale {response.describe()}")
        anchors.append((_tidy(point), given.text(key)))
    given.done()
    return tuple(sorted(anchors))


def _read_items(top: _Table, responses: dict[str, Response], default: str) -> tuple[Item, ...]:
    items = []
    for it in top.tables("items"):
        item_id = it.identifier("id")
        name = it.text("response", default or None)
        if name is None:
            raise it.fail("response", None, "missing: name the item's response (or the instrument's default "
                          "response = \"...\")")
        if name not in responses:
            raise it.fail("response", name, f"no such response (responses: {sorted(responses)})")
        response = responses[name]
        rating = response.kind == "rating"
        reversed_ = it.boolean("reversed", False)
        if reversed_ and not rating:
            raise it.fail("reversed", True, f"item {item_id!r} is a choice: only a rating has ends to swap")
        choices = it.strings("choices", ()) if not rating else ()
        if not rating and (len(choices) < 2 or len(set(choices)) < len(choices)):
            raise it.fail("choices", list(choices), "a choice needs two or more different choices")
        anchors = _anchors(it, response) if rating else ()
        items.append(Item(item_id, it.text("text"), response, reversed_, anchors, it.text("title", ""), choices))
        it.done()
    top.unique("items", [i.id for i in items], "item id")
    return tuple(items)


def _read_scales(top: _Table, items: tuple[Item, ...]) -> tuple[Scale, ...]:
    known = {i.id: i for i in items}
    scales: list[Scale] = []
    for sc in top.tables("scales"):
        name = sc.identifier("name")
        score = sc.text("score", choices=SCORES)
        parts = sc.strings("scales", ())
        members = sc.strings("items", ()) if not parts or "items" in sc.data else ()
        if bool(parts) == bool(members):
            raise sc.fail("items", list(members), "give the scale's items, or (for a sum of sums) its scales")
        sc.unique("items", list(members), "item")
        for item_id in members:
            if item_id not in known:
                raise sc.fail("items", list(members), f"names item {item_id!r}, which the instrument does not have")
            if known[item_id].response.kind != "rating":
                raise sc.fail("items", list(members), f"item {item_id!r} is a choice: a scale scores ratings")
        for part in parts:
            if part not in [s.name for s in scales] or score != "sum":
                raise sc.fail("scales", list(parts), f"names {part!r}: a sum of sums adds scales listed before it"
                              " (and is itself a sum)")
        weight = sc.number("weight", 1.0)
        if weight <= 0:
            raise sc.fail("weight", weight, "must be a positive number")
        scales.append(Scale(name, tuple(members), score, weight, sc.boolean("from_minimum", False), tuple(parts)))
        sc.done()
    top.unique("scales", [s.name for s in scales], "scale name")
    return tuple(scales)


class _Table:
    """One table of an instrument file: reads its keys, checks each value, refuses keys it never read."""

    def __init__(self, where: str, data: dict, prefix: str = ""):
        self.where, self.data, self.prefix, self.read = where, data, prefix, set()

    def fail(self, key: str, value, message: str) -> InstrumentError:
        return InstrumentError(f"{self.where}: {self.prefix}{key} = {value!r}: {message}")

    def raw(self, key: str, default=...):
        self.read.add(key)
        if key in self.data:
            return self.data[key]
        if default is ...:
            raise InstrumentError(f"{self.where}: missing key {self.prefix}{key}")
        return default

    def text(self, key: str, default=..., choices: tuple[str, ...] | None = None):
        value = self.raw(key, default)
        if value is None and default is None:
            return None
        if not isinstance(value, str) or (not value.strip() and default is ...):
            raise self.fail(key, value, "must be a non-empty string")
        if choices is not None and value not in choices:
            raise self.fail(key, value, f"must be one of {list(choices)}")
        return value

    def identifier(self, key: str) -> str:
        value = self.text(key)
        if not IDENTIFIER.fullmatch(value):
            raise self.fail(key, value, "must be letters, digits and _ , starting with a letter (it names rows "
                            "of tables)")
        return value

    def number(self, key: str, default=...) -> float:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or _number(value) is None:
            raise self.fail(key, value, "must be a number")
        return float(value)

    def boolean(self, key: str, default=...) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, value, "must be true or false")
        return value

    def strings(self, key: str, default=...) -> tuple[str, ...]:
        value = self.raw(key, default)
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) and v for v in value):
            raise self.fail(key, value, "must be a list of non-empty strings")
        return tuple(value)

    def table(self, key: str, default=...) -> _Table:
        value = self.raw(key, default)
        if not isinstance(value, dict):
            raise self.fail(key, value, "must be a table")
        return _Table(self.where, value, f"{self.prefix}{key}.")

    def tables(self, key: str) -> list[_Table]:
        value = self.raw(key)
        if not isinstance(value, list) or not value or not all(isinstance(v, dict) for v in value):
            raise self.fail(key, value, f"must be a non-empty array of tables ([[{self.prefix}{key}]])")
        return [_Table(self.where, v, f"{self.prefix}{key}[{i}].") for i, v in enumerate(value)]

    def unique(self, key: str, values: list[str], what: str) -> None:
        seen: set[str] = set()
        for value in values:
            if value in seen:
                shown = values if len(values) <= 12 else [*values[:12], f"... {len(values)} in all"]
                raise self.fail(key, shown, f"{what} {value!r} appears twice")
            seen.add(value)

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.read, key=str)
        if unknown:
            raise InstrumentError(f"{self.where}: unknown key {self.prefix}{unknown[0]} (known here: "
                                  f"{sorted(self.read)})")
