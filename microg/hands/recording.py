"""The project's recording format for hand frames, the recorder, and replay.

A recording is an Apache Arrow IPC *stream* (``.arrows``): a schema message carrying the metadata,
then record batches of frames, then an end-of-stream marker written on close. The stream format
has no footer, so a file is valid at every batch boundary: the writer appends a batch (a tenth
of a second of frames by default) and hands it to the operating system at once, and a crash loses
at most the batch in progress. A file without its end marker was cut off; the reader returns
every complete frame and says so. Buffers are zstd-compressed by Arrow itself, and any Arrow
reader (pyarrow, pandas, R, Julia, ...) can open the file.

One row is one frame: ``timestamp`` (s), one nullable struct column per side (``left``, ``right``)
holding ``track_id``, ``palm_position`` (3), ``palm_orientation`` (4, w x y z), ``joints`` (75 =
5 digits x 5 joints x 3, digit-major) and ``widths`` (20), in metres, float64. A null struct is a
hand the tracker did not see; NaN inside it is a value the tracker marked unknown. float64 throughout
keeps a record-replay round trip exact.

A recording loaded for use (``load_recording``: replay, import, the filter report) has its clock
counted from its first frame, once, as it is read: a recorder whose clock reads far from zero (Unix
seconds, as a headset's page stamps frames: 1.8e9 s) leaves each time only a few significant digits
below the millisecond, and the physics works on differences of such times.
"""

from __future__ import annotations

import datetime
import gzip
import time
import warnings
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pyarrow as pa

from microg import __version__

from microg.skeleton import N_BONES, N_DIGITS, SIDES, Hand, HandFrame
from .source import HandSource

FORMAT = "microg-hands"
FORMAT_VERSION = "1"
SUFFIX = ".arrows"
UNITS = "length m, time s, palm_orientation unit quaternion (w, x, y, z) from hand to tracker frame"
COORDINATES = "tracker frame: right-handed, y up, origin at the device, +z toward the user"
UNKNOWN = "unknown"
END_OF_STREAM = b"\xff\xff\xff\xff\x00\x00\x00\x00"
STREAM_START = b"\xff\xff\xff\xff"
BATCH_FRAMES = 11
"""Frames per appended batch: about 0.1 s at the Leap's 110 Hz, the most a crash can lose."""

_JOINT_VALUES = N_DIGITS * (N_BONES + 1) * 3
_WIDTH_VALUES = N_DIGITS * N_BONES
_HAND_TYPE = pa.struct([
    ("track_id", pa.int64()),
    ("palm_position", pa.list_(pa.float64(), 3)),
    ("palm_orientation", pa.list_(pa.float64(), 4)),
    ("joints", pa.list_(pa.float64(), _JOINT_VALUES)),
    ("widths", pa.list_(pa.float64(), _WIDTH_VALUES)),
])
SCHEMA = pa.schema([("timestamp", pa.float64())] + [(side, _HAND_TYPE) for side in SIDES])


class RecordingError(ValueError):
    """A file that is not a readable hand recording; the message names the file and what is wrong."""


