"""The session runner with the real physics, driven by scripted hand frames."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from microg.hands.filter import HandFilter
from microg.sim import step
from microg.sim.rotation import quat_to_matrix
from microg.study import framelog
from microg.study.export import run_frames, run_hand_frames, trials_table
from microg.study.inputs import ScriptedInputs, participant_plan
from microg.study.session import (EventLog, SimulationClock, Unattended, resume_session, run_session, run_task,
                                  task_world)
from microg.study.store import Event, StoreError, create_study, open_study
from tests.waiting import WAIT_S

from .conftest import answers, scripted_inputs
from .scripted import RATE, ScriptedPinch, pinch_keyframes


def one_task(store, task_index=0, rules=None, **script):
    """Run one planned task of P01's session with a scripted pinch; returns (result, run_id, source)."""
    session = store.session_of("P01") or store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    task = store.tasks(session.id)[task_index]
    source = ScriptedPinch(pinch_keyframes(participant_plan(store.protocol, task), **script))
    run_id = store.begin_run(session.id, task=task, source=source.description, seed=0, t=0.0)
    result = run_task(log=EventLog(store, session.id, SimulationClock()), run_id=run_id,
                      world=task_world(store.protocol, task), source=source, protocol=store.protocol, rules=rules)
    return result, run_id, source


def test_a_session_walks_the_timeline_and_each_task_ends_when_the_hand_lets_go(make_study):
    store, record = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    inputs = scripted_inputs()
    status = run_session(store, session.id, inputs, clock=SimulationClock(), rater=answers("7", "6", "3", "4"))
    assert status == "completed" and store.session(session.id).status == "completed"

    phases = [e.data["phase"] for e in store.events(session.id) if e.kind == "phase_start"]
    assert phases == [p.name for p in store.protocol.phases_for(record.group)]
    trials = trials_table(store)
    assert len(trials) == len(store.tasks(session.id)) and trials.completed.all() and (trials.attempts == 0).all()
    for source, (_, trial) in zip(inputs.made, trials.iterrows()):
        # the script starts opening the hand at its second-to-last keyframe; the grasp ends within that opening
        opening = source.keys[-3][0]
        assert opening <= trial.time_s <= opening + 0.1
    runs = store.db.execute("SELECT id, frames FROM task_runs ORDER BY id").fetchall()
    for (run_id, frames), source in zip(runs, inputs.made):
        assert frames == source.index == len(run_frames(store, run_id))
    assert store.answers(session.id) == {("paper", "questionnaire", "impulse_penetration", "naturalness"): 7,
                                         ("paper", "questionnaire", "impulse_penetration", "efficiency"): 6,
                                         ("paper", "questionnaire", "soft_hand", "naturalness"): 3,
                                         ("paper", "questionnaire", "soft_hand", "efficiency"): 4}
    times = store.db.execute("SELECT response_time_s FROM answers").fetchall()
    assert all(row[0] >= 0 for row in times)  # each answer keeps how long it took


@pytest.mark.parametrize("simulated, synchronous", [(True, 1), (False, 2)])
def test_only_a_live_session_waits_for_the_disk_at_each_commit(make_study, simulated, synchronous):
    """A live session's commits are flushed (FULL = 2); a simulated one's are not (NORMAL = 1): its
    seed makes its frames again."""
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=simulated, clock="simulation")
    assert store.db.execute("PRAGMA synchronous").fetchone()[0] == 2
    run_session(store, session.id, scripted_inputs(), clock=SimulationClock(), rater=answers("7", "6", "3", "4"))
    assert store.db.execute("PRAGMA synchronous").fetchone()[0] == synchronous


def test_under_gravity_the_object_waits_on_the_table_and_a_dropped_one_falls_back_onto_it(make_study):
    store, _ = make_study("quick-gravity")
    result, run_id, _ = one_task(store, squeeze=0.03, drop_at_place=1, open_s=0.3)
    assert result.status == "aborted" and result.attempts == 1  # the script ends without picking it up again
    events = store.events(store.session_of("P01").id, run_id)
    assert "drop" in [e.kind for e in events] and "respawn" not in [e.kind for e in events]
    frames = run_frames(store, run_id)
    start, _ = store.protocol.start_pose(store.tasks(store.session_of("P01").id)[0].object)
    hold_t = next(e.data["frame_t"] for e in events if e.kind == "hold")
    before_hold = frames[frames.t < hold_t - 0.1][["px", "py", "pz"]].to_numpy()
    assert len(before_hold) > 10
    assert np.abs(before_hold - start).max() < 1e-3  # standing on the table (it sinks a fraction of a mm)
    # it fell onto the table away from the start, and whatever way it lies, its lowest corner rests there
    last = frames.iloc[-1]
    rot = quat_to_matrix(last[["qw", "qx", "qy", "qz"]].to_numpy(dtype=float))
    half = store.protocol.object(store.tasks(store.session_of("P01").id)[0].object).spec.half_extents
    lowest = last.py - np.abs(rot[1]) @ half
    assert lowest == pytest.approx(store.protocol.table_height, abs=3e-3)  # the table is compliant
    assert np.hypot(last.px - start[0], last.pz - start[2]) > 0.02


