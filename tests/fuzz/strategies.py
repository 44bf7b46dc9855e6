"""What the fuzz suite feeds the parsers: any TOML or JSON value, and edits of valid files.

The property each test checks: any input gives a result or the project's own error for that
input (``ProtocolError``, ``RecordingError``, ``ParticipantError``, ``RatingError``,
``AnalysisInputError``), never another exception, and a refused input writes nothing."""

from __future__ import annotations

import json
import math

from hypothesis import settings, strategies as st

FUZZ = settings(max_examples=150, deadline=None)
"""A few seconds per parser on CI's two cores; the repeatable profile (tests/conftest.py) fixes the examples."""

scalars = st.one_of(st.none(), st.booleans(), st.integers(min_value=-2**70, max_value=2**70),
                    st.sampled_from([2**63, -2**63 - 1, 10**400, -10**400]),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=5),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=5)),
                      max_leaves=12)
"""Any value a TOML or JSON file can hold (None stands for a missing key), integers no double holds included."""


def toml_value(value) -> str:
    """``value`` as TOML (scalars, lists and inline tables; None: an empty string)."""
    if value is None:
        return '""'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)  # TOML readers take integers beyond 64 bits: the parsers must refuse them by name
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"


@st.composite
def edits(draw, data):
    """``data`` (nested dicts and lists, e.g. a parsed protocol) with one to three values replaced,
    removed or added somewhere inside it."""
    import copy

    data = copy.deepcopy(data)
    for _ in range(draw(st.integers(1, 3))):
        node = data
        while True:
            keys = list(node) if isinstance(node, dict) else list(range(len(node)))
            if not keys:
                break
            key = draw(st.sampled_from(keys))
            if isinstance(node[key], (dict, list)) and node[key] and draw(st.booleans()):
                node = node[key]
                continue
            action = draw(st.sampled_from(["replace", "remove", "add"]))
            if action == "remove" and isinstance(node, dict):
                del node[key]
            elif action == "add" and isinstance(node, dict):
                node[draw(st.text(min_size=1, max_size=8))] = draw(values)
            else:
                node[key] = draw(values)
            break
    return data


@st.composite
def text_edits(draw, text: str):
    """``text`` with a few characters or lines deleted, duplicated or replaced by any character."""
    for _ in range(draw(st.integers(1, 4))):
        if not text:
            break
        i = draw(st.integers(0, len(text) - 1))
        j = min(len(text), i + draw(st.integers(0, 40)))
        text = text[:i] + draw(st.sampled_from(["", text[i:j] * 2, draw(st.text(max_size=3))])) + text[j:]
    return text