@dataclass(frozen=True)
class RecordingInfo:
    """What a recording says about itself, stored in its header."""

    source: str
    """What produced the frames, e.g. ``leap`` or ``leapjs:grab.json.gz``."""
    device: str
    """The tracking device as the source named it."""
    frame_rate: float
    """Nominal frames per second (Hz) the device reported."""
    start_time: str
    """Wall-clock time of the first frame, ISO 8601 in UTC; ``unknown`` when the source did not say."""
    units: str = UNITS
    coordinates: str = COORDINATES
    notes: str = ""
    software: str = f"microg {__version__}"

    def to_metadata(self) -> dict[bytes, bytes]:
        entries = {f.name: str(getattr(self, f.name)) for f in fields(self)}
        entries |= {"format": FORMAT, "format_version": FORMAT_VERSION}
        return {k.encode(): v.encode() for k, v in entries.items()}

    @classmethod
    def from_metadata(cls, metadata: dict[bytes, bytes] | None, where: str) -> RecordingInfo:
        entries = {k.decode(): v.decode() for k, v in (metadata or {}).items()}
        if entries.get("format") != FORMAT:
            raise RecordingError(f"{where}: an Arrow stream but not a hand recording "
                                 f"(metadata format = {entries.get('format')!r}, expected {FORMAT!r})")
        if entries.get("format_version") != FORMAT_VERSION:
            raise RecordingError(f"{where}: format_version = {entries.get('format_version')!r}; "
                                 f"this microg reads version {FORMAT_VERSION}")
        values = {f.name: entries[f.name] for f in fields(cls) if f.name in entries}
        try:
            values["frame_rate"] = float(values["frame_rate"])
        except (KeyError, ValueError):
            raise RecordingError(f"{where}: metadata frame_rate = {entries.get('frame_rate')!r}: "
                                 "must be a number (Hz)") from None
        return cls(**values)


@dataclass(frozen=True)
class Recording:
    """The frames of a recording file, and whether the file was complete."""

    path: Path
    info: RecordingInfo
    frames: tuple[HandFrame, ...]
    truncated: bool = False
    """True when the file ends before its end marker (a crash or a cut mid-write); ``frames`` holds
    every frame that was completely written."""
    problem: str = ""
    """Why the tail could not be read, when ``truncated``."""


def utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")


_HAND_ARRAYS = (("palm_position", (3,)), ("palm_orientation", (4,)), ("joints", (N_DIGITS, N_BONES + 1, 3)),
                ("widths", (N_DIGITS, N_BONES)))


def _hand_column(hands: list[Hand | None]) -> pa.StructArray:
    """One side's struct column; zeros under the null mask where the hand is absent."""
    ids = pa.array([0 if h is None else h.track_id for h in hands], type=pa.int64())
    children = [ids]
    for name, shape in _HAND_ARRAYS:
        size = int(np.prod(shape))
        values = np.zeros((len(hands), size))
        for i, hand in enumerate(hands):
            if hand is not None:
                values[i] = np.ravel(getattr(hand, name))
        children.append(pa.FixedSizeListArray.from_arrays(pa.array(values.ravel()), size))
    absent = pa.array([h is None for h in hands])
    return pa.StructArray.from_arrays(children, fields=list(_HAND_TYPE), mask=absent)


def _frames_to_batch(frames: list[HandFrame]) -> pa.RecordBatch:
    columns = [pa.array([f.timestamp for f in frames], type=pa.float64())]
    columns += [_hand_column([f.hand(side) for f in frames]) for side in SIDES]
    return pa.record_batch(columns, schema=SCHEMA)


def _batch_to_frames(batch: pa.RecordBatch, first: int) -> list[HandFrame]:
    """The frames of one batch, the recording's frames ``first`` on; ValueError names the first
    frame that no hand can make (what ``Hand`` refuses: a 1 m wide finger would fling objects)."""
    n = batch.num_rows
    timestamps = batch.column("timestamp").to_numpy()
    sides = {}
    for side in SIDES:
        column = batch.column(side)
        arrays = [column.field(name).flatten().to_numpy().reshape(n, *shape) for name, shape in _HAND_ARRAYS]
        sides[side] = (column.is_valid().to_numpy(zero_copy_only=False), column.field("track_id").to_numpy(),
                       *arrays)
    frames = []
    for i in range(n):
        try:
            with np.errstate(over="ignore"):  # absurd coordinates are refused just below, by name
                hands = tuple(Hand(side, joints[i], widths[i], palm[i], orientation[i], int(ids[i]))
                              for side, (present, ids, palm, orientation, joints, widths) in sides.items()
                              if present[i])
            frames.append(HandFrame(float(timestamps[i]), hands))
        except ValueError as error:
            raise ValueError(f"frame {first + i} (timestamp = {timestamps[i]:g} s): {error}") from None
    return frames


