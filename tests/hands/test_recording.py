"""The recording format: exact round trips, crash safety, metadata, replay and source selection."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from microg.skeleton import Hand, HandFrame
from microg.hands import (RecordingError, RecordingInfo, RecordingWriter, ReplaySource, load_recording,
                          open_source, read_recording, record, write_recording)
from microg.hands.recording import UNKNOWN
from microg.hands.source import HandSource
REPOSITORY = Path(__file__).resolve().parents[2]
from tests.hands.synthetic import flat_hand, sweep, with_nan

INFO = RecordingInfo(source="test", device="synthetic hand", frame_rate=110.0, start_time="2024-05-01T10:00:00+00:00")


def awkward_frames(n: int = 40) -> list[HandFrame]:
    """Both hands, one hand, none; NaNs where a tracker marks values unknown; changing ids."""
    rng = np.random.default_rng(3)
    frames = []
    for i in range(n):
        hands = []
        if i % 7:
            right = flat_hand(rng.normal(0, 0.1, 3), "right", track_id=i // 10)
            hands.append(with_nan(right, joint=(1, 0)) if i % 3 else right)
        if i % 2:
            left = flat_hand(rng.normal(0, 0.1, 3), "left", track_id=100 + i)
            hands.append(Hand("left", left.joints, left.widths, left.palm_position, np.full(4, np.nan), left.track_id))
        frames.append(HandFrame(1234.5 + i * 0.0091 + rng.uniform(0, 1e-4), tuple(hands)))
    return frames


def test_write_then_read_gives_identical_frames_and_metadata(tmp_path):
    frames = awkward_frames()
    path = tmp_path / "take.arrows"
    assert write_recording(path, INFO, frames) == len(frames)
    recording = read_recording(path)
    assert recording.frames == tuple(frames)
    assert recording.info == INFO
    assert not recording.truncated and recording.problem == ""


def test_record_then_replay_gives_identical_frames(tmp_path):
    frames = awkward_frames(25)
    path = tmp_path / "live.arrows"
    summary = record(ReplaySource(frames, "pretend-live"), path, INFO, progress=False)
    assert summary.frames == 25 and summary.seconds == pytest.approx(frames[-1].timestamp - frames[0].timestamp)
    replay = open_source(f"replay:{path}")
    assert isinstance(replay, HandSource)
    replayed = []
    while (frame := replay.next_frame()) is not None:
        replayed.append(frame)
    # the same frames, on a clock from the first frame's (the recorder's clock read 1234.5 s)
    assert replayed == [HandFrame(f.timestamp - frames[0].timestamp, f.hands) for f in frames]
    assert replay.description == f"replay:{path}"


def test_record_stops_after_duration_or_frames_and_stamps_the_start_time(tmp_path):
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 50)
    by_frames = record(ReplaySource(frames, "s"), tmp_path / "a.arrows", INFO, max_frames=7, progress=False)
    assert by_frames.frames == 7
    unknown_start = RecordingInfo(source="s", device="d", frame_rate=110.0, start_time=UNKNOWN)
    by_time = record(ReplaySource(frames, "s"), tmp_path / "b.arrows", unknown_start, duration=0.1, progress=False)
    assert by_time.frames == 12  # 0.1 s at 110 Hz: frames 0..11
    assert read_recording(tmp_path / "b.arrows").info.start_time.startswith("20")


def test_the_shared_recordings_survive_the_round_trip(recordings, tmp_path):
    original = load_recording(recordings / "grab.json.gz")
    write_recording(tmp_path / "grab.arrows", original.info, original.frames)
    copy = load_recording(tmp_path / "grab.arrows")
    assert copy.frames == original.frames and copy.info == original.info


def test_a_file_cut_mid_write_keeps_every_complete_frame_and_says_so(tmp_path):
    frames = awkward_frames(30)
    path = tmp_path / "whole.arrows"
    boundaries = []
    with RecordingWriter(path, INFO, batch_frames=4) as writer:
        for frame in frames:
            writer.write(frame)
            if writer.frames_written and (not boundaries or boundaries[-1][0] != writer.frames_written):
                boundaries.append((writer.frames_written, os.path.getsize(path)))
    data = path.read_bytes()
    for written, size in boundaries[:-1]:
        for cut in (size, size + 1, size + 37):
            partial = tmp_path / f"cut{cut}.arrows"
            partial.write_bytes(data[:cut])
            recording = read_recording(partial)
            assert recording.truncated, cut
            assert recording.frames == tuple(frames[:written])
    cut_in_end_marker = tmp_path / "end.arrows"
    cut_in_end_marker.write_bytes(data[:-3])
    assert read_recording(cut_in_end_marker).frames == tuple(frames)
    assert read_recording(cut_in_end_marker).truncated


def test_a_crashed_recorder_leaves_a_readable_file(tmp_path):
    """A real crash: the writing process dies without closing the file."""
    path = tmp_path / "crash.arrows"
    script = textwrap.dedent(f"""
        import os
        from microg.hands import RecordingInfo, RecordingWriter
        from tests.hands.synthetic import sweep
        writer = RecordingWriter({str(path)!r}, RecordingInfo("crash", "d", 110.0, "unknown"), batch_frames=10)
        for frame in sweep((0, 0.2, 0), (0.1, 0, 0), 35):
            writer.write(frame)
        os._exit(1)
    """)
    result = subprocess.run([sys.executable, "-c", script], cwd=REPOSITORY, capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(REPOSITORY)})
    assert result.returncode == 1, result.stderr
    recording = read_recording(path)
    assert recording.truncated and "no end marker" in recording.problem
    assert recording.frames == tuple(sweep((0, 0.2, 0), (0.1, 0, 0), 30))


def test_replaying_a_truncated_recording_warns_and_plays_what_was_complete(tmp_path):
    path = tmp_path / "t.arrows"
    write_recording(path, INFO, awkward_frames(12))
    path.write_bytes(path.read_bytes()[:-20])
    with pytest.warns(UserWarning, match="cut off"):
        source = ReplaySource.from_file(path)
    assert 0 < len(source.frames) < 12


def test_an_existing_file_is_never_overwritten_silently(tmp_path):
    path = tmp_path / "keep.arrows"
    path.write_bytes(b"precious")
    with pytest.raises(FileExistsError, match="keep.arrows"):
        RecordingWriter(path, INFO)
    assert path.read_bytes() == b"precious"


def test_other_arrow_streams_and_garbage_are_refused_by_name(tmp_path):
    other = tmp_path / "other.arrows"
    schema = pa.schema([("x", pa.int64())], metadata={"format": "something-else"})
    with pa.OSFile(str(other), "wb") as sink, pa.ipc.new_stream(sink, schema) as writer:
        writer.write_batch(pa.record_batch([pa.array([1])], schema=schema))
    with pytest.raises(RecordingError, match="other.arrows: an Arrow stream but not a hand recording"):
        load_recording(other)
    stub = tmp_path / "stub.arrows"
    stub.write_bytes(b"\xff\xff\xff\xff\x10")
    with pytest.raises(RecordingError, match="stub.arrows: not a readable hand recording"):
        load_recording(stub)


def test_the_format_is_told_by_content_not_by_name(recordings, tmp_path):
    disguised = tmp_path / "grab.arrows"
    disguised.write_bytes((recordings / "grab.json.gz").read_bytes())
    assert load_recording(disguised).info.source == "leapjs:grab.arrows"


def test_paced_replay_keeps_the_recorded_timing():
    frames = [HandFrame(t) for t in (10.0, 10.01, 10.05, 10.06)]
    clock = [100.0]
    waits = []

    def sleep(seconds):
        waits.append(seconds)
        clock[0] += seconds

    source = ReplaySource(frames, "paced", realtime=True, clock=lambda: clock[0], sleep=sleep)
    arrivals = []
    while source.next_frame() is not None:
        arrivals.append(clock[0])
        clock[0] += 0.002  # the session's own work per frame
    assert np.array(arrivals) - 100.0 == pytest.approx([0.0, 0.01, 0.05, 0.06])
    fast = ReplaySource(frames, "fast", clock=lambda: 0.0, sleep=lambda s: pytest.fail("fast replay slept"))
    assert [fast.next_frame() for _ in range(5)] == frames + [None]


def test_open_source_understands_its_specs(tmp_path):
    with pytest.raises(ValueError, match="'simulated:novice'.*leap, lsl:STREAM_NAME, replay:PATH"):
        open_source("simulated:novice")
    with pytest.raises(ValueError, match="replay:PATH"):
        open_source("replay:")
    with pytest.raises(RecordingError, match="missing.arrows"):
        open_source(f"replay:{tmp_path / 'missing.arrows'}")
