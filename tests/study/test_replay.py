"""Real recordings replayed through real tasks: placed in the workspace, one recording per task."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.hands.align import Alignment, find_alignment, parse_alignment
from microg.paths import LEAP_RECORDINGS
from microg.skeleton import Hand, HandFrame
from microg.study.store import open_study

from .conftest import PROTOCOLS


def run(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result


def test_a_given_alignment_moves_and_turns_every_hand_rigidly():
    alignment = parse_alignment("0.1,0.2,0.3,0,90,0")
    assert isinstance(alignment, Alignment) and alignment.offset == (0.1, 0.2, 0.3)
    joints = np.zeros((5, 5, 3))
    joints[1, 4] = [0.05, 0.0, 0.0]
    hand = Hand("right", joints, np.full((5, 4), 0.01), np.zeros(3))
    moved = alignment.hand(hand)
    # 90 degrees about y takes +x to -z; then the offset
    assert np.allclose(moved.joints[1, 4], [0.1, 0.2, 0.3 - 0.05]) and np.allclose(moved.palm_position, [0.1, 0.2, 0.3])
    assert np.linalg.norm(moved.joints[1, 4] - moved.joints[0, 0]) == pytest.approx(0.05)


def test_grasp_alignment_puts_the_tightest_pinch_on_the_object():
    tips = [(0.30, 0.05), (0.10, 0.01), (0.20, 0.03)]  # (x of the pinch, thumb-index gap)
    frames = []
    for t, (x, gap) in enumerate(tips):
        joints = np.full((5, 5, 3), np.nan)
        joints[0, 4], joints[1, 4] = [x - gap / 2, 0.5, 0.0], [x + gap / 2, 0.5, 0.0]
        frames.append(HandFrame(float(t), (Hand("right", joints, np.full((5, 4), np.nan), np.array([x, 0.6, 0.0])),)))
    alignment = find_alignment("grasp", frames, hand_start=(0, 0.3, 0.1), object_start=(-0.12, 0.18, 0.0))
    assert np.allclose(alignment.offset, [-0.12 - 0.10, 0.18 - 0.5, 0.0])
    start = find_alignment("start", frames, hand_start=(0, 0.3, 0.1), object_start=(-0.12, 0.18, 0.0))
    assert np.allclose(start.offset, [0 - 0.30, 0.3 - 0.6, 0.1])


def manifest(folder, entries: str) -> str:
    path = folder / "replay.toml"
    path.write_text(f'align = "grasp"\n{entries}')
    return str(path)


def test_a_real_recording_placed_on_the_object_grasps_it_in_a_real_task(tmp_path):
    study = tmp_path / "study"
    assert run("study", "init", study, "--protocol", PROTOCOLS / "quick.toml", "--seed", "3").exit_code == 0
    assert run("participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24",
               "--handedness", "right", "--mr-experience", "yes").exit_code == 0
    grab = LEAP_RECORDINGS / "grab.json.gz"
    entries = "".join(f'[[task]]\nobject = "{name}"\nrecording = "{grab}"\n'
                      for name in ("cube", "flat_cuboid", "long_cuboid", "ball"))
    result = run("session", "run", study, "--participant", "P01", "--input",
                 f"replay:{manifest(tmp_path, entries)}", "--quiet")
    assert result.exit_code == 0, result.output
    with open_study(study) as store:
        session = store.session_of("P01")
        runs = store.db.execute("SELECT id, source FROM task_runs WHERE session_id = ?", (session.id,)).fetchall()
        assert all("grab.json.gz" in source and "'how': 'grasp'" in source for _, source in runs)
        holds = [e for e in store.events(session.id) if e.kind == "hold"]
        assert holds, "a real hand closing on the object holds it in at least one task"


def test_a_task_without_a_recording_is_an_error_before_anything_runs(tmp_path):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "tiny.toml", "--seed", "3")
    run("participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24", "--handedness", "right",
        "--mr-experience", "yes")
    entries = f'[[task]]\nobject = "cube"\nphase = "stage1"\nrecording = "{LEAP_RECORDINGS / "grab.json.gz"}"\n'
    result = run("session", "run", study, "--participant", "P01", "--input", f"replay:{manifest(tmp_path, entries)}")
    assert result.exit_code == 1 and "no recording for the task stage2 cube of P01" in result.output
    with open_study(study) as store:
        assert store.session_of("P01") is None  # nothing ran, nothing was logged


@pytest.mark.parametrize("entries, message", [
    ('[[task]]\nobject = "cube"\n', "task[0].recording = None: must be a non-empty string"),
    ('[[task]]\nobject = "cube"\nrecording = "nowhere.json"\n', "no such file"),
    ('[[task]]\nobject = "cube"\nrecording = "{grab}"\nstart_s = 3\nend_s = 1\n', "task[0].end_s = 1"),
    ('[[task]]\nobject = "cube"\nrecording = "{grab}"\nalign = "up"\n', "task[0].align: --align 'up'"),
    ('[[task]]\nobject = "cube"\nrecording = "{grab}"\nspeed = 2\n', "unknown key 'speed'"),
])
def test_a_bad_manifest_is_named_with_its_key_and_value(tmp_path, entries, message):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "tiny.toml", "--seed", "3")
    run("participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24", "--handedness", "right",
        "--mr-experience", "yes")
    path = manifest(tmp_path, entries.format(grab=LEAP_RECORDINGS / "grab.json.gz"))
    result = run("session", "run", study, "--participant", "P01", "--input", f"replay:{path}")
    assert result.exit_code == 1 and message in result.output and "replay.toml" in result.output


def test_the_mocap_stream_on_lsl_carries_the_logged_poses(make_study):
    pylsl = pytest.importorskip("pylsl")
    from microg.study.lsl import MOCAP_CHANNELS, MocapOutlet, session_tags
    from microg.study.session import Outputs, SimulationClock, run_session
    from microg.study import framelog

    from .conftest import scripted_inputs

    store, _ = make_study("tiny")
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    outlet = MocapOutlet(store.protocol.tracking_rate, session_tags(store, session.id), name="microg-test-mocap",
                         source_id="microg-test-mocap")
    inlet = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", "microg-test-mocap")[0], max_buflen=600)
    info = inlet.info()
    channel = info.desc().child("channels").child("channel")
    labels = []
    while not channel.empty():
        labels.append((channel.child_value("label"), channel.child_value("unit"), channel.child_value("type")))
        channel = channel.next_sibling()
    assert labels == list(MOCAP_CHANNELS) and info.type() == "MoCap"
    inlet.open_stream()
    run_session(store, session.id, scripted_inputs(), clock=SimulationClock(), outputs=Outputs(sinks=(outlet,)))
    received, _ = inlet.pull_chunk(timeout=5.0, max_samples=100_000)
    logged = np.concatenate([framelog.read(store.db, run.id) for run in store.runs(session.id)])
    assert len(received) == len(logged)
    names = [label for label, _, _ in MOCAP_CHANNELS]
    received = np.asarray(received, dtype=np.float32)
    object_columns = [names.index(f"object_{a}") for a in "xyz"]
    np.testing.assert_array_equal(received[:, object_columns], logged["position"])
    rendered = [names.index(f"rendered_right_index_proximal_{a}") for a in "xyz"]
    np.testing.assert_array_equal(received[:, rendered], logged["rendered"][:, 1, 5])
