"""The study verbs from the command line: a researcher's whole path, and clear errors."""

from __future__ import annotations

import contextlib
import os
import pwd
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner

from microg.hands.recording import RecordingInfo, write_recording
from microg.cli import main
from microg.study.export import read_tables
from microg.study.inputs import participant_plan
from microg.study.protocol import load_protocol
from microg.study.store import PlannedTask, open_study

from tests.waiting import WAIT_S, ended, joined, wait_until

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
        session = store.create_session("P01", input_spec=f"replay:{bad}", simulated=False, clock="simulation")  # a session begun before
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
    (tmp_path / "instruments").mkdir()
    (tmp_path / "instruments" / "comfort.toml").write_text(
        'title = "Comfort"\nsource = "This lab."\n[responses.r]\nmin = 0\nmax = 10\n[[items]]\nid = "comfort"\n'
        'text = "How was it?"\nresponse = "r"\n[[scales]]\nname = "comfort"\nitems = ["comfort"]\nscore = "mean"\n')
    mine.write_text(f'extends = "{PROTOCOLS / "tiny.toml"}"\nname = "mine"\n'
                    + '\n[[timeline]]\nphase = "orientation"\nminutes = 1\n[[timeline]]\nphase = "training"\n'
                      'minutes = 6\n[[timeline]]\nphase = "stage1"\nminutes = 6\n[[timeline]]\nphase = "stage2"\n'
                      'minutes = 6\n[[timeline]]\nphase = "end"\ninstruments = ["paper", "comfort"]\n'
                      'about = "each"\nminutes = 4\n')
    study = str(tmp_path / "study")
    result = CliRunner().invoke(main, ["study", "init", study, "--protocol", str(mine)])
    assert result.exit_code == 0
    assert (f"warning: {mine}: timeline[4].instruments = ['paper', 'comfort']: comfort: the rating model of "
            "simulated participants answers only") in result.output
    CliRunner().invoke(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
                              "--handedness", "right", "--mr-experience", "yes"])
    result = CliRunner().invoke(main, ["session", "run", study, "--participant", "P01", "--input", "simulated"])
    assert result.exit_code == 1 and "a simulated participant cannot run this study's protocol" in result.output
    with open_study(study) as store:
        assert store.session_of("P01") is None
    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path / "demo"), "--participants", "2",
                                       "--protocol", str(mine), "--quiet"])
    assert result.exit_code == 1 and "'comfort'" in result.output and not (tmp_path / "demo").exists()


# ---------------------------------------------------------------- what a careful tester tries (issue 29)

REPOSITORY = PROTOCOLS.parents[2]


@contextlib.contextmanager
def acting_as_another_user():
    """The process acting as a user whom permissions stop: itself, or user nobody when it runs as
    root (whom no permission stops); yields the user's name."""
    if os.geteuid() != 0:
        yield pwd.getpwuid(os.geteuid()).pw_name
        return
    try:
        nobody = pwd.getpwnam("nobody")
    except KeyError:
        pytest.skip("runs as root and there is no user nobody to act as")
    os.setegid(nobody.pw_gid)
    os.seteuid(nobody.pw_uid)
    try:
        yield nobody.pw_name
    finally:
        os.seteuid(0)
        os.setegid(0)


@pytest.fixture
def locked_study():
    """A study inside a folder nobody may enter: (the folder, the study); in a folder of its own that
    anyone may enter (pytest's own temporary folders are the owner's only)."""
    base = Path(tempfile.mkdtemp(prefix="microg-locked-"))
    base.chmod(0o755)
    locked = base / "locked"
    study = locked / "study"
    assert CliRunner().invoke(main, ["study", "init", str(study), "--protocol", str(PROTOCOLS / "tiny.toml")]).exit_code == 0
    locked.chmod(0)
    yield locked, study
    locked.chmod(0o755)
    shutil.rmtree(base)


