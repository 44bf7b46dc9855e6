"""Hand recordings, either format: any file gives a recording or a RecordingError naming it."""

from __future__ import annotations

import gzip
import json

import numpy as np
import pyarrow as pa
from hypothesis import HealthCheck, given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from microg.hands.recording import SCHEMA, RecordingError, RecordingInfo, load_recording
from microg.paths import LEAP_RECORDINGS

from .strategies import FUZZ, edits, values

FIXTURE = settings(FUZZ, suppress_health_check=[HealthCheck.function_scoped_fixture])
LEAPJS = json.loads(gzip.decompress((LEAP_RECORDINGS / "pinch.json.gz").read_bytes()))
"""A real LeapJS recording; the fuzz edits its first frames."""

numbers = st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([0.0, -1.0, 1e3, 1e300, 0.01])


def load(path):
    try:
        return load_recording(path)
    except RecordingError as error:
        assert str(path) in str(error), error


@st.composite
def hand_columns(draw, n: int):
    """One side's struct column of ``n`` rows with any values (and any rows missing)."""
    def floats(size):
        return pa.FixedSizeListArray.from_arrays(pa.array(draw(arrays(np.float64, n * size, elements=numbers))), size)

    fields = [pa.array(draw(st.lists(st.integers(-2**63, 2**63 - 1), min_size=n, max_size=n)), pa.int64()),
              floats(3), floats(4), floats(75), floats(20)]
    mask = pa.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    return pa.StructArray.from_arrays(fields, fields=list(SCHEMA.field("left").type), mask=mask)


@FIXTURE
@given(st.integers(1, 4).flatmap(lambda n: st.tuples(arrays(np.float64, n, elements=numbers), hand_columns(n),
                                                     hand_columns(n))),
       st.integers(0, 60))
def test_any_values_in_an_arrow_recording_give_frames_or_a_clear_error(tmp_path, columns, cut):
    path = tmp_path / "fuzzed.arrows"
    info = RecordingInfo(source="fuzz", device="none", frame_rate=110.0, start_time="unknown")
    batch = pa.record_batch([pa.array(columns[0]), columns[1], columns[2]], schema=SCHEMA)
    with pa.OSFile(str(path), "wb") as sink, pa.ipc.new_stream(sink, SCHEMA.with_metadata(info.to_metadata())) as out:
        out.write_batch(batch)
    if cut:
        path.write_bytes(path.read_bytes()[:-cut])  # a file cut off mid-write
    load(path)


@FIXTURE
@given(st.binary(max_size=300), st.booleans())
def test_any_bytes_as_a_recording_give_a_clear_error(tmp_path, content, gzipped):
    path = tmp_path / "bytes.json"
    path.write_bytes(gzip.compress(content) if gzipped else content)
    load(path)


@FIXTURE
@given(edits({"metadata": LEAPJS.get("metadata", {}), "frames": LEAPJS["frames"][:3]}) | values)
def test_any_edit_of_a_leapjs_recording_gives_frames_or_a_clear_error(tmp_path, document):
    path = tmp_path / "fuzzed.json"
    path.write_text(json.dumps(document, allow_nan=True))
    load(path)
