"""A session on LSL recorded into XDF, read back with pyxdf and lined up with the study's log."""

from __future__ import annotations

import time
import uuid

import numpy as np
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study import framelog
from microg.study.assignment import Participant
from microg.study.inputs import ScriptedInputs
from microg.study.lsl import MARKERS_NAME, MOCAP_NAME, MarkerOutlet, MocapOutlet, session_tags
from microg.study.protocol import load_protocol
from microg.study.session import Outputs, WallClock, make_clock, resume_session, run_session
from microg.study.store import Event, create_study
from microg.study.xdf import XdfError, line_up

from .conftest import PROTOCOLS
from .scripted import ScriptedPinch, pinch_keyframes

pylsl = pytest.importorskip("pylsl")
pytest.importorskip("pyxdf")
pytestmark = pytest.mark.slow

RESIDUAL_MS = 5.0
"""Markers carry their event's own time: within this of the logged time on one machine, one
monotonic clock, no network, however late the marker is pushed."""


class Sent:
    """The session's markers: each one sent on ``outlet`` and its kind kept; ``crash_on`` raises
    ``Crash`` once, after sending the first marker of that kind (its event already committed)."""

    def __init__(self, outlet: MarkerOutlet, crash_on: str | None = None):
        self.outlet, self.crash_on, self.kinds, self.crashed_at = outlet, crash_on, [], None

    def mark(self, event: Event) -> None:
        self.kinds.append(event.kind)
        self.outlet.mark(event)
        if event.kind == self.crash_on and self.crashed_at is None:
            self.crashed_at = time.monotonic()
            raise Crash