@pytest.mark.parametrize("args", [
    ["study", "status", "{study}"],
    ["participant", "add", "{study}", "--id", "P01", "--gender", "female", "--age", "24", "--handedness", "right",
     "--mr-experience", "yes"],
    ["session", "run", "{study}", "--participant", "P01", "--input", "simulated", "--quiet"],
    ["export", "{study}", "--quiet"],
    ["report", "{study}", "--out", "{locked}/report"],
])
def test_a_study_in_a_folder_the_user_may_not_enter_names_the_folder_and_the_permission(locked_study, args):
    locked, study = locked_study
    args = [a.format(study=study, locked=locked) for a in args]
    with acting_as_another_user() as user:
        result = CliRunner().invoke(main, args)
    assert result.exit_code in (1, 2) and "Traceback" not in result.output, result.output
    assert f"{locked}: permission denied: user {user} may not enter this folder" in result.output, result.output


@pytest.mark.slow
@pytest.mark.parametrize("name", ["SIGTERM", "SIGHUP", "SIGINT"])
def test_sigterm_and_sighup_pause_a_session_as_ctrl_c_does(tmp_path, name):
    study = str(tmp_path / "study")
    CliRunner().invoke(main, ["study", "init", study, "--protocol", str(PROTOCOLS / "tiny.toml")])
    CliRunner().invoke(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
                              "--handedness", "right", "--mr-experience", "yes"])
    # watched on the participant's display, the simulated participant plays at real time: seconds a task
    session = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "session", "run", study,
                                "--participant", "P01", "--input", "simulated", "--display"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=REPOSITORY)
    said = bytearray()

    def read() -> None:  # the progress bar rewrites its line: read what comes, not lines
        while chunk := os.read(session.stderr.fileno(), 4096):
            said.extend(chunk)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        wait_until(lambda: b" frames, " in said, "the session's progress bar to count frames of its first task",
                   seen=lambda: bytes(said[-400:]), going=lambda: session.poll() is None)
        session.send_signal(getattr(signal, name))
        status = ended(session, f"the session after {name}")
    finally:
        if session.poll() is None:
            session.kill()
            session.wait()
    joined(reader, "the reader of the session's messages")
    told = said.decode(errors="replace")
    shown = told[-6000:]  # on failure: the end of what the session said, the whole traceback if any
    assert status == 1 and "Traceback" not in told, shown
    assert told.rsplit("\r", 1)[-1].rstrip().endswith(
        f"Error: session 1 of P01 paused; the task in progress will run again from its start on: microg session "
        f"resume {study} --participant P01"), shown
    with open_study(study, readonly=True) as store:
        session_record = store.session_of("P01")
        run = store.runs(session_record.id)[-1]
        ended_by = [e.data["reason"] for e in store.events(session_record.id, run.id) if e.kind == "task_end"]
    assert session_record.status == "running" and run.status == "interrupted"
    assert ended_by == [f"KeyboardInterrupt: {name}"], ended_by


def test_a_signal_stops_a_session_at_its_next_safe_point_or_where_it_waits():
    """Ctrl-C, SIGTERM or SIGHUP while the session computes is noted and raised at its next safe
    point (here a frame), never inside what it computes, or as the session ends when none came after
    it; while it waits (a prompt, the page, a tracker) it stops the wait at once."""
    from microg.cli.session import _Checked, _pause_on_signals

    with pytest.raises(KeyboardInterrupt, match="SIGTERM"):
        with _pause_on_signals() as pause:
            signal.raise_signal(signal.SIGTERM)
            wait_until(lambda: pause.signal, "the handler to note SIGTERM")  # it ran, and raised nothing
            pause.take(None)
    with pytest.raises(KeyboardInterrupt, match="SIGINT"):
        with _pause_on_signals() as pause:
            signal.raise_signal(signal.SIGINT)
            wait_until(lambda: pause.signal, "the handler to note SIGINT")  # no safe point after it

    class Researcher:
        def __init__(self):
            self.asked = threading.Event()

        def ready(self, task):
            self.asked.set()
            return threading.Event().wait(WAIT_S)  # no answer comes

    researcher = Researcher()

    def hang_up() -> None:
        if researcher.asked.wait(WAIT_S):
            signal.pthread_kill(threading.main_thread().ident, signal.SIGHUP)

    with _pause_on_signals() as pause:
        threading.Thread(target=hang_up, daemon=True).start()
        with pytest.raises(KeyboardInterrupt, match="SIGHUP"):
            _Checked(researcher, pause, waits=True).ready(None)


