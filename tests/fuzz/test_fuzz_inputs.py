"""What people type and what the report reads: participant fields, questionnaire answers, the
report's input tables. Any input gives a result or the project's error, and a refusal writes nothing."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from microg.analysis.tables import AnalysisInputError, read_questionnaire, read_trials
from microg.paths import PROTOCOLS
from microg.power import design_from_protocol
from microg.study.assignment import GENDERS, HANDEDNESS, Participant, ParticipantError
from microg.study.protocol import load_protocol
from microg.instruments import Instrument, Item, Response
from microg.study.questionnaire import Question, RatingError, parse_answer
from microg.study.store import create_study

from tests.waiting import WAIT_S

from .strategies import FUZZ, edits, scalars, toml_value

FIXTURE = settings(FUZZ, suppress_health_check=[HealthCheck.function_scoped_fixture])
STUDIES = settings(FIXTURE, max_examples=40)
"""Each example creates a study database (a durable commit or two): fewer examples, each of several people."""


@STUDIES
@given(st.lists(st.tuples(st.text(max_size=8) | st.sampled_from(["P01", "p01", "P02", "Pé", "007"]) | scalars,
                          st.sampled_from(GENDERS) | scalars, st.integers(-5, 130) | scalars,
                          st.sampled_from(HANDEDNESS) | scalars, st.booleans() | scalars), min_size=1, max_size=6))
def test_any_participant_fields_enrol_or_are_refused_without_a_trace(tmp_path_factory, people):
    with create_study(tmp_path_factory.mktemp("fuzz") / "study", load_protocol(PROTOCOLS / "paper.toml"), 1) as store:
        for fields in people:
            before = store.participants()
            try:
                record = store.add_participant(Participant(*fields))
            except ParticipantError:
                assert store.participants() == before  # a refusal writes nothing
            else:
                assert record.id == fields[0] and record.id.isascii() and record.id.isalnum()
        ids = [p.id.lower() for p in store.participants()]
        assert len(ids) == len(set(ids))  # one BIDS subject per participant


@FUZZ
@given(st.text(max_size=12), st.integers(-3, 3), st.integers(1, 12), st.sampled_from([1, 0.5, 5]))
def test_any_typed_answer_is_a_rating_on_the_scale_or_a_clear_error(text, low, span, step):
    item = Item("i", "How was it?", Response("r", "rating", low, low + span * step, step))
    asked = Question(Instrument("mine", "Mine", "lab", "", (item,), (), "mine.toml", ""), item, "end", "", "", 1, 1)
    try:
        rating = parse_answer(asked, text)
    except RatingError as error:
        assert f"from {low:g} to {low + span * step:g}" in str(error)
    else:
        assert low <= rating <= low + span * step
        assert abs((rating - low) / step - round((rating - low) / step)) < 1e-9


TRIALS = ["participant", "group", "interaction", "object", "time_s", "attempts", "completed", "phase"]
cells = st.one_of(st.sampled_from(["", "P1", "V", "B", "cube", "nan", "inf", "-1", "0", "3.5", "true", "x,y", '"']),
                  st.text(max_size=5), st.floats().map(repr), st.integers(-5, 5).map(str))


@FIXTURE
@given(st.lists(st.sampled_from(TRIALS + ["rating", "item", "?"]), min_size=0, max_size=8, unique=True),
       st.integers(0, 6), st.data(), st.sampled_from(["csv", "parquet"]))
def test_any_table_handed_to_the_report_is_read_or_refused(tmp_path, columns, rows, data, fmt):
    table = pd.DataFrame([[data.draw(cells) for _ in columns] for _ in range(rows)], columns=columns)
    path = tmp_path / f"table.{fmt}"
    if fmt == "csv":
        path.write_text(table.to_csv(index=False) if columns else data.draw(st.text(max_size=20)))
    else:
        table.to_parquet(path)
    for read in (read_trials, read_questionnaire):
        try:
            read(path)
        except AnalysisInputError as error:
            assert str(path) in str(error), error


EFFECTS = {"sd": 20.0, "correlation": 0.5,
           "means": {"veteran": {"cube": 45.0, "flat_cuboid": 55.0, "long_cuboid": 55.0},
                     "beginner": {"cube": 55.0, "flat_cuboid": 70.0, "long_cuboid": 70.0}}}
"""The issue's effects file, as data."""
PAPER_DESIGN = design_from_protocol(load_protocol(PROTOCOLS / "paper.toml"))


@FIXTURE
@given(edits(EFFECTS))
def test_any_edit_of_an_effects_file_is_read_or_refused_naming_it(tmp_path, data):
    from microg.power import PowerInputError, read_effects

    path = tmp_path / "effects.toml"
    lines = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    lines += [f"[{json.dumps(k)}]\n" + "\n".join(f"{json.dumps(a)} = {toml_value(b)}" for a, b in v.items())
              for k, v in data.items() if isinstance(v, dict)]
    path.write_text("\n".join(lines) + "\n")
    try:
        effects = read_effects(path, PAPER_DESIGN)
    except PowerInputError as error:
        assert str(error).startswith(str(path)), error
    else:
        assert np.isfinite(effects.means).all() and np.isfinite(effects.covariances).all()


@pytest.fixture(scope="module")
def page_server():
    from microg.view.display import ParticipantDisplay

    with ParticipantDisplay(load_protocol(PROTOCOLS / "paper.toml")) as display:
        yield display


header_names = st.sampled_from(["Host", "Origin", "Upgrade", "Connection", "Sec-WebSocket-Key",
                                "Sec-WebSocket-Version", "Cookie", "X"])
header_values = st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=40)


@FIXTURE
@given(st.binary(max_size=300).filter(lambda b: not set(b) & set(b" \r\n")), st.booleans(),
       st.lists(st.tuples(header_names, header_values), max_size=6))
def test_any_request_to_the_participant_page_gets_an_answer_and_no_traceback(page_server, caplog, path, own_host,
                                                                             headers):
    import logging
    import socket

    lines = ([("Host", f"127.0.0.1:{page_server.port}")] if own_host else []) + headers
    request = (b"GET /" + path + b" HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in lines).encode() + b"\r\n")
    with caplog.at_level(logging.ERROR, logger="websockets"), \
            socket.create_connection(("127.0.0.1", page_server.port), timeout=WAIT_S) as sock:
        sock.sendall(request)
        status = sock.recv(64).split(b"\r\n", 1)[0]
    assert status.split(b" ")[1] in (b"101", b"200", b"400", b"403", b"404"), status
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR], caplog.text
