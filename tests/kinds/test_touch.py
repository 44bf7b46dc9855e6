"""A task kind declared in the tests alone (``tests.kinds.touch``) runs end to end with no edit to
microg: the protocol reads its table, a simulated participant plays it on the participant's page,
an in-silico study plays it to the same table, the export carries its measure (and its codebook
row), and the report analyses it under its own title."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from microg.insilico.studies import sized_protocol
from microg.study import Participant, SimulationClock, create_study, open_inputs, run_session, trials_table
from microg.study.protocol import ProtocolError, load_protocol
from microg.task import KINDS, register
from tests.kinds.touch import KIND, TIPS
from tests.view.browser import MISSING, chromium, page_text

PROTOCOL = Path(__file__).parent / "touch.toml"
WORK_S = 300.0
"""A generous bound for a tiny session on a loaded machine: the waits end on events, this only keeps
a broken run from hanging."""


def study(folder: Path, batched: bool, sinks=()):
    """A study of the touch protocol with two participants a group, played by logged sessions or by an
    in-silico study; its store (closed) and trials table."""
    from microg.insilico.studies import play_sessions
    from microg.study.session import Outputs

    protocol = sized_protocol(load_protocol(PROTOCOL), 1)
    with create_study(folder, protocol, 3) as store:
        for number, gender in enumerate(("female", "male")):
            store.add_participant(Participant(f"S{number + 1:03d}", gender, 25, "right", True))
        inputs = {r.participant.id: open_inputs("simulated", protocol.group(r.group)) for r in store.participants()}
        for pid, source in inputs.items():
            store.create_session(pid, input_spec=source.spec, simulated=True, clock="simulation")
        if batched:
            play_sessions(store, lambda session: inputs[session.participant_id])
        else:
            for pid, source in inputs.items():
                run_session(store, store.session_of(pid).id, source, clock=SimulationClock(),
                            outputs=Outputs(sinks=tuple(sinks)))
        return trials_table(store)


@pytest.fixture(scope="module", autouse=True)
def touch_registered():
    """The touch kind in microg's registry while this module runs, and gone after it."""
    register(KIND)
    yield
    del KINDS[KIND.name]


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    folder = tmp_path_factory.mktemp("touch") / "study"
    return folder, study(folder, batched=False)


def test_the_protocol_reads_the_kinds_table_and_a_bad_one_is_refused_naming_file_key_and_value(tmp_path):
    protocol = load_protocol(PROTOCOL)
    assert protocol.task.touch.hold_s == 0.5 and {p.kind for p in protocol.phases} == {"touch"}
    for bad, expected in (("hold_s = -1.0", "task.touch.hold_s = -1.0: must be a positive number (seconds)"),
                          ('hold_s = "long"', "task.touch.hold_s = 'long'"),
                          ("hold_s = 30.0", "task.touch.hold_s = 30.0: must be shorter than task.timeout_s"),
                          ("hold_s = 0.5\nhold = 1", "unknown key task.touch.hold")):
        text = PROTOCOL.read_text().replace("hold_s = 0.5", bad)
        path = tmp_path / "bad.toml"
        path.write_text(text.replace('extends = "../study/protocols/quick-gravity.toml"',
                                     f'extends = "{PROTOCOL.parent.parent / "study" / "protocols"}/quick-gravity.toml"'))
        with pytest.raises(ProtocolError) as refused:
            load_protocol(path)
        assert str(path) in str(refused.value) and expected in str(refused.value)


def test_a_simulated_participant_touches_the_cube_with_its_index_tip_and_holds_it(logged):
    folder, trials = logged
    played = trials[trials["phase"] != "training"]
    assert (played["task_kind"] == "touch").all() and played["completed"].all()
    assert (played["time_to_touch_s"] < played["time_s"]).all()
    assert np.allclose(played["time_s"] - played["time_to_touch_s"], 0.5, atol=0.02)  # the hold, to a frame
    from microg.study import framelog, open_study

    with open_study(folder, readonly=True) as store:
        run_id = store.db.execute("SELECT id FROM task_runs r JOIN tasks t ON t.session_id = r.session_id AND "
                                  "t.task_index = r.task_index WHERE t.phase = 'touching' LIMIT 1").fetchone()[0]
        frames = framelog.read(store.db, run_id)
    touching = framelog.touching_slots(frames["touching"])
    tip = touching[:, TIPS[0]] | touching[:, TIPS[1]]
    assert tip[-1] and tip[-int(0.5 * 100):].all()  # the fingertip on the cube through the last hold
    stages = np.array(framelog.stage_names(), dtype=object)[frames["stage"]]
    assert stages[0] == "reach" and stages[-1] == "completed"


