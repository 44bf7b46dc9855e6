"""The questionnaires in a session: every item of every instrument of the VR protocol asked where the
timeline puts it and committed as it is given, with its response time; a session cut off in the middle
of a questionnaire resumes at the first unanswered item; simulated participants answer through the
rating model; the export writes the answers and their scores."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pandas as pd
import pytest

from microg.analysis.scoring import score_answers
from microg.instruments import load_instrument
from microg.participant.ratings import Experience, InstrumentModel, unanswered
from microg.study.export import export_study, read_answers
from microg.study import framelog, open_inputs
from microg.study.simulated_rater import HANDLING, HANDLING_KEYS, SimulatedRater, handling
from microg.study.questionnaire import TerminalRater, questions
from microg.study.session import SimulationClock, resume_session, run_session
from microg.study.store import StoreError, open_study

from .conftest import scripted_inputs


def asked_in_order(protocol, group: str) -> list[tuple]:
    """Every question's key of a participant of ``group``, in the timeline's order."""
    return [q.key for phase in protocol.phases_for(group) if phase.instruments for q in questions(protocol, phase)]


class CutOff(Exception):
    """The participant stops answering (the session is cut off)."""


def typing(values: dict, stop_after: int | None = None):
    """A terminal participant who answers each item with ``values[item]`` (else its scale's bottom, or
    its first choice) and stops after ``stop_after`` answers; ``asked`` lists the items as asked."""
    asked = []

    def read(prompt: str) -> str:
        question = rater.current
        if stop_after is not None and len(asked) == stop_after:
            raise CutOff
        asked.append(question.key)
        item = question.item
        return str(values.get(item.id, "1" if item.choices else f"{item.response.low:g}"))

    rater = TerminalRater(read=read, write=lambda text: None)
    answer = rater.answer

    def remembering(question):
        rater.current = question
        return answer(question)

    rater.answer = remembering
    rater.asked = asked
    return rater


def test_every_item_is_asked_where_the_timeline_puts_it_and_a_cut_off_session_resumes_at_the_first_unanswered(
        make_study):
    store, record = make_study("tiny-vr")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    expected = asked_in_order(store.protocol, record.group)
    assert len(expected) == 16 + 2 * (14 + 21) + 4 + 16 + 2 * 10
    first = typing({"ssq08": 2}, stop_after=40)  # in the IPQ after stage 1
    with pytest.raises(CutOff):
        run_session(store, session.id, scripted_inputs(), clock=SimulationClock(), rater=first)
    assert first.asked == expected[:40] and set(store.answers(session.id)) == set(expected[:40])

    second = typing({"ssq08": 3})
    status = resume_session(store, session.id, scripted_inputs(), clock=SimulationClock(store.last_time(session.id)),
                            rater=second)
    assert status == "completed"
    assert second.asked == expected[40:]  # only the unanswered items, from the first of them on
    answers = store.answers(session.id)
    assert list(answers) == expected and answers[("ssq", "pre", "", "ssq08")] == 2
    assert answers[("ssq", "post", "", "ssq08")] == 3
    assert answers[("tlx", "after", "soft_hand", "pair_mental_physical")] == "mental"  # choice 1
    rows = store.db.execute("SELECT response_time_s, source FROM answers").fetchall()
    assert all(r[0] >= 0 and r[1] == "participant" for r in rows)
    events = [e.data for e in store.events(session.id) if e.kind == "answer"]
    assert [(e["instrument"], e["administration"], e["interaction"], e["item"]) for e in events] == expected


def test_simulated_participants_answer_every_instrument_through_the_rating_model(make_study):
    store, record = make_study("tiny-vr")
    assert store.protocol.simulation_problems() == []
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, scripted_inputs(), clock=SimulationClock(),
                rater=SimulatedRater(store, session.id, session.seed))
    answers = store.answers(session.id)
    assert list(answers) == asked_in_order(store.protocol, record.group)
    assert {r[0] for r in store.db.execute("SELECT DISTINCT source FROM answers")} == {"model"}
    assert store.db.execute("SELECT COUNT(*) FROM answers WHERE response_time_s IS NOT NULL").fetchone()[0] == 0
    for key, value in answers.items():  # every answer is one its item takes
        assert store.protocol.instruments[key[0]].item(key[3]).read(value) == value

    out = store.dir.parent / "export"
    export_study(store.dir, out, frames=False, bids=False, progress=False, say=lambda text: None)
    exported = pd.read_csv(out / "answers.csv", dtype={"value": str, "interaction": str, "administration": str},
                           keep_default_na=False)
    assert len(exported) == len(answers) and exported["simulated"].all()
    scores = pd.read_csv(out / "scores.csv", keep_default_na=False, na_values=[""])
    assert list(scores.columns) == ["participant", "instrument", "administration", "interaction", "scale", "score"]
    again = score_answers(exported, {n: load_instrument(out / "instruments" / f"{n}.toml")
                                     for n in ("ssq", "ipq", "tlx", "sus", "paper")})
    assert np.allclose(again["score"], scores["score"]) and scores["score"].notna().all()
    assert set(zip(scores.instrument, scores.administration)) == {
        ("ssq", "pre"), ("ssq", "post"), ("ipq", "after"), ("tlx", "after"), ("paper", "questionnaire"),
        ("sus", "end")}
    likert = pd.read_csv(out / "questionnaire.csv")
    assert len(likert) == 4 and set(likert["item"]) == {"naturalness", "efficiency"}
    answers_back, instruments = read_answers(out)
    assert len(answers_back) == len(answers) and sorted(instruments) == ["ipq", "paper", "ssq", "sus", "tlx"]


@pytest.mark.parametrize("source", ["scripted", "simulated"])
def test_a_run_ends_with_what_the_rating_model_reads_of_its_frames(make_study, source):
    """The ``handling`` event that ends each run (summed batch by batch as the frames are logged:
    a scripted hand frame by frame, a simulated participant's compiled batches) equals what the
    run's logged frames read back give: the rating model reads it instead of every frame."""
    store, record = make_study("tiny")
    session = store.create_session("P01", input_spec=source, simulated=True, clock="simulation")
    inputs = scripted_inputs() if source == "scripted" else open_inputs("simulated", store.protocol.group(record.group))
    run_session(store, session.id, inputs, clock=SimulationClock())
    ends = store.db.execute("SELECT run_id, data FROM events WHERE kind = ?", (HANDLING,)).fetchall()
    assert len(ends) == len(store.runs(session.id)) >= 2
    for run_id, data in ends:
        logged = framelog.read(store.db, run_id)
        summed = json.loads(data)
        again = handling(logged)
        assert [summed[k] for k in ("penetration_samples", "shake_samples")] == [again[1], again[3]]
        assert np.allclose([summed[k] for k in HANDLING_KEYS], again, rtol=1e-12, atol=0)
        assert again[1] > 0 or source == "scripted"  # a simulated hand touches its object


def lived(attempts: float = 0.0, time_s: float = 20.0, missed: float = 0.0, penetration: float = 3.0) -> Experience:
    return Experience(3, attempts, missed, time_s, penetration, 10.0)


def mean_score(name: str, scale: str, experience, exposure: float, seeds=range(60)) -> float:
    """The mean score of ``scale`` over simulated participants ``seeds`` with the same experience."""
    instrument = load_instrument(name)
    rows = [(seed, name, item, value) for seed in seeds
            for item, value in InstrumentModel(seed).answers(instrument, "post", "x", experience, exposure).items()]
    scores = score_answers(pd.DataFrame(rows, columns=["participant", "instrument", "item", "value"]),
                           {name: instrument})
    return float(scores.loc[scores.scale == scale, "score"].mean())


def test_the_rating_model_answers_each_instrument_the_way_its_documentation_says():
    # SSQ rises with the minutes of tasks done; IPQ's presence falls with attempts; NASA-TLX's workload
    # rises with attempts and slow tasks; SUS falls with tasks not completed
    assert mean_score("ssq", "total", None, 30.0) > mean_score("ssq", "total", None, 0.0) + 20
    assert mean_score("ipq", "spatial", lived(), 0) > mean_score("ipq", "spatial", lived(attempts=3.0), 0) + 0.5
    assert mean_score("tlx", "raw", lived(attempts=2.0, time_s=60.0), 0) > mean_score("tlx", "raw", lived(), 0) + 15
    assert mean_score("sus", "sus", lived(), 0) > mean_score("sus", "sus", lived(missed=0.7), 0) + 10
    # the weighted TLX's comparisons follow the ratings: the subscale rated higher is mostly chosen
    model, tlx = InstrumentModel(3), load_instrument("tlx")
    answers = model.answers(tlx, "after", "x", lived(attempts=3.0), 0)
    pairs = [i for i in tlx.items if i.choices]
    agree = [answers[i.id] == max(i.choices, key=lambda c: answers[c]) for i in pairs
             if answers[i.choices[0]] != answers[i.choices[1]]]
    assert np.mean(agree) > 0.6
    # the same participant, instrument, administration and interaction model: the same answers (a resume)
    assert model.answers(tlx, "after", "x", lived(attempts=3.0), 0) == answers
    assert model.answers(tlx, "after", "y", lived(attempts=3.0), 0) != answers


def test_the_rating_model_refuses_an_instrument_it_does_not_know(tmp_path):
    path = tmp_path / "comfort.toml"
    path.write_text('title = "Comfort"\nsource = "lab"\n[responses.r]\nmin = 1\nmax = 7\n[[items]]\nid = "c1"\n'
                    'text = "Comfy?"\nresponse = "r"\n[[scales]]\nname = "comfort"\nitems = ["c1"]\nscore = "mean"\n')
    assert "answers only the instruments ['paper', 'ssq', 'ipq', 'tlx', 'sus']" in unanswered(load_instrument(path))
    assert unanswered(load_instrument("tlx")) == ""


def test_a_study_of_an_older_schema_is_refused_saying_what_changed(make_study):
    store, _ = make_study("tiny")
    folder = store.dir
    store.close()
    with sqlite3.connect(folder / "study.db") as db:
        db.execute("DROP TRIGGER study_no_update")
        db.execute("UPDATE study SET schema_version = 4")
    with pytest.raises(StoreError) as error:
        open_study(folder)
    assert "schema version 4, this microg" in str(error.value) and "reads 9" in str(error.value)
    assert "version 7: each answer names its instrument and administration and keeps its response time" \
        in str(error.value) and "version 5: " in str(error.value) and "version 6: " in str(error.value)
    assert "version 8: participants handed to a station can be taken back" in str(error.value)
    assert "version 9: a participant has several sessions" in str(error.value)
