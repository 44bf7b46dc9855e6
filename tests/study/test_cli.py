"""The study verbs from the command line: a researcher's whole path, and clear errors."""

from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from microg.hands.recording import RecordingInfo, write_recording
from microg.cli import main
from microg.study.export import read_tables
from microg.study.inputs import participant_plan
from microg.study.protocol import load_protocol
from microg.study.store import PlannedTask, open_study

from .conftest import PROTOCOLS
from .scripted import ScriptedPinch, pinch_keyframes

def cube_recording(path):
    """A recording of the scripted pinch doing the tiny protocol's cube task."""
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    plan = participant_plan(protocol, PlannedTask(0, "stage1", "impulse_penetration", "cube", "C", 1))
    source, frames = ScriptedPinch(pinch_keyframes(plan)), []
    while (frame := source.next_frame()) is not None:
        frames.append(frame)
    write_recording(path, RecordingInfo(source="scripted pinch", device="none", frame_rate=110.0,
                                        start_time="unknown"), frames)
    return path


def test_a_researcher_creates_a_study_runs_a_replayed_session_and_exports_it(tmp_path):
    run = CliRunner().invoke
    study = str(tmp_path / "study")
    result = run(main, ["study", "init", study, "--protocol", str(PROTOCOLS / "tiny.toml"), "--seed", "4"])
    assert result.exit_code == 0, result.output
    result = run(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
                        "--handedness", "right", "--mr-experience", "yes"])
    assert result.exit_code == 0 and result.output.startswith("P01: group ")

    recording = cube_recording(tmp_path / "cube.arrows")
    answers = "abc\n11\n7\n5\n6\n8\n"
    result = run(main, ["session", "run", study, "--participant", "P01", "--input", f"replay:{recording}",
                        "--questionnaire", "ask", "--quiet"], input=answers)
    assert result.exit_code == 0, result.output
    assert "'abc' is not a whole number" in result.output and "11 is off the scale" in result.output
    trials, questionnaire = read_tables(study)
    tasks = trials[trials.phase != "training"]
    assert tasks.completed.all() and not trials.simulated.any()
    assert sorted(questionnaire.rating) == [5, 6, 7, 8] and (questionnaire.source == "participant").all()
    with open_study(study) as store:
        rejected = [e.data["answer"] for e in store.events(store.session_of("P01").id) if e.kind == "answer_rejected"]
        assert rejected == ["abc", "11"]

    with open_study(study) as store:
        status = store.session_of("P01").status  # incomplete when the cube's recording could not do a training task
    assert status in ("completed", "incomplete")
    result = run(main, ["session", "resume", study, "--participant", "P01"])
    assert result.exit_code == 1 and f"is {status}; there is nothing to resume" in result.output
    result = run(main, ["session", "run", study, "--participant", "P01", "--input", f"replay:{recording}"])
    assert result.exit_code == 1 and "never run twice" in result.output

    out = str(tmp_path / "out")
    result = run(main, ["export", study, "--out", out, "--quiet"])
    assert result.exit_code == 0 and (tmp_path / "out" / "trials.parquet").exists()
    assert (tmp_path / "out" / "bids" / "sub-P01" / "motion").is_dir()
    result = run(main, ["export", study, "--out", out, "--quiet"])
    assert result.exit_code == 1 and "exists" in result.output and "--overwrite" in result.output

    result = run(main, ["participant", "withdraw", study, "--participant", "P01", "--reason", "felt unwell"])
    assert result.exit_code == 0
    result = run(main, ["participant", "list", study])
    assert "[withdrawn]" in result.output
    assert "0 active, 1 withdrawn" in run(main, ["study", "status", study]).output


@pytest.mark.parametrize("args, message", [
    (["participant", "add", "{study}", "--id", "P02", "--gender", "male", "--age", "12", "--handedness", "left",
      "--mr-experience", "no"], "participant P02: age = 12: the protocol 'tiny' takes participants aged 18-30"),
    (["session", "run", "{study}", "--participant", "P09", "--input", "leap"], "no participant 'P09'"),
    (["session", "run", "{study}", "--all", "--input", "webcam"], "must be leap, webxr, lsl:STREAM_NAME, replay:FILE or simulated"),
    (["export", "{missing}"], "no study in"),
])
def test_bad_input_on_the_command_line_gets_a_clear_error(tmp_path, args, message):
    study, missing = str(tmp_path / "study"), str(tmp_path / "missing")
    CliRunner().invoke(main, ["study", "init", study, "--protocol", str(PROTOCOLS / "tiny.toml")])
    result = CliRunner().invoke(main, [a.format(study=study, missing=missing) for a in args])
    assert result.exit_code == 1 and message in result.output, result.output
    assert "Traceback" not in result.output


def test_a_bad_protocol_names_file_key_and_value_on_the_command_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(f'extends = "{PROTOCOLS / "tiny.toml"}"\n[task]\nhold_s = 0\n')
    result = CliRunner().invoke(main, ["study", "init", str(tmp_path / "s"), "--protocol", str(bad)])
    assert result.exit_code == 1
    assert f"{bad}: task.hold_s = 0: must be a positive number" in result.output
    assert not (tmp_path / "s").exists()