def test_session_run_help_lists_every_input_the_readme_documents():
    readme = (REPOSITORY / "README.md").read_text()
    listed = re.search(r"--input ([\w:\\|]+)` \|", readme).group(1).split("\\|")  # the table of verbs
    named = re.findall(r"`--input (\w+:[A-Z_.]+)`", readme)  # the prose: replay:FILE, lsl:NAME
    assert {"leap", "webxr", "lsl:NAME", "replay:FILE", "simulated"} <= set(listed + named)
    help_text = CliRunner().invoke(main, ["session", "run", "--help"]).output
    for value in listed + named:
        assert value in help_text, value


@pytest.mark.parametrize("args, message", [
    (["hands", "import", "{recording}", "-o", "{out}/x.arrows"], "-o is now --out"),
    (["hands", "import", "{recording}", "--output", "{out}/x.arrows"], "--output is now --out"),
    (["hands", "import", "{recording}", "--force"], "--force is now --overwrite"),
    (["hands", "record", "--out", "{out}/x.arrows", "--force"], "--force is now --overwrite"),
    (["power", "--effects", "{out}/e.toml", "--system", "soft_hand", "--out", "{out}"], "--system is now --interaction"),
    (["report", "--system", "soft_hand", "--out", "{out}"], "--system is now --interaction"),
    (["report", "--system-column", "model", "--out", "{out}"], "--system-column is now --interaction-column"),
    (["view", "--study", "{out}"], "--study is now the argument STUDY_DIR"),
])
def test_a_renamed_option_names_its_new_spelling(tmp_path, args, message):
    recording = REPOSITORY / "data" / "leap-v2-recordings" / "wave.json.gz"
    result = CliRunner().invoke(main, [a.format(recording=recording, out=tmp_path) for a in args])
    assert result.exit_code == 2 and f"Error: {message}" in result.output, result.output
    assert list(tmp_path.iterdir()) == []


def test_a_seed_the_database_cannot_store_is_refused_by_the_option(tmp_path):
    result = CliRunner().invoke(main, ["study", "init", str(tmp_path / "s"), "--seed", str(2**63)])
    assert result.exit_code == 2 and "is not in the range 0<=x<=9223372036854775807" in result.output
    assert not (tmp_path / "s").exists()


BIG = "1" + "0" * 400
"""An integer TOML reads and no double holds."""


