"""Hands from another tracker over LSL drive a real session: the same guard, filter and physics."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from microg.participant.scripted import probe_hand
from microg.skeleton import HandFrame
from microg.hands.lsl import CHANNELS, STREAM_TYPE, describe_channels, frame_of, sample_of
from microg.study.export import run_frames, trials_table
from microg.study.inputs import open_inputs, participant_plan
from microg.study.session import SimulationClock, run_session
from microg.study.store import open_study

from tests.study.conftest import make_study  # noqa: F401  (the fixture)
from tests.study.scripted import RATE, ScriptedPinch, pinch_keyframes
from tests.waiting import WAIT_S, joined

pylsl = pytest.importorskip("pylsl")


def test_a_frame_goes_through_the_channel_layout_and_back_unchanged():
    frame = HandFrame(1.5, (probe_hand({"thumb.distal": (0.0, 0.2, 0.0), "index.distal": (0.05, 0.2, 0.0)}),))
    again = frame_of(sample_of(frame), frame.timestamp)
    assert len(sample_of(frame)) == len(CHANNELS) == 206
    assert [h.side for h in again.hands] == ["right"]
    np.testing.assert_array_equal(again.hands[0].joints, frame.hands[0].joints)
    np.testing.assert_array_equal(again.hands[0].widths, frame.hands[0].widths)


def test_a_hand_stream_published_on_lsl_drives_a_session(make_study):  # noqa: F811
    store, record = make_study("tiny")
    name = "microg-test-hands"
    info = pylsl.StreamInfo(name, STREAM_TYPE, len(CHANNELS), RATE, "double64", "microg-test-hands-source")
    describe_channels(info)
    outlet = pylsl.StreamOutlet(info)
    tasks = store.tasks(store.create_session("P01", input_spec="lsl", simulated=False, clock="simulation").id)
    published = []

    def publish():
        """The scripted pinch of each task, back to back, stamped at the tracking rate."""
        if not outlet.wait_for_consumers(WAIT_S):
            return  # the session never listened: it fails below, its tasks aborted
        t0 = pylsl.local_clock()
        offset = 0.0
        for task in tasks:
            source = ScriptedPinch(pinch_keyframes(participant_plan(store.protocol, task)))
            while (frame := source.next_frame()) is not None:
                outlet.push_sample(sample_of(frame), t0 + offset + frame.timestamp)
                published.append(frame)
            offset += source.keys[-1][0] + 1.0

    inputs = open_inputs(f"lsl:{name}")
    thread = threading.Thread(target=publish, daemon=True)
    thread.start()
    hung = threading.Timer(WAIT_S, inputs.close)  # a stream that stops: the source ends, the tasks abort
    hung.start()
    try:
        status = run_session(store, store.session_of("P01").id, inputs, clock=SimulationClock())
    finally:
        hung.cancel()
        inputs.close()
    joined(thread, "the hand stream's publisher")
    assert status == "completed"
    trials = trials_table(store)
    assert trials.completed.all() and (trials.attempts == 0).all()
    runs = store.runs(store.session_of("P01").id)
    assert all(r.status == "completed" for r in runs)
    logged = run_frames(store, runs[0].id)
    first = published[0].hands[0]
    columns = [f"right_index_proximal_base_{a}" for a in "xyz"]
    assert np.array_equal(logged[columns].iloc[0].to_numpy(dtype=float), first.joints[1, 1])


def stream(name: str):
    info = pylsl.StreamInfo(name, STREAM_TYPE, len(CHANNELS), RATE, "double64", f"{name}-source")
    describe_channels(info)
    return pylsl.StreamOutlet(info)


def test_a_stream_that_stops_sending_ends_its_source_with_a_clear_error():
    """An input that never comes: a stream found but silent, or one that stops after some frames,
    ends the source naming the stream (a session then stops and says how to resume), never a wait
    without end."""
    from microg.hands.lsl import LslInputError, LslSource

    outlet = stream("microg-test-silent")
    source = LslSource("microg-test-silent", frame_timeout=0.3, start_timeout=0.5)
    try:
        with pytest.raises(LslInputError, match="no sample from LSL stream 'microg-test-silent' for 0.5 s since it "
                                                "was found: is its tracker publishing frames"):
            source.next_frame()
        outlet.push_sample(sample_of(HandFrame(0.0, (probe_hand({"index.distal": (0.0, 0.2, 0.0)}),))))
        assert source.next_frame() is not None
        with pytest.raises(LslInputError, match="for 0.3 s: did the tracker or its bridge stop publishing"):
            source.next_frame()
    finally:
        source.close()
    del outlet


def test_a_session_whose_stream_stops_says_so_and_how_to_resume(make_study):  # noqa: F811
    """The session's command ends with the stream's error and how to resume, no traceback; the run
    cut off is kept, marked interrupted, and the study checks sound."""
    from click.testing import CliRunner

    from microg.cli import main

    store, _ = make_study("tiny")
    outlet = stream("microg-test-stopping")
    task = store.tasks(store.create_session("P01", input_spec="lsl:microg-test-stopping", simulated=False,
                                            clock="wall").id)[0]
    store.close()  # the session below opens the study itself; a new session would be refused: it has one

    def publish():
        if outlet.wait_for_consumers(WAIT_S):
            source = ScriptedPinch(pinch_keyframes(participant_plan(store.protocol, task)))
            t0 = pylsl.local_clock()
            for _ in range(30):  # then nothing more
                frame = source.next_frame()
                outlet.push_sample(sample_of(frame), t0 + frame.timestamp)

    thread = threading.Thread(target=publish, daemon=True)
    thread.start()
    result = CliRunner().invoke(main, ["session", "resume", str(store.dir), "--participant", "P01",
                                       "--no-display", "--questionnaire", "skip", "--quiet"], input="\n" * 20)
    joined(thread, "the hand stream's publisher")
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert "session 1 of P01 stopped: no sample from LSL stream 'microg-test-stopping' for 2 s" in result.output
    assert f"microg session resume {store.dir} --participant P01" in result.output
    with open_study(store.dir, readonly=True) as again:
        run = again.runs(1)[-1]
        assert run.status == "interrupted" and again.db.execute(
            "SELECT frames FROM task_runs WHERE id = ?", (run.id,)).fetchone()[0] == 30
    check = CliRunner().invoke(main, ["study", "check", str(store.dir)])
    assert check.exit_code == 0, check.output
