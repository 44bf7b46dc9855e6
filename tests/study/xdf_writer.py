"""A test fixture standing in for LabRecorder: records LSL streams from pylsl inlets into an XDF file.

The labrecorder wheel records on Linux, but stopping it drops what it has not pulled yet (up to its
pull interval) and nothing tells when it has, so a test could only sleep. This recorder says when a
stream has delivered a given number of samples (``wait_for``), then writes the XDF chunks
(FileHeader, StreamHeader, Samples, ClockOffset, StreamFooter) as the XDF specification lays them out.
"""

from __future__ import annotations

import struct
import threading
from pathlib import Path

import pylsl

from tests.waiting import WAIT_S, joined

FILE_HEADER, STREAM_HEADER, SAMPLES, CLOCK_OFFSET, STREAM_FOOTER = 1, 2, 3, 4, 6
HANG_S = 300.0
"""A bound against a hang only: each wait below ends as soon as LSL answers, on a busy machine too."""
VALUE_FORMATS = {pylsl.cf_float32: "f", pylsl.cf_double64: "d", pylsl.cf_int32: "i", pylsl.cf_int16: "h",
                 pylsl.cf_int8: "b"}


def _varlen(n: int) -> bytes:
    """XDF's variable-length integer: a byte saying how many bytes follow (1, 4 or 8), then them."""
    if n < 256:
        return struct.pack("<BB", 1, n)
    return struct.pack("<BI", 4, n) if n < 2 ** 32 else struct.pack("<BQ", 8, n)


def _chunk(tag: int, content: bytes, stream_id: int | None = None) -> bytes:
    head = struct.pack("<H", tag) + (b"" if stream_id is None else struct.pack("<I", stream_id))
    return _varlen(len(head) + len(content)) + head + content


class _Stream:
    def __init__(self, stream_id: int, info: pylsl.StreamInfo):
        self.id = stream_id
        self.inlet = pylsl.StreamInlet(info, max_buflen=600, recover=False)
        self.inlet.open_stream(timeout=HANG_S)  # subscribed: every sample pushed from now on arrives
        self.info = self.inlet.info()
        self.format = self.info.channel_format()
        self.samples: list[list] = []
        self.stamps: list[float] = []
        self.offsets = [self._offset()]

    def _offset(self) -> tuple[float, float]:
        offset = self.inlet.time_correction(timeout=HANG_S)
        return pylsl.local_clock() - offset, offset

    def encode(self) -> bytes:
        out = [_varlen(len(self.samples))]
        for stamp, values in zip(self.stamps, self.samples):
            out.append(struct.pack("<Bd", 8, stamp))
            if self.format == pylsl.cf_string:
                out.extend(_varlen(len(v.encode())) + v.encode() for v in values)
            else:
                out.append(struct.pack(f"<{len(values)}{VALUE_FORMATS[self.format]}", *values))
        return b"".join(out)


class XdfRecorder:
    """Records the streams with the given source ids (waiting until each is found and subscribed)."""

    def __init__(self, path: Path, source_ids: list[str]):
        self.path = path
        self.streams = [_Stream(i + 1, pylsl.resolve_byprop("source_id", s, minimum=1, timeout=HANG_S)[0])
                        for i, s in enumerate(source_ids)]
        self._arrived = threading.Condition()
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._pull, args=(s,), daemon=True) for s in self.streams]
        for thread in self._threads:
            thread.start()

    def _pull(self, stream: _Stream) -> None:
        while not self._stop.is_set():
            samples, stamps = stream.inlet.pull_chunk(timeout=0.2)
            if samples:
                with self._arrived:
                    stream.samples.extend(samples)
                    stream.stamps.extend(stamps)
                    self._arrived.notify_all()

    def wait_for(self, source_id: str, count: int) -> None:
        """Return once the stream ``source_id`` has delivered ``count`` samples."""
        stream = next(s for s in self.streams if s.info.source_id() == source_id)
        with self._arrived:
            assert self._arrived.wait_for(lambda: len(stream.samples) >= count, WAIT_S), \
                f"waited {WAIT_S:g} s for {count} samples of {source_id}; {len(stream.samples)} arrived"

    def close(self) -> None:
        """Stop pulling and write the XDF file."""
        self._stop.set()
        for thread in self._threads:
            joined(thread, "an LSL stream's reader")
        parts = [b"XDF:", _chunk(FILE_HEADER, b'<?xml version="1.0"?><info><version>1.0</version></info>')]
        for stream in self.streams:
            parts.append(_chunk(STREAM_HEADER, stream.info.as_xml().encode(), stream.id))
        for stream in self.streams:
            stream.offsets.append(stream._offset())
            parts.append(_chunk(SAMPLES, stream.encode(), stream.id))
            parts.extend(_chunk(CLOCK_OFFSET, struct.pack("<dd", *offset), stream.id) for offset in stream.offsets)
            footer = (f'<?xml version="1.0"?><info><first_timestamp>{stream.stamps[0]!r}</first_timestamp>'
                      f'<last_timestamp>{stream.stamps[-1]!r}</last_timestamp>'
                      f'<sample_count>{len(stream.samples)}</sample_count></info>')
            parts.append(_chunk(STREAM_FOOTER, footer.encode(), stream.id))
        self.path.write_bytes(b"".join(parts))
        for stream in self.streams:
            stream.inlet.close_stream()