def test_in_microgravity_a_drop_counts_as_an_attempt(make_study):
    store, _ = make_study("quick")
    result, run_id, _ = one_task(store, drop_at_place=1, open_s=0.3)
    assert result.attempts == 1
    assert [e.kind for e in store.events(store.session_of("P01").id, run_id)].count("drop") == 1


def test_a_task_not_finished_in_time_ends_as_a_timeout(make_study):
    store, _ = make_study("quick")
    rules = replace(store.protocol.task, timeout_s=1.0)
    result, run_id, _ = one_task(store, rules=rules, squeeze=-0.05)  # the pinch never closes on the object
    assert (result.status, result.time_s, result.attempts) == ("timeout", None, 0)
    row = store.db.execute("SELECT status, time_s, reason FROM task_runs WHERE id = ?", (run_id,)).fetchone()
    assert row["status"] == "timeout" and row["time_s"] is None and "timeout_s = 1" in row["reason"]
    assert result.frames == round(1.0 * RATE) + 1


def test_a_source_that_ends_early_aborts_the_task(make_study):
    store, _ = make_study("quick")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")

    class Short(ScriptedPinch):
        def next_frame(self, observation=None):
            return None if self.index >= 50 else super().next_frame(observation)

    inputs = ScriptedInputs(lambda plan, seed: Short(pinch_keyframes(plan)))
    status = run_session(store, session.id, inputs, clock=SimulationClock())
    trials = trials_table(store)
    assert (trials.status == "aborted").all() and not trials.completed.any() and trials.time_s.isna().all()
    tasks = len(store.tasks(session.id))
    assert status == "incomplete" and store.session(session.id).status == "incomplete"  # never "completed"
    end = store.events(session.id)[-1]
    assert end.kind == "session_end" and end.data == {"status": "incomplete", "tasks": {"aborted": tasks},
                                                      "reason": f"no measure from {tasks} task(s) aborted"}


def test_the_stored_hand_frames_simulate_the_logged_run_again_exactly(make_study):
    store, _ = make_study("quick")
    result, run_id, _ = one_task(store)
    assert result.status == "completed"
    task = store.tasks(store.session_of("P01").id)[0]
    world, positions = task_world(store.protocol, task), []
    smooth = HandFilter(store.protocol.filter_window, 1 / store.protocol.tracking_rate).smooth
    for frame in run_hand_frames(store, run_id):
        world = step(world, smooth(frame))
        positions.append(world.data.position[0].copy())
    logged = run_frames(store, run_id)[["px", "py", "pz"]].to_numpy()
    assert np.array_equal(np.array(positions, dtype=np.float32), logged)  # the log keeps float32 poses


def test_the_side_without_a_hand_is_logged_untracked_and_nan(make_study):
    store, _ = make_study("quick")
    _, run_id, _ = one_task(store)
    frames = framelog.read(store.db, run_id)
    tracked = frames["tracked"]
    assert tracked[:, 1].all() and not tracked[:, 0].any()  # the scripted pinch is a right hand
    assert not frames["track_id"][:, 0].any()
    for field in framelog.HAND_FIELDS:
        assert np.isnan(frames[field][:, 0]).all()
    assert not np.isnan(frames["palm_position"][:, 1]).any()


class Failing(ScriptedPinch):
    """A source that breaks (as a tracker might) after ``fail_after`` frames."""

    def __init__(self, keys, fail_after):
        super().__init__(keys)
        self.fail_after = fail_after

    def next_frame(self, observation=None):
        if self.index == self.fail_after:
            raise RuntimeError("tracker unplugged")
        return super().next_frame(observation)


