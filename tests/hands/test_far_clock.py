"""A source's clock far from zero: rebased once, where the source's time becomes the session's, so
the same motion stamped in 2100 (epoch microseconds, as some trackers stamp frames) or in Unix time
(as the participant's page stamps a headset's frames) replays to the same object path."""

from __future__ import annotations

import gzip
import json

import numpy as np
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.hands import load_recording, write_recording
from microg.hands.webxr import WAITING_FRAMES, WebXRSource
from microg.paths import LEAP_RECORDINGS
from microg.study import framelog
from microg.study.store import open_study
from tests.study.conftest import PROTOCOLS

YEAR_2100_US = 4_102_444_800 * 10**6
"""2100-01-01 in microseconds since the epoch: a double holds it in seconds only to 0.5 us."""
UNIX_NOW_MS = 1.8e12
"""The page's clock (ms since the epoch) about now."""


def replayed(folder, recording) -> np.ndarray:
    """The logged frames of the first task of a replayed session (tiny protocol, placed on the cube)."""
    study = str(folder / "study")
    run = CliRunner().invoke
    assert run(main, ["study", "init", study, "--protocol", str(PROTOCOLS / "tiny.toml"), "--seed", "3"]).exit_code == 0
    run(main, ["participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24", "--handedness",
               "right", "--mr-experience", "yes"])
    result = run(main, ["session", "run", study, "--participant", "P01", "--input", f"replay:{recording}", "--align",
                        "grasp", "--quiet"])
    assert result.exit_code == 0, result.output
    with open_study(study, readonly=True) as store:
        return framelog.read(store.db, store.runs(store.session_of("P01").id)[0].id)


@pytest.mark.slow
def test_a_leapjs_recording_stamped_in_2100_replays_to_the_same_object_path(tmp_path):
    document = json.loads(gzip.decompress((LEAP_RECORDINGS / "grab.json.gz").read_bytes()))
    for frame in document["frames"]:
        frame["timestamp"] += YEAR_2100_US
    far = tmp_path / "grab-2100.json"
    far.write_text(json.dumps(document))
    original, shifted = replayed(tmp_path / "a", LEAP_RECORDINGS / "grab.json.gz"), replayed(tmp_path / "b", far)
    # the timestamps are whole microseconds: rebased in microseconds they are the same numbers, so the
    # physics computes the same path to the last bit (unrebased, it moved by 0.1 mm in this task)
    assert len(original) == len(shifted) > 100
    for name in ("t", "position", "orientation", "joints"):
        assert np.array_equal(original[name], shifted[name], equal_nan=True), name


@pytest.mark.slow
def test_a_recording_in_unix_seconds_replays_within_its_own_rounding(tmp_path):
    recording = load_recording(LEAP_RECORDINGS / "grab.json.gz")
    unix = tmp_path / "grab-unix.arrows"
    write_recording(unix, recording.info, [type(f)(f.timestamp + UNIX_NOW_MS / 1e3, f.hands) for f in recording.frames])
    original, shifted = replayed(tmp_path / "a", LEAP_RECORDINGS / "grab.json.gz"), replayed(tmp_path / "b", unix)
    # stored at 1.8e9 s (where doubles lie 2^-22 s apart) each time is rounded by up to 2^-23 s, 0.12 us,
    # and rebased exactly. The hand moves under 2 m/s: 0.24 um in that time; the object's path may differ
    # by ten times that, 2.4 um (it differs by 1.2 um here; unrebased it moved by 0.1 mm in this task)
    assert len(original) == len(shifted) > 100
    assert np.abs(original["t"] - shifted["t"]).max() <= 2.0**-23
    assert np.linalg.norm(original["position"] - shifted["position"], axis=-1).max() <= 2.4e-6


def flat_hand_message(t: float) -> dict:
    """A hands message at page time ``t`` (ms) without a hand: the clock is what is tested."""
    return {"type": "hands", "t": t, "hands": []}


def test_headset_frames_in_unix_time_keep_their_intervals_exactly():
    source = WebXRSource(90.0, backlog_s=10.0)
    clock = {"offset_ms": 12.375, "rtt_ms": 3.0, "spread_ms": 0.5}
    reads = UNIX_NOW_MS + np.arange(20) * 11.0  # a 90 Hz headset, on the page's clock (ms since the epoch)
    for t in reads:
        source.receive(flat_hand_message(float(t)), clock)
    times = np.array([source.next_frame().timestamp for _ in reads])
    # from the first frame, whole milliseconds apart: exact (in Unix seconds the 11 ms intervals came
    # out as 0.01099992 or 0.01100016 s: doubles at 1.8e9 s lie a quarter of a microsecond apart)
    assert np.array_equal(times, np.arange(20) * 11.0 / 1e3)
    source.close()


def test_a_page_with_a_standing_clock_cannot_pile_up_frames():
    source = WebXRSource(90.0)
    clock = {"offset_ms": 0.0, "rtt_ms": 3.0, "spread_ms": 0.5}
    for _ in range(10 * WAITING_FRAMES):
        source.receive(flat_hand_message(UNIX_NOW_MS), clock)  # a script that never moves its clock on
    assert len(source._frames) == WAITING_FRAMES and source.frames_dropped == 9 * WAITING_FRAMES
    source.close()
