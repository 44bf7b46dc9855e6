"""Recordings read within a stated bound: a gzip bomb is refused before it fills the memory, JSON
nested too deeply or holding numbers no double holds is named, and the bound can be raised."""

from __future__ import annotations

import gzip
import json
import tracemalloc

import numpy as np
import pytest

from microg.hands import RecordingError, load_recording
from microg.hands.leapjs import INFLATE_RATIO, LIMIT_VARIABLE

MiB = 1 << 20


def bomb(path, inflated: int):
    """A valid LeapJS document of no frames padded with ``inflated`` bytes of blanks, gzipped (1000:1)."""
    with gzip.open(path, "wb", compresslevel=9) as out:
        out.write(b'{"frames": [')
        for _ in range(inflated // MiB):
            out.write(b" " * MiB)
        out.write(b"]}")
    return path


def test_a_gzip_bomb_is_refused_before_it_inflates(tmp_path):
    path = bomb(tmp_path / "bomb.json.gz", 64 * MiB)
    size = path.stat().st_size
    assert size < MiB // 8  # 64 MiB of JSON in a file of tens of kilobytes
    tracemalloc.start()
    try:
        with pytest.raises(RecordingError) as refused:
            load_recording(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    message = str(refused.value)
    assert message.startswith(f"{path}: holds more than {INFLATE_RATIO * size} bytes of JSON ({INFLATE_RATIO} times "
                              "the gzip file); refused unread") and LIMIT_VARIABLE in message
    assert peak < 4 * INFLATE_RATIO * size  # what the bound allows, not the 64 MiB (read whole, it took them)


def test_the_bound_is_configurable(tmp_path, monkeypatch):
    path = bomb(tmp_path / "bomb.json.gz", 2 * MiB)
    with pytest.raises(RecordingError, match="16 times the gzip file"):
        load_recording(path)
    monkeypatch.setenv(LIMIT_VARIABLE, str(3 * MiB))
    assert load_recording(path).frames == ()  # read whole: a document without frames
    monkeypatch.setenv(LIMIT_VARIABLE, "100")
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps({"frames": [], "metadata": {"title": "x" * 200}}))
    with pytest.raises(RecordingError, match=rf"{plain}: holds more than 100 bytes of JSON \({LIMIT_VARIABLE}\)"):
        load_recording(plain)
    monkeypatch.setenv(LIMIT_VARIABLE, "lots")
    with pytest.raises(RecordingError, match=f"{LIMIT_VARIABLE} = 'lots': must be a whole number of bytes"):
        load_recording(plain)


def test_json_nested_too_deeply_is_named(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"frames": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(RecordingError, match=rf"{path}: not a LeapJS recording: its JSON is nested too deeply"):
        load_recording(path)


BIG = 10**400
"""An integer JSON holds and no double does."""


def frame(timestamp=5, hand_id=1, palm=(0, 200, 0)):
    return {"timestamp": timestamp, "hands": [{"id": hand_id, "type": "right", "palmPosition": list(palm)}],
            "pointables": []}


def test_integers_no_double_holds_are_named_or_unknown(tmp_path):
    path = tmp_path / "big.json"
    path.write_text(json.dumps({"frames": [frame(timestamp=BIG)]}))
    with pytest.raises(RecordingError, match=r"frames\[0\].timestamp = 1000000000.*: must be a number"):
        load_recording(path)
    path.write_text(json.dumps({"frames": [frame(hand_id=2**64)]}))
    with pytest.raises(RecordingError, match=rf"frames\[0\].hands\[0\].id = {2**64}: must be an integer hand id"):
        load_recording(path)
    path.write_text(json.dumps({"frames": [frame(palm=(BIG, 200, 0))], "metadata": {"frameRate": BIG}}))
    recording = load_recording(path)  # beyond any double: infinite, so unknown, as the tracker marks it
    palm = recording.frames[0].hands[0].palm_position
    assert np.isnan(palm[0]) and palm[1:].tolist() == [float(np.float32(0.2)), 0.0]  # the tracker's precision
    assert np.isnan(recording.info.frame_rate)