def test_a_failure_mid_task_interrupts_the_run_and_resume_runs_only_that_task_again(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    last = len(store.tasks(session.id)) - 1
    calls = []

    def breaking(plan, seed):
        calls.append(plan.object.name)
        keys = pinch_keyframes(plan)
        return Failing(keys, 100) if len(calls) == last + 1 else ScriptedPinch(keys)

    with pytest.raises(RuntimeError, match="tracker unplugged"):
        run_session(store, session.id, ScriptedInputs(breaking), clock=SimulationClock())
    runs = store.runs(session.id)
    assert [r.status for r in runs] == ["completed"] * last + ["interrupted"]
    kept = store.db.execute("SELECT COALESCE(SUM(count), 0) FROM frames WHERE run_id = ?", (runs[-1].id,)).fetchone()[0]
    assert kept == 100
    assert "tracker unplugged" in store.db.execute("SELECT reason FROM task_runs WHERE id = ?",
                                                   (runs[-1].id,)).fetchone()[0]

    status = resume_session(store, session.id, scripted_inputs(), clock=SimulationClock(store.last_time(session.id)))
    assert status == "completed"
    runs = store.runs(session.id)
    assert [(r.task_index, r.run, r.status) for r in runs] == \
        [(i, 1, "completed") for i in range(last)] + [(last, 1, "interrupted"), (last, 2, "completed")]
    assert store.db.execute("SELECT COALESCE(SUM(count), 0) FROM frames WHERE run_id = ?", (runs[-2].id,)).fetchone()[0] == kept
    trials = trials_table(store)
    assert trials.completed.all() and trials.runs.tolist() == [1] * last + [2]


def test_a_skipped_task_is_recorded_as_skipped_not_as_zero(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")

    class SkipFirst(Unattended):
        def ready(self, task):
            return task.index != 0

    run_session(store, session.id, scripted_inputs(), clock=SimulationClock(), operator=SkipFirst())
    first = trials_table(store).iloc[0]
    assert first.status == "skipped" and not first.completed
    assert np.isnan(first.time_s) and first.attempts is pd.NA


def test_the_log_never_changes_what_it_holds(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, scripted_inputs(), clock=SimulationClock())
    attempts = [
        "UPDATE events SET kind = 'x'", "DELETE FROM events", "DELETE FROM frames",
        "UPDATE frames SET count = 1", "UPDATE task_runs SET time_s = 1.0", "UPDATE task_runs SET status = 'running'",
        "DELETE FROM task_runs", "UPDATE sessions SET status = 'running'", "UPDATE participants SET age = 30",
        "DELETE FROM participants", "UPDATE protocols SET resolved = '{}'", "UPDATE tasks SET object = 'ball'",
    ]
    for statement in attempts:
        with pytest.raises(StoreError, match="refused the change: .*never"):
            store.db.execute(statement)
    with pytest.raises(StoreError, match="never run twice"):
        store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    with pytest.raises(StoreError, match="never overwritten"):
        create_study(store.dir, store.protocol, 1)


def test_one_session_is_run_by_one_process_at_a_time(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.lock_session(session.id)
    with open_study(store.dir) as other:
        with pytest.raises(StoreError, match="another process"):
            other.lock_session(session.id)


def test_task_and_stage_events_go_out_as_lsl_markers(make_study):
    pylsl = pytest.importorskip("pylsl")
    from microg.study.lsl import MarkerOutlet

    clock = SimulationClock()
    outlet = MarkerOutlet({}, clock, name="microg-test", source_id="microg-test-markers")
    streams = pylsl.resolve_byprop("source_id", "microg-test-markers")  # waits until the stream is seen
    inlet = pylsl.StreamInlet(streams[0])
    inlet.open_stream()
    store, _ = make_study("quick")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    task = store.tasks(session.id)[0]
    source = ScriptedPinch(pinch_keyframes(participant_plan(store.protocol, task)))
    run_id = store.begin_run(session.id, task=task, source=source.description, seed=0, t=0.0)
    run_task(log=EventLog(store, session.id, clock, outlet), run_id=run_id, world=task_world(store.protocol, task),
             source=source, protocol=store.protocol)
    outlet.mark(Event(clock.now(), "end_of_test", {}))  # a last marker: everything before it has arrived once it has
    received = []
    while not received or json.loads(received[-1])["kind"] != "end_of_test":
        sample, _ = inlet.pull_sample(timeout=WAIT_S)  # waits for the next marker
        assert sample is not None, f"waited {WAIT_S:g} s for the next marker; received {received}"
        received.append(sample[0])
    kinds = [json.loads(m)["kind"] for m in received[:-1]]
    logged = [e.kind for e in store.events(session.id, run_id) if e.kind != "task_start"]  # the test logged it
    assert kinds == logged


def test_withdrawing_a_participant_ends_their_unfinished_session_as_aborted(make_study):
    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.withdraw("P01", "felt unwell")
    assert store.session(session.id).status == "aborted"
    with pytest.raises(ValueError, match="only a running session"):
        run_session(store, session.id, scripted_inputs(), clock=SimulationClock())
    trials = trials_table(store)
    assert trials.withdrawn.all() and (trials.status == "not_run").all()