def unchecked(hand, **changes):
    """A copy of ``hand`` with ``changes``, past ``Hand``'s checks: as a damaged file would hold it."""
    from dataclasses import fields

    copy = object.__new__(type(hand))
    for field in fields(hand):
        object.__setattr__(copy, field.name, changes.get(field.name, getattr(hand, field.name)))
    return copy


def recording_with(path, frames, change=None):
    """``frames`` (hand frames) written as a recording, each hand passed through ``change`` first."""
    from dataclasses import replace

    if change is not None:
        frames = [replace(f, hands=tuple(change(h) for h in f.hands)) for f in frames]
    write_recording(path, RecordingInfo(source="test", device="none", frame_rate=110.0, start_time="unknown"), frames)
    return path


def test_a_recording_with_impossible_hands_is_refused_before_any_session_and_on_resume(tmp_path):
    from microg.hands.recording import load_recording

    study = str(tmp_path / "study")
    assert CliRunner().invoke(main, ["study", "init", study, "--protocol", str(PROTOCOLS / "tiny.toml")]).exit_code == 0
    CliRunner().invoke(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
                              "--handedness", "right", "--mr-experience", "yes"])
    frames = load_recording(cube_recording(tmp_path / "cube.arrows")).frames
    bad = recording_with(tmp_path / "wide.arrows", frames, lambda h: unchecked(h, widths=h.widths * 100.0))
    for attempt in range(2):
        result = CliRunner().invoke(main, ["session", "run", study, "--participant", "P01", "--input",
                                           f"replay:{bad}", "--quiet"])
        assert result.exit_code == 1 and "Traceback" not in result.output
        assert f"--input replay:{bad}: {bad}: frame 0 (timestamp = 0 s): right widths[0, 1] = 1.6 m: wider than any " \
               "finger (at most 0.05 m)" in result.output, result.output
    with open_study(study) as store:
        assert store.session_of("P01") is None
        session = store.create_session("P01", f"replay:{bad}", False, "simulation")  # a session begun before
    result = CliRunner().invoke(main, ["session", "resume", study, "--participant", "P01", "--quiet"])
    assert result.exit_code == 1 and "wider than any finger" in result.output and "Traceback" not in result.output
    with open_study(study) as store:
        assert store.session(session.id).status == "running" and store.runs(session.id) == []


def test_lsl_says_it_opens_ports_and_a_session_of_aborted_tasks_says_so(tmp_path):
    pytest.importorskip("pylsl")
    from microg.hands.recording import load_recording
    from microg.study.lsl import NETWORK_NOTICE

    study = str(tmp_path / "study")
    CliRunner().invoke(main, ["study", "init", study, "--protocol", str(PROTOCOLS / "tiny.toml")])
    CliRunner().invoke(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
                              "--handedness", "right", "--mr-experience", "yes"])
    frames = load_recording(cube_recording(tmp_path / "cube.arrows")).frames
    short = recording_with(tmp_path / "short.arrows", frames[:20])
    result = CliRunner().invoke(main, ["session", "run", study, "--participant", "P01", "--input", f"replay:{short}",
                                       "--lsl", "--quiet"])
    assert result.exit_code == 0, result.output
    assert NETWORK_NOTICE in result.output and "ResolveScope = machine" in NETWORK_NOTICE
    tasks = re.search(r"session of P01: incomplete, (\d) tasks: (\d) aborted\n", result.output).groups()
    assert tasks[0] == tasks[1] and int(tasks[0]) >= 2
    status = CliRunner().invoke(main, ["study", "status", study]).output
    assert f"session 1 incomplete, {tasks[0]} tasks: {tasks[0]} aborted (replay:" in status


def test_a_protocol_simulated_participants_cannot_answer_warns_at_init_and_refuses_simulated_sessions(tmp_path):
    mine = tmp_path / "mine.toml"
    item = '[[questionnaire.items]]\nname = "{}"\nquestion = "How was it?"\nlow = "bad"\nhigh = "good"\n'
    mine.write_text(f'extends = "{PROTOCOLS / "tiny.toml"}"\nname = "mine"\n' + item.format("naturalness")
                    + item.format("comfort"))
    study = str(tmp_path / "study")
    result = CliRunner().invoke(main, ["study", "init", study, "--protocol", str(mine)])
    assert result.exit_code == 0
    assert (f"warning: {mine}: questionnaire.items[1].name = 'comfort': the rating model of simulated participants "
            "rates only ['efficiency', 'naturalness']; simulated sessions") in result.output
    CliRunner().invoke(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
                              "--handedness", "right", "--mr-experience", "yes"])
    result = CliRunner().invoke(main, ["session", "run", study, "--participant", "P01", "--input", "simulated"])
    assert result.exit_code == 1 and "a simulated participant cannot run this study's protocol" in result.output
    with open_study(study) as store:
        assert store.session_of("P01") is None
    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path / "demo"), "--participants", "2",
                                       "--protocol", str(mine), "--quiet"])
    assert result.exit_code == 1 and "'comfort'" in result.output and not (tmp_path / "demo").exists()