def test_an_in_silico_study_of_the_kind_gives_the_logged_table(tmp_path, logged):
    _, trials = logged
    pd.testing.assert_frame_equal(study(tmp_path / "batched", batched=True).drop(columns=["study"]),
                                  trials.drop(columns=["study"]), check_exact=True)


def test_the_export_carries_the_kinds_measure_and_its_codebook_and_the_report_its_section(tmp_path, logged):
    from microg.analysis import write_report
    from microg.study.export import export_study, kind_infos

    folder, _ = logged
    export_study(folder, tmp_path / "export", frames=False, bids=False, progress=False)
    exported = pd.read_csv(tmp_path / "export" / "trials.csv")
    assert "time_to_touch_s" in exported.columns
    codebook = pd.read_csv(tmp_path / "export" / "codebook.csv")
    row = codebook[(codebook["table"] == "trials") & (codebook["column"] == "time_to_touch_s")].iloc[0]
    assert row["unit"] == "s" and "touch" in row["meaning"]
    stages = codebook[(codebook["table"] == "trials") & (codebook["column"] == "task_kind")].iloc[0]
    assert "touch: Touch" in stages["allowed"]
    report = write_report(tmp_path / "export" / "trials.csv", None, tmp_path / "report", kinds=kind_infos())
    text = (report.parent / "report.md").read_text()
    assert "Touch: " in text and "time to touch (s)" in text and "attempts (touches that broke off)" in text


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING}")
def test_the_participants_page_says_what_the_kind_says_at_each_stage(tmp_path):
    """A simulated participant's session paced at real time on the participant's page: the page
    shows the stage's words the kind declares (it has none of its own)."""
    from microg.study.inputs import PacedInputs
    from microg.study.session import Outputs, Unattended
    from microg.view.display import DisplayOperator, ParticipantDisplay
    from tests.view.test_display import wait

    from microg.study import open_study

    protocol = sized_protocol(load_protocol(PROTOCOL), 1)
    with create_study(tmp_path / "shown", protocol, 3) as store:
        store.add_participant(Participant("S001", "female", 25, "right", True))
        inputs = PacedInputs(open_inputs("simulated", protocol.group(store.participants()[0].group)))
        session = store.create_session("S001", input_spec=inputs.spec, simulated=True, clock="simulation")
    ended = threading.Event()
    texts = {stage.name: stage.text for stage in KIND.stages}
    with ParticipantDisplay(protocol) as display, chromium((800, 600)) as driver:
        driver.get(display.url)
        wait(driver, "return document.body.innerText.includes('Waiting for the session')")
        # every text the page shows, kept as it changes: a stage half a second long is seen however
        # seldom a loaded machine lets the test look
        driver.execute_script("window.shown = new Set(); new MutationObserver(() => "
                              "window.shown.add(document.body.innerText)).observe(document.body, "
                              "{subtree: true, childList: true, characterData: true});")
        seen = "return [...window.shown].some(text => text.includes({!r}))"

        def run():
            with open_study(tmp_path / "shown") as store:
                run_session(store, session.id, inputs, clock=SimulationClock(), outputs=Outputs(sinks=(display,)),
                            operator=DisplayOperator(display, Unattended()))
            ended.set()

        threading.Thread(target=run, daemon=True).start()
        wait(driver, seen.format(texts["reach"]), "the reach stage's words")
        wait(driver, seen.format(texts["touching"]), "the touching stage's words")
        assert ended.wait(WORK_S), f"the session did not end within {WORK_S:g} s"
