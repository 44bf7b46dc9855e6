"""Import of the shared LeapJS v2 recordings, checked against the raw JSON read independently."""

import gzip
import json

import numpy as np
import pytest

from microg.hands import RecordingError, load_recording
from microg.hands.leapjs import read_leapjs
from tests.hands.conftest import FILES


def raw_json(path):
    with gzip.open(path, "rt") as stream:
        return json.load(stream)


@pytest.fixture(scope="module")
def imported(recordings):
    return {name: (load_recording(recordings / name), raw_json(recordings / name)) for name in FILES}


@pytest.mark.parametrize("name", FILES)
def test_every_frame_imports_with_strictly_increasing_timestamps(imported, name):
    recording, raw = imported[name]
    assert len(recording.frames) == FILES[name] == raw["metadata"]["frames"]
    times = np.array([f.timestamp for f in recording.frames])
    assert (np.diff(times) > 0).all()
    recorded = np.array([f["timestamp"] for f in raw["frames"]])  # microseconds on the recorder's clock
    assert times[0] == 0.0 and np.array_equal(times, (recorded - recorded[0]) / 1e6)  # from the first frame
    assert all([h.side for h in f.hands] == ["right"] for f in recording.frames)
    assert not recording.truncated


@pytest.mark.parametrize("name", FILES)
def test_frames_are_kept_as_they_arrived_with_their_gaps(imported, name):
    recording, raw = imported[name]
    raw_gaps = np.sum(np.diff([f["timestamp"] for f in raw["frames"]]) > 20_000)
    assert np.sum(np.diff([f.timestamp for f in recording.frames]) > 0.020) == raw_gaps


@pytest.mark.parametrize("name", FILES)
def test_bone_lengths_are_human_and_match_the_trackers_own_finger_length(imported, name):
    recording, raw = imported[name]
    lengths = np.array([f.hands[0].bone_lengths for f in recording.frames]) * 1e3  # mm
    # the Leap skeleton keeps its bone lengths: constant over frames
    median = np.median(lengths, axis=0)
    assert np.std(lengths[:, :, 1:], axis=0).max() < 0.5
    assert median[0, 0] == 0.0  # the thumb's zero-length metacarpal
    assert np.isnan(median[1:, 0]).all()  # no metacarpal bases in LeapJS v2: unknown, not zero
    assert ((median[:, 1] > 25) & (median[:, 1] < 55)).all()  # proximal (the thumb's: its metacarpal)
    assert ((median[:, 2] > 15) & (median[:, 2] < 40)).all()  # intermediate
    assert ((median[:, 3] > 12) & (median[:, 3] < 30)).all()  # distal
    # LeapJS's own finger ``length``: intermediate + distal, plus half the proximal for the fingers
    frame = raw["frames"][len(raw["frames"]) // 2]
    reported = {p["type"]: p["length"] for p in frame["pointables"]}
    ours = lengths[len(raw["frames"]) // 2]
    for digit, length in reported.items():
        expected = ours[digit, 2] + ours[digit, 3] + (0.5 * ours[digit, 1] if digit else 0.0)
        assert expected == pytest.approx(length, abs=0.5)


def test_values_are_the_recorded_ones_in_metres(imported):
    recording, raw = imported["pinch.json.gz"]
    frame, hand = raw["frames"][100], recording.frames[100].hands[0]
    assert hand.palm_position == pytest.approx(np.array(frame["hands"][0]["palmPosition"]) * 1e-3)
    assert hand.track_id == frame["hands"][0]["id"]
    for finger in frame["pointables"]:
        d = finger["type"]
        for j, key in enumerate(("mcpPosition", "pipPosition", "dipPosition", "tipPosition"), start=1):
            assert hand.joints[d, j] == pytest.approx(np.array(finger[key]) * 1e-3)
        assert hand.widths[d, 1:] == pytest.approx([finger["width"] * 1e-3] * 3)


@pytest.mark.parametrize("name", FILES)
def test_palm_orientation_maps_the_hand_axes_onto_normal_and_direction(imported, name):
    """LeapC's convention: hand -y is the palm normal, hand -z the direction to the fingers."""
    from scipy.spatial.transform import Rotation

    recording, raw = imported[name]
    for frame, raw_frame in list(zip(recording.frames, raw["frames"]))[::25]:
        w, x, y, z = frame.hands[0].palm_orientation
        rotation = Rotation.from_quat([x, y, z, w])
        raw_hand = raw_frame["hands"][0]
        assert rotation.apply([0, -1, 0]) == pytest.approx(raw_hand["palmNormal"], abs=0.02)
        assert rotation.apply([0, 0, -1]) == pytest.approx(raw_hand["direction"], abs=0.02)


def test_a_bad_field_is_named_with_its_value(tmp_path):
    document = {"metadata": {"frames": 1}, "frames": [
        {"timestamp": 5, "hands": [{"id": 1, "type": "right", "palmPosition": "up"}], "pointables": []}]}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document))
    with pytest.raises(RecordingError, match=r"bad.json: frames\[0\].hands\[0\].palmPosition = 'up'"):
        read_leapjs(path)


def test_a_missing_value_stays_unknown(tmp_path):
    document = {"frames": [{"timestamp": 5, "hands": [{"id": 1, "type": "left", "palmPosition": [1, 2, 3]}],
                            "pointables": [{"handId": 1, "type": 1, "mcpPosition": [0, 0, 0],
                                            "pipPosition": [0, 0, -40], "dipPosition": None,
                                            "tipPosition": [0, 0, -80], "width": 18}]}]}
    path = tmp_path / "partial.json"
    path.write_text(json.dumps(document))
    hand = read_leapjs(path).frames[0].hands[0]
    assert np.isnan(hand.joints[1, 3]).all() and np.isnan(hand.joints[0]).all()
    assert hand.joints[1, 2] == pytest.approx([0, 0, -0.04])
    assert np.isnan(hand.palm_orientation).all()


@pytest.mark.parametrize("content, message", [
    (b"not json at all", "neither a microg hand recording"),
    (b'{"frames": 3}', "frames is missing or not a list"),
    (b'{"frames": [{"timestamp": "soon"}]}', r"frames\[0\].timestamp = 'soon'"),
])
def test_what_is_not_a_recording_is_refused_by_name(tmp_path, content, message):
    path = tmp_path / "thing.json"
    path.write_bytes(content)
    with pytest.raises(RecordingError, match=message):
        load_recording(path)