@pytest.mark.parametrize("protocol, objects, expected", [
    ("", 'material = 3\n', ["objects/slab.toml", "material = 3: must be a table"]),
    ("", 'mass = 1e300\n', ["objects/slab.toml", "mass = 1e+300: must lie from 0.0001 to 1000 kg"]),
    ("", f'size = [{BIG}, 0.05, 0.05]\n', ["objects/slab.toml", f"size.x = {BIG}: must be a positive number"]),
    ("", 'inertia = ["heavy", 1e-4, 1e-4]\n', ["objects/slab.toml", "inertia[0] = 'heavy': must be a positive number"]),
    ("", 'name = 7\n', ["objects/slab.toml", "name = 7: must be a non-empty string"]),
    (f"duration_minutes = {BIG}\n", "", [f"duration_minutes = {BIG}: must be a positive number"]),
    (f"seed = {2**64}\n", "", [f"seed = {2**64}: must be a whole number from 0 to 9223372036854775807"]),
    ("[logging]\nframe_batch = 1000000000000\n", "", ["logging.frame_batch = 1000000000000: must be a whole number "
                                                      "from 1 to 10000"]),
    ("[scene]\nsubsteps = 1000000000\n", "", ["scene.substeps = 1000000000: the physics would step 1.1e+11 times"]),
    ("[scene]\nfilter_window = 1000000000\n", "", ["scene.filter_window = 1000000000: must be a whole number from 1 "
                                                   "to 100"]),
    ("[scene]\ngravity = [0.0, -1e300, 0.0]\n", "", ["scene.gravity = [0.0, -1e+300, 0.0]: each number must lie "
                                                     "within 100 of zero"]),
    ("[task]\nhold_s = 100.0\n", "", ["task.timeout_s = 15.0: the 3 holds of hold_s = 100 s take longer"]),
    ("[task]\nplaces = [" + "[0.0, 0.2, 0.0], " * 101 + "]\n", "", ["task.places: 101 positions; at most 100"]),
    ("[questionnaire]\nscale_max = 1000000000000000000\n", "", ["[questionnaire] is now an instrument file"]),
    ("x = " + "[" * 2000 + "]" * 2000 + "\n", "", ["not a protocol file: its tables or arrays are nested too deeply"]),
    ("# " + "x" * (1 << 20) + "\n", "", ["over 1 MiB: not a protocol file"]),
])
def test_absurd_sizes_in_protocol_and_object_files_name_file_key_and_value(tmp_path, protocol, objects, expected):
    (tmp_path / "objects").mkdir()
    slab = {"name": '"slab"', "shape": '"box"', "size": "[0.1, 0.02, 0.05]", "mass": "0.2"}
    slab.update(line.split(" = ", 1) for line in objects.splitlines())
    (tmp_path / "objects" / "slab.toml").write_text("".join(f"{k} = {v}\n" for k, v in slab.items()))
    mine = tmp_path / "mine.toml"
    mine.write_text(f'extends = "{PROTOCOLS / "tiny.toml"}"\nname = "mine"\n{protocol}'
                    + ("" if "[objects]" in protocol or not objects else '[objects]\nnames = ["slab"]\n'))
    result = CliRunner().invoke(main, ["study", "init", str(tmp_path / "s"), "--protocol", str(mine)])
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert str(tmp_path) in result.output
    for part in expected:
        assert part in result.output, (part, result.output)
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("verb, message", [
    (["session", "run", "{study}", "--participant", "P01", "--input", "replay:{deep}", "--quiet"],
     "{deep}: not a replay manifest: its tables or arrays are nested too deeply"),
    (["report", "--trials", "{deep}", "--columns", "{deep}", "--out", "{out}"],
     "{deep}: not a TOML file of column names: nested too deeply"),
])
def test_toml_nested_too_deeply_is_named_by_every_reader(tmp_path, verb, message):
    study, deep = tmp_path / "study", tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 2000 + "]" * 2000 + "\n")
    CliRunner().invoke(main, ["study", "init", str(study), "--protocol", str(PROTOCOLS / "tiny.toml")])
    CliRunner().invoke(main, ["participant", "add", str(study), "--id", "P01", "--gender", "female", "--age", "24",
                              "--handedness", "right", "--mr-experience", "yes"])
    names = dict(study=study, deep=deep, out=tmp_path / "out")
    result = CliRunner().invoke(main, [a.format(**names) for a in verb])
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert message.format(**names) in result.output


@pytest.mark.parametrize("name, text, message", [
    ("pilot.txt", "[parameters.aim_sd]\nmean = 0.004\nsd = 0.001\n", "is no profile: give a population file (.toml)"),
    ("pilot.toml", "[parameters.aim_sd]\nmean = 0.004\nsd = -0.001\n", "parameters.aim_sd.sd = -0.001: must be >= 0"),
])
def test_a_demo_of_a_population_that_cannot_be_drawn_from_writes_nothing(tmp_path, name, text, message):
    """Before, a file not named .toml ended in a worker's traceback after the study was made."""
    profile = tmp_path / name
    profile.write_text(text)
    result = CliRunner().invoke(main, ["demo", "--profile", str(profile), "--participants", "2",
                                       "--out", str(tmp_path / "demo")])
    assert result.exit_code == 1 and f"--profile {profile}: " in result.output and message in result.output
    assert "Traceback" not in result.output and not (tmp_path / "demo").exists()