class RecordingWriter:
    """Appends frames to a new recording file, one batch at a time (see module docstring).

    Use as a context manager; ``close`` writes the end marker that tells a reader the file is whole.
    """

    def __init__(self, path: str | Path, info: RecordingInfo, *, batch_frames: int = BATCH_FRAMES,
                 overwrite: bool = False):
        self.path = Path(path)
        if self.path.exists() and not overwrite:
            raise FileExistsError(f"{self.path}: already exists; choose another name or allow overwriting")
        self.info = info
        self.batch_frames = batch_frames
        self.frames_written = 0
        self._pending: list[HandFrame] = []
        self._sink = pa.OSFile(str(self.path), "wb")
        options = pa.ipc.IpcWriteOptions(compression="zstd")
        self._writer = pa.ipc.new_stream(self._sink, SCHEMA.with_metadata(info.to_metadata()), options=options)

    def write(self, frame: HandFrame) -> None:
        self._pending.append(frame)
        if len(self._pending) >= self.batch_frames:
            self.flush()

    def flush(self) -> None:
        """Append the pending frames as one batch and hand it to the operating system."""
        if self._pending:
            self._writer.write_batch(_frames_to_batch(self._pending))
            self._sink.flush()
            self.frames_written += len(self._pending)
            self._pending = []

    def close(self) -> None:
        if self._sink.closed:
            return
        self.flush()
        self._writer.close()
        self._sink.close()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write_recording(path: str | Path, info: RecordingInfo, frames, *, overwrite: bool = False) -> int:
    """Write ``frames`` to a new recording; returns how many were written."""
    with RecordingWriter(path, info, overwrite=overwrite) as writer:
        for frame in frames:
            writer.write(frame)
    return writer.frames_written


def read_recording(path: str | Path) -> Recording:
    """Read a recording in the project's format, keeping every complete frame of a cut-off file."""
    path = Path(path)
    try:
        source = pa.memory_map(str(path))
    except OSError as error:
        raise RecordingError(f"{path}: cannot open: {error}") from None
    with source:
        try:
            reader = pa.ipc.open_stream(source)
            schema = reader.schema
        except (pa.ArrowInvalid, OSError) as error:
            raise RecordingError(f"{path}: not a readable hand recording (its header is missing or "
                                 f"cut off: {error})") from None
        info = RecordingInfo.from_metadata(schema.metadata, str(path))
        if not schema.remove_metadata().equals(SCHEMA):
            raise RecordingError(f"{path}: columns {schema.names} do not match the hand recording schema "
                                 f"{SCHEMA.names} of format version {FORMAT_VERSION}")
        frames: list[HandFrame] = []
        problem = ""
        try:
            for batch in reader:
                try:
                    frames.extend(_batch_to_frames(batch, len(frames)))
                except ValueError as error:
                    raise RecordingError(f"{path}: {error}") from None
        except (pa.ArrowInvalid, OSError) as error:
            problem = f"the last batch is incomplete ({error})"
        size = source.size()
        source.seek(max(0, size - len(END_OF_STREAM)))
        if not problem and source.read() != END_OF_STREAM:
            problem = "the file has no end marker (the recorder did not close it)"
    return Recording(path, info, tuple(frames), truncated=bool(problem), problem=problem)


