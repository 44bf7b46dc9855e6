"""What people type and what the report reads: participant fields, questionnaire answers, the
report's input tables. Any input gives a result or the project's error, and a refusal writes nothing."""

from __future__ import annotations

import pandas as pd
from hypothesis import HealthCheck, given, settings, strategies as st

from microg.analysis.tables import AnalysisInputError, read_questionnaire, read_trials
from microg.paths import PROTOCOLS
from microg.study.assignment import GENDERS, HANDEDNESS, Participant, ParticipantError
from microg.study.protocol import load_protocol
from microg.study.questionnaire import RatingError, parse_rating
from microg.study.store import create_study

from .strategies import FUZZ, scalars

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
@given(st.text(max_size=12), st.integers(-3, 3), st.integers(0, 12))
def test_any_typed_answer_is_a_rating_on_the_scale_or_a_clear_error(text, low, span):
    try:
        rating = parse_rating(text, low, low + span)
    except RatingError as error:
        assert f"from {low} to {low + span}" in str(error)
    else:
        assert low <= rating <= low + span


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