class Crash(Exception):
    """Stands in for the session's process dying."""


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A wall-clock session (as a live one) of scripted pinches with its LSL streams recorded to XDF;
    returns (store, session id, XDF path)."""
    from .xdf_writer import XdfRecorder

    tmp_path = tmp_path_factory.mktemp("xdf")
    store = create_study(tmp_path / "study", load_protocol(PROTOCOLS / "tiny.toml"), 1)
    store.add_participant(Participant("P01", "female", 24, "right", True))
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="wall")
    tags = session_tags(store, session.id)
    ids = [f"microg-test-{kind}-{uuid.uuid4().hex}" for kind in ("markers", "mocap")]
    clock = WallClock()
    sent = Sent(MarkerOutlet(tags, clock, source_id=ids[0]))
    mocap = MocapOutlet(store.protocol.tracking_rate, tags, source_id=ids[1])
    path = tmp_path / "session.xdf"
    recorder = XdfRecorder(path, ids)
    inputs = ScriptedInputs(lambda plan, seed: ScriptedPinch(pinch_keyframes(plan)), clock="wall")
    run_session(store, session.id, inputs, clock=clock, outputs=Outputs(sinks=(mocap,), markers=sent))
    recorder.wait_for(ids[0], len(sent.kinds))
    recorder.wait_for(ids[1], sum(framelog.count(store.db, run.id) for run in store.runs(session.id)))
    recorder.close()
    yield store, session.id, path
    store.close()


def test_an_xdf_of_the_session_lines_up_with_its_log(recorded):
    store, session_id, path = recorded
    lineup, = line_up(store, path)
    events = store.events(session_id)
    sent_kinds = {"phase_start", "phase_end", "task_start", "task_end", "tracking_guard", "handling"}
    stage = {e.kind for e in events if "frame_t" in e.data}
    logged = [(e.kind, e.t) for e in events if e.kind in sent_kinds | stage]
    markers = lineup.markers
    assert markers.matched.all() and list(zip(markers.kind, markers.study_t)) == logged
    assert lineup.fit.max_residual_ms < RESIDUAL_MS, lineup.markers.residual_ms.describe()
    span = markers.study_t.max() - markers.study_t.min()
    assert abs(lineup.fit.slope - 1) < 2 * RESIDUAL_MS / 1e3 / span  # both clocks count this machine's seconds

    runs = store.runs(session_id)
    tasks = lineup.tasks
    assert list(tasks.run) == [r.run for r in runs] and (tasks.lsl_start_from == "marker").all()
    np.testing.assert_allclose(lineup.fit.study(tasks.lsl_start), [r.started_at for r in runs],
                               atol=RESIDUAL_MS / 1e3)
    np.testing.assert_allclose(lineup.fit.study(tasks.lsl_end), [r.ended_at for r in runs], atol=RESIDUAL_MS / 1e3)

    mocap = lineup.mocap
    assert list(tasks.mocap_samples) == list(tasks.frames) and mocap.run.notna().all()
    for run, task in zip(runs, tasks.itertuples()):
        logged_frames = framelog.read(store.db, run.id)
        samples = mocap[(mocap.task_index == task.task_index) & (mocap.run == task.run)]
        assert list(samples.frame) == list(range(len(logged_frames)))
        np.testing.assert_array_equal(samples[[f"object_{a}" for a in "xyz"]].to_numpy(), logged_frames["position"])
        np.testing.assert_array_equal(samples[[f"object_q{c}" for c in "wxyz"]].to_numpy(),
                                      logged_frames["orientation"])
        assert (samples.study_t.diff().dropna() > 0).all()
        assert run.started_at - RESIDUAL_MS / 1e3 <= samples.study_t.min()
        assert samples.study_t.max() <= run.ended_at + RESIDUAL_MS / 1e3


def test_export_xdf_writes_the_tables_and_says_how_well_the_clocks_fit(recorded, tmp_path):
    store, _, path = recorded
    out = tmp_path / "lined-up"
    result = CliRunner().invoke(main, ["export", str(store.dir), "--xdf", str(path), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "participant P01, session 1:" in result.output and "max residual" in result.output
    for name in ("tasks", "markers", "mocap"):
        assert (out / f"xdf_{name}.csv").exists() and (out / f"xdf_{name}.parquet").exists()
    again = CliRunner().invoke(main, ["export", str(store.dir), "--xdf", str(path), "--out", str(out)])
    assert again.exit_code == 1 and f"{out} exists" in again.output


def test_an_xdf_that_does_not_belong_says_why(recorded, make_study, tmp_path):
    from .xdf_writer import XdfRecorder

    store, session_id, path = recorded
    not_xdf = tmp_path / "notes.xdf"
    not_xdf.write_text("not an XDF file")
    with pytest.raises(XdfError, match=f"{not_xdf}: not a readable XDF file"):
        line_up(store, not_xdf)

    other, _ = make_study("tiny")  # another study: the same participant id and session number
    other.create_session("P01", input_spec="scripted", simulated=True, clock="wall")
    with pytest.raises(XdfError, match=f"{path}: its Markers streams '{MARKERS_NAME}' are of participant P01, "
                                       "session 1 .* no session of the study in"):
        line_up(other, path)

    mocap_only = tmp_path / "mocap.xdf"
    ids = [f"microg-test-mocap-{uuid.uuid4().hex}"]
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(MOCAP_NAME, "MoCap", 1, 90.0, "float32", ids[0]))
    recorder = XdfRecorder(mocap_only, ids)
    outlet.push_sample([0.0])
    recorder.wait_for(ids[0], 1)
    recorder.close()
    with pytest.raises(XdfError, match=f"{mocap_only}: no Markers stream named '{MARKERS_NAME}' .* it holds "
                                       f"'{MOCAP_NAME}' \\(MoCap\\)"):
        line_up(store, mocap_only)

    few = tmp_path / "few.xdf"
    ids = [f"microg-test-markers-{uuid.uuid4().hex}"]
    clock = WallClock()
    markers = MarkerOutlet(session_tags(store, session_id), clock, source_id=ids[0])
    recorder = XdfRecorder(few, ids)
    first = store.events(session_id)[0]
    markers.mark(first)
    markers.mark(Event(clock.now(), "phase_start", {"phase": "no such phase"}))
    recorder.wait_for(ids[0], 2)
    recorder.close()
    with pytest.raises(XdfError, match=f"{few}: 1 of the 2 markers .* \\(participant P01, session 1\\) match the "
                                       "study log's events"):
        line_up(store, few)


def test_a_session_resumed_after_a_crash_lines_up_part_by_part(tmp_path):
    """The session's clock carries on from its last logged time at a resume, while the LSL clock ran
    on through the crash: one line per part, each as close as the session that never stopped."""
    from .xdf_writer import XdfRecorder

    store = create_study(tmp_path / "study", load_protocol(PROTOCOLS / "tiny.toml"), 1)
    store.add_participant(Participant("P01", "female", 24, "right", True))
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="wall")
    ids = [f"microg-test-markers-{uuid.uuid4().hex}"]
    first = WallClock()
    sent = Sent(MarkerOutlet(session_tags(store, session.id), first, source_id=ids[0]), crash_on="place_lit")
    recorder = XdfRecorder(tmp_path / "resumed.xdf", ids)
    inputs = ScriptedInputs(lambda plan, seed: ScriptedPinch(pinch_keyframes(plan)), clock="wall")
    with pytest.raises(Crash):  # dies in the first task, its first place just lit (and logged)
        run_session(store, session.id, inputs, clock=first, outputs=Outputs(markers=sent))
    while time.monotonic() - sent.crashed_at < 0.5:  # the crash and the restart take real time: LSL's clock runs on
        time.sleep(0.05)
    again = make_clock("wall", store.last_time(session.id))
    sent.outlet.clock = again
    resume_session(store, session.id, inputs, clock=again, outputs=Outputs(markers=sent))
    recorder.wait_for(ids[0], len(sent.kinds))
    recorder.close()

    lineup, = line_up(store, tmp_path / "resumed.xdf")
    markers = lineup.markers
    assert markers.matched.all()  # a marker goes out once its event is logged: none is lost with a crash
    assert "session_resume" in set(markers.kind) and len(lineup.fit.starts) == 2
    assert lineup.fit.max_residual_ms < RESIDUAL_MS, lineup.markers.residual_ms.describe()
    assert lineup.fit.offsets[1] - lineup.fit.offsets[0] > 0.5 - RESIDUAL_MS / 1e3  # the time the crash took
    runs = store.runs(session.id)
    assert [r.status for r in runs][:2] == ["interrupted", "completed"]  # the first task, cut off, then again
    started = lineup.tasks.lsl_start.to_numpy()
    np.testing.assert_allclose(lineup.fit.study(started), [r.started_at for r in runs], atol=RESIDUAL_MS / 1e3)
    assert (np.diff(started) > 0).all()
    store.close()