def load_recording(path: str | Path) -> Recording:
    """Read a recording of either kind, told apart by content: the project's format or LeapJS v2 JSON,
    with its clock counted from its first frame (module docstring; LeapJS's is rebased in microseconds)."""
    from .leapjs import read_leapjs

    path = Path(path)
    try:
        with open(path, "rb") as stream:
            head = stream.read(4)
    except OSError as error:
        raise RecordingError(f"{path}: cannot open: {error}") from None
    if head == STREAM_START:
        return from_first_frame(read_recording(path))
    if head[:2] == b"\x1f\x8b":
        try:
            with gzip.open(path, "rb") as stream:
                head = stream.read(64).lstrip()[:1]
        except (OSError, EOFError) as error:
            raise RecordingError(f"{path}: a gzip file that does not unpack: {error}") from None
    if head.lstrip()[:1] == b"{":
        return read_leapjs(path)
    raise RecordingError(f"{path}: neither a microg hand recording ({SUFFIX}) nor LeapJS v2 JSON "
                         f"(plain or gzip); the file starts with {head!r}")


def from_first_frame(recording: Recording) -> Recording:
    """``recording`` with its frames' times counted from the first frame's (exact: two times within a
    factor of two of each other subtract without rounding)."""
    if not recording.frames or recording.frames[0].timestamp == 0.0:
        return recording
    origin = recording.frames[0].timestamp
    return replace(recording, frames=tuple(HandFrame.made(f.timestamp - origin, f.hands) for f in recording.frames))


class ReplaySource:
    """Plays recorded frames as a ``HandSource``: as fast as asked (default) or paced in real time.

    Paced replay waits until each frame's time since the first frame has passed on ``clock``.
    """

    def __init__(self, frames, description: str, *, realtime: bool = False,
                 clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep):
        self.frames = tuple(frames)
        self.description = description
        self.realtime = realtime
        self._clock, self._sleep = clock, sleep
        self._next = 0
        self._started_at: float | None = None

    @classmethod
    def from_file(cls, path: str | Path, *, realtime: bool = False) -> ReplaySource:
        recording = load_recording(path)
        if recording.truncated:
            warnings.warn(f"{recording.path}: recording was cut off ({recording.problem}); "
                          f"replaying its {len(recording.frames)} complete frames", stacklevel=2)
        return cls(recording.frames, f"replay:{recording.path}", realtime=realtime)

    def next_frame(self, observation=None) -> HandFrame | None:
        if self._next >= len(self.frames):
            return None
        frame = self.frames[self._next]
        self._next += 1
        if self.realtime:
            if self._started_at is None:
                self._started_at = self._clock()
            due = self._started_at + (frame.timestamp - self.frames[0].timestamp)
            if (wait := due - self._clock()) > 0:
                self._sleep(wait)
        return frame

    def close(self) -> None:
        self._next = len(self.frames)


@dataclass(frozen=True)
class RecordSummary:
    path: Path
    frames: int
    seconds: float
    """Time from the first to the last recorded frame, on the source's clock."""


def record(source: HandSource, path: str | Path, info: RecordingInfo, *, duration: float | None = None,
           max_frames: int | None = None, overwrite: bool = False, progress: bool = True) -> RecordSummary:
    """Record ``source`` into a new file until it ends, ``duration`` seconds or ``max_frames`` frames
    have passed, or Ctrl-C; the file is closed properly in every case. ``info.start_time`` is set to
    the wall-clock time of the first frame when it is ``unknown``."""
    from tqdm import tqdm

    first = source.next_frame()
    if first is None:
        raise RecordingError(f"{source.description}: delivered no frame; nothing recorded to {path}")
    if info.start_time == UNKNOWN:
        info = replace(info, start_time=utc_now())
    frame, last, count = first, first, 0
    with RecordingWriter(path, info, overwrite=overwrite) as writer, \
            tqdm(desc=f"recording {Path(path).name}", unit=" frames", disable=not progress) as bar:
        try:
            while frame is not None:
                writer.write(frame)
                last, count = frame, count + 1
                bar.update()
                if max_frames is not None and count >= max_frames:
                    break
                if duration is not None and frame.timestamp - first.timestamp >= duration:
                    break
                frame = source.next_frame()
        except KeyboardInterrupt:
            pass
    return RecordSummary(Path(path), writer.frames_written, last.timestamp - first.timestamp)
