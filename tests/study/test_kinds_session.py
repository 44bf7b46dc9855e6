"""A session runs each task kind: the catch's launched object caught by a still pinch in its path,
the spinning object stopped by a pinch, each kind's measures logged and in the trials table."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from microg.study import SimulationClock, run_session
from microg.study.export import trials_table
from microg.study.inputs import ScriptedInputs, open_inputs

from .scripted import RADIUS, ScriptedPinch, TwoPinches, pinch_keyframes

MEET = 0.05
"""m along the launch from the start where the still pinch waits."""


def kind_hands(plan, seed):
    """The training's pick-and-place pinch; a pinch that waits open in the catch's path and closes as
    the object arrives; a pinch that closes on the spinning object at its start."""
    half = float(plan.object.half_extents[0])
    open_gap, closed = half + RADIUS + 0.02, half + RADIUS - 0.006
    start = np.asarray(plan.start)
    if plan.phase == "catching":
        meet, due = start + [0.0, 0.0, MEET], MEET / 0.2  # the launch: 0.2 m/s along z (protocols/kinds.toml)
        return ScriptedPinch([(0.0, meet, open_gap), (due - 0.1, meet, open_gap), (due, meet, closed),
                              (6.0, meet, closed)])
    if plan.phase == "stopping":
        return ScriptedPinch([(0.0, start, open_gap + 0.02), (0.3, start, open_gap + 0.02), (0.5, start, closed),
                              (8.0, start, closed)])
    return ScriptedPinch(pinch_keyframes(plan))


def test_a_session_runs_a_catch_and_a_stop_of_a_spin_and_the_trials_table_has_their_measures(make_study):
    store, record = make_study("kinds")
    session = store.create_session(record.id, input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, ScriptedInputs(kind_hands), clock=SimulationClock())
    trials = trials_table(store).set_index("phase")
    catch, stop = trials.loc["catching"], trials.loc["stopping"]
    assert catch.task_kind == "catch" and stop.task_kind == "stop_spin"
    assert catch.status == "completed" and catch.time_to_catch_s > 0 and catch.time_s > catch.time_to_catch_s
    assert stop.status == "completed" and stop.time_to_rest_s > 0 and stop.time_s > stop.time_to_rest_s
    assert not stop.flipped  # a cube's axes are alike: it cannot flip
    assert pd.isna(catch.time_to_rest_s) and pd.isna(stop.time_to_catch_s) and pd.isna(catch.flipped)
    measures = [e.data for e in store.events(session.id) if e.kind == "measures"]
    assert measures == [{"kind": "catch", "time_to_catch_s": catch.time_to_catch_s},
                        {"kind": "stop_spin", "time_to_rest_s": stop.time_to_rest_s, "flipped": False}]


def test_a_simulated_participant_catches_and_stops_a_spin_in_a_session(make_study):
    """``--input simulated:veteran``: the participant plays each phase's kind (the kinds protocol
    with a catch it can reach in time, ``kinds-simulated.toml``)."""
    store, record = make_study("kinds-simulated")
    session = store.create_session(record.id, input_spec="simulated:veteran", simulated=True, clock="simulation")
    run_session(store, session.id, open_inputs("simulated:veteran"), clock=SimulationClock())
    trials = trials_table(store).set_index("phase")
    catch, stop = trials.loc["catching"], trials.loc["stopping"]
    assert catch.status == "completed" and 0 < catch.time_to_catch_s < catch.time_s
    assert stop.status == "completed" and 0 < stop.time_to_rest_s < stop.time_s


def test_a_simulated_participant_hands_the_cube_over_with_both_hands_in_a_session(make_study):
    """``--input simulated:veteran`` plays a handover with both hands, each hand's holds logged (study
    seed 3: its first hand takes the floating cube within the protocol's 15 s; in others a failed
    grasp may knock it away until the timeout, as in the pick-and-place)."""
    store, record = make_study("handover", seed=3)
    session = store.create_session(record.id, input_spec="simulated:veteran", simulated=True, clock="simulation")
    run_session(store, session.id, open_inputs("simulated:veteran"), clock=SimulationClock())
    passed = trials_table(store).set_index("phase").loc["passing"]
    assert passed.task_kind == "handover" and passed.status == "completed"
    assert 0 < passed.transfer_time_s <= passed.both_held_s < passed.time_s
    holds = [e.data["hand"] for e in store.events(session.id) if e.kind == "hold" and "hand" in e.data]
    assert holds.index("right") < holds.index("left")  # the protocol's first_hand took it first


def test_a_pick_and_place_session_logs_no_measures_and_leaves_the_kinds_columns_empty(make_study):
    store, record = make_study("tiny", gender="male")
    session = store.create_session(record.id, input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, ScriptedInputs(lambda plan, seed: ScriptedPinch(pinch_keyframes(plan))),
                clock=SimulationClock())
    trials = trials_table(store)
    assert set(trials.task_kind) == {"pick_and_place"} and set(trials.status) == {"completed"}
    assert trials[["time_to_catch_s", "time_to_rest_s", "flipped"]].isna().all().all()
    assert not [e for e in store.events(session.id) if e.kind == "measures"]


def send_hands(plan, seed):
    """A pinch that closes on the cube at its start, carries it along z at 0.1 m/s and opens while
    moving on, then lifts away: the cube drifts on toward the target (protocols/send.toml)."""
    if plan.phase != "sending":
        return ScriptedPinch(pinch_keyframes(plan))
    half = float(plan.object.half_extents[0])
    open_gap, closed = half + RADIUS + 0.02, half + RADIUS - 0.006
    start, along, up = np.asarray(plan.start), np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    return ScriptedPinch([(0.0, start, open_gap), (0.3, start, closed), (0.6, start, closed),
                          (1.0, start + 0.04 * along, closed), (1.1, start + 0.05 * along, open_gap),
                          (1.4, start + 0.05 * along + 0.08 * up, open_gap), (8.0, start + 0.05 * along + 0.08 * up,
                                                                               open_gap)])


def test_a_session_runs_a_send_and_the_trials_table_has_its_measures(make_study):
    store, record = make_study("send")
    session = store.create_session(record.id, input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, ScriptedInputs(send_hands), clock=SimulationClock())
    send = store.protocol.task.send
    trials = trials_table(store).set_index("phase")
    sent = trials.loc["sending"]
    assert sent.task_kind == "send" and sent.status == "completed" and sent.attempts == 0
    release = next(e.data for e in store.events(session.id) if e.kind == "release")
    due = np.linalg.norm(np.subtract(send.target, release["position"])) / send.arrival_s
    assert sent.release_speed_error == pytest.approx(release["speed"] - due, abs=1e-12)
    assert release["position"][2] - store.protocol.task.start[2] > 0.03  # let go on the way, 4 cm along z
    assert 0 <= sent.send_error_m < send.radius
    assert trials.loc["placing"][["send_error_m", "release_speed_error"]].isna().all()


def handover_hands(plan, seed):
    """Two pinches that hand the cube over from the right hand to the left (the passing phase of
    protocols/handover.toml); the pick-and-place pinch for the other phases."""
    if plan.phase != "passing":
        return ScriptedPinch(pinch_keyframes(plan))
    return TwoPinches(np.asarray(plan.start), np.asarray(plan.rules.handover.place), float(plan.object.half_extents[0]))


def test_a_session_runs_a_handover_of_two_hands_and_the_trials_table_has_its_measures(make_study):
    store, record = make_study("handover")
    session = store.create_session(record.id, input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, ScriptedInputs(handover_hands), clock=SimulationClock())
    trials = trials_table(store).set_index("phase")
    passed = trials.loc["passing"]
    assert passed.task_kind == "handover" and passed.status == "completed" and passed.attempts == 0
    handover = next(e.data for e in store.events(session.id) if e.kind == "handover")
    assert passed.transfer_time_s == pytest.approx(handover["transfer_time_s"], abs=1e-12)
    assert 0 < passed.transfer_time_s < passed.both_held_s < passed.time_s
    assert {e.data.get("hand") for e in store.events(session.id) if e.kind == "hold"} >= {"left", "right"}
    assert trials.loc["placing"][["transfer_time_s", "both_held_s"]].isna().all()
