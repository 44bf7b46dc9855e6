"""Import of LeapJS v2 recordings (JSON, plain or gzip; see data/leap-v2-recordings/README.md).

Each finger ("pointable") gives mcp, pip, dip and tip positions, i.e. the proximal, intermediate
and distal bones. There is no carpal position, so the metacarpal bases of the index to pinky
fingers stay NaN (unknown). The thumb is the exception: the Leap v2 skeleton models it with a
zero-length metacarpal, so its metacarpal base *is* its mcp position. Bone widths are the
finger's width, as in LeapJS. The palm orientation is built from ``palmNormal`` and ``direction``
with LeapC's convention (see ``units.palm_quaternion``), so recorded and live hands agree.
Frames keep their recorded spacing (uneven spacing and missing frames are the data), on a clock
that starts at the first frame: the recorder's own clock may read far from zero (microseconds
since the epoch: a double holds such a time in seconds only to half a microsecond), so its
microseconds are rebased before they become seconds, exactly for whole microseconds.

A file is read whole, within a bound: at most ``MAX_JSON_BYTES`` of JSON, and a gzip file may
inflate to at most ``INFLATE_RATIO`` times its own size (a 3 MB file that inflates to 4 GiB is
refused before it fills the memory). ``MICROG_JSON_LIMIT=BYTES`` in the environment sets another
bound (in bytes of JSON) for an unusual file.
"""

from __future__ import annotations

import gzip
import json
import os
from pathlib import Path

import numpy as np

from microg.skeleton import N_BONES, N_DIGITS, Hand, HandFrame
from .recording import UNKNOWN, Recording, RecordingError, RecordingInfo
from .units import metres, palm_quaternion, seconds

FINGER_JOINTS = ("mcpPosition", "pipPosition", "dipPosition", "tipPosition")
"""The joints a LeapJS v2 finger gives, from knuckle to tip: joints 1..4 of a digit."""
MAX_JSON_BYTES = 2 << 30
"""The most JSON read from one file (2 GiB): a 40-minute recording at 110 Hz is about 250 MB."""
INFLATE_RATIO = 16
"""The most a gzip file may inflate, in times its own size; LeapJS recordings inflate about 4.5 times."""
LIMIT_VARIABLE = "MICROG_JSON_LIMIT"
"""The environment variable that sets another bound, in bytes of JSON, for every file."""
MAX_TRACK_ID = 2**63 - 1
"""Hand ids are stored as 64-bit integers."""


def json_limit(size: int, gzipped: bool) -> int:
    """How many bytes of JSON a file of ``size`` bytes may hold (see the module docstring)."""
    given = os.environ.get(LIMIT_VARIABLE)
    if given is not None:
        try:
            return int(given)
        except ValueError:
            raise RecordingError(f"{LIMIT_VARIABLE} = {given!r}: must be a whole number of bytes") from None
    return min(MAX_JSON_BYTES, INFLATE_RATIO * size) if gzipped else MAX_JSON_BYTES


def _load_json(path: Path) -> dict:
    try:
        with open(path, "rb") as raw:
            gzipped = raw.read(2) == b"\x1f\x8b"
            raw.seek(0)
            limit = json_limit(os.fstat(raw.fileno()).st_size, gzipped)
            with gzip.GzipFile(fileobj=raw) if gzipped else raw as stream:
                text = stream.read(limit + 1)
    except (OSError, EOFError) as error:
        raise RecordingError(f"{path}: not readable as LeapJS JSON: {error}") from None
    if len(text) > limit:
        given = LIMIT_VARIABLE in os.environ
        raise RecordingError(
            f"{path}: holds more than {limit} bytes of JSON (" + (f"{LIMIT_VARIABLE}" if given else
            f"{INFLATE_RATIO} times the gzip file" if gzipped and limit < MAX_JSON_BYTES else "2 GiB")
            + f"); refused unread. A genuine recording that large reads with {LIMIT_VARIABLE}=BYTES set higher")
    try:
        return json.loads(text)
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RecordingError(f"{path}: not readable as LeapJS JSON: {error}") from None
    except RecursionError:
        raise RecordingError(f"{path}: not a LeapJS recording: its JSON is nested too deeply (a recording "
                             "nests five levels)") from None


def _float(value) -> float | None:
    """A JSON number as a float (an integer too large for one is infinite, so unknown); None for anything else."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return None
    try:
        return float(value)
    except OverflowError:
        return np.inf


def _vector(where: str, value, length: int = 3) -> np.ndarray:
    if value is None:
        return np.full(length, np.nan)
    numbers = [_float(v) for v in value] if isinstance(value, list) else []
    if len(numbers) != length or None in numbers:
        raise RecordingError(f"{where} = {value!r}: must be {length} numbers")
    return np.asarray(numbers, dtype=np.float64)


def _number(where: str, value) -> float:
    if value is None:
        return np.nan
    number = _float(value)
    if number is None:
        raise RecordingError(f"{where} = {value!r}: must be a number")
    return number


def _hand(where: str, hand: dict, pointables: list[tuple[str, dict]]) -> Hand:
    side = hand.get("type")
    if side not in ("left", "right"):
        raise RecordingError(f"{where}.type = {side!r}: must be 'left' or 'right'")
    joints = np.full((N_DIGITS, N_BONES + 1, 3), np.nan)
    widths = np.full((N_DIGITS, N_BONES), np.nan)
    for finger_where, finger in pointables:
        digit = finger.get("type")
        if digit not in range(N_DIGITS) or isinstance(digit, bool):
            raise RecordingError(f"{finger_where}.type = {digit!r}: must be a finger type 0..4 (thumb..pinky)")
        for j, name in enumerate(FINGER_JOINTS, start=1):
            joints[digit, j] = metres(_vector(f"{finger_where}.{name}", finger.get(name)))
        widths[digit, 1:] = metres(_number(f"{finger_where}.width", finger.get("width")))
        if digit == 0:
            joints[0, 0] = joints[0, 1]
            widths[0, 0] = widths[0, 1]
    with np.errstate(invalid="ignore"):
        widths[~(widths > 0)] = np.nan
    palm = metres(_vector(f"{where}.palmPosition", hand.get("palmPosition")))
    orientation = palm_quaternion(_vector(f"{where}.palmNormal", hand.get("palmNormal")),
                                  _vector(f"{where}.direction", hand.get("direction")))
    track_id = hand.get("id")
    if not isinstance(track_id, int) or isinstance(track_id, bool) or abs(track_id) > MAX_TRACK_ID:
        raise RecordingError(f"{where}.id = {track_id!r}: must be an integer hand id (64-bit)")
    return Hand(side, joints, widths, palm, orientation, track_id)


def _timestamp(where: str, frame) -> int | float:
    """A frame's timestamp (microseconds, as recorded), checked."""
    if not isinstance(frame, dict):
        raise RecordingError(f"{where} = {str(frame)[:60]!r}: must be a frame object")
    timestamp = frame.get("timestamp")
    number = _float(timestamp)
    if number is None or not np.isfinite(number):
        raise RecordingError(f"{where}.timestamp = {timestamp!r}: must be a number (microseconds)")
    return timestamp


def _frame(where: str, frame: dict, origin: int | float) -> HandFrame:
    """One frame, its time in seconds since ``origin`` (the first frame's timestamp, microseconds)."""
    timestamp = _timestamp(where, frame)
    pointables, listed = frame.get("pointables") or [], frame.get("hands") or []
    for key, value in (("pointables", pointables), ("hands", listed)):
        if not isinstance(value, list):
            raise RecordingError(f"{where}.{key} = {str(value)[:60]!r}: must be a list")
    hands = []
    try:
        for h, hand in enumerate(listed):
            hand_where = f"{where}.hands[{h}]"
            if not isinstance(hand, dict):
                raise RecordingError(f"{hand_where} = {str(hand)[:60]!r}: must be a hand object")
            fingers = [(f"{where}.pointables[{p}]", pointable) for p, pointable in enumerate(pointables)
                       if isinstance(pointable, dict) and pointable.get("handId") == hand.get("id")
                       and not pointable.get("tool", False)]
            hands.append(_hand(hand_where, hand, fingers))
        return HandFrame(seconds(timestamp - origin), tuple(hands))
    except (ValueError, FloatingPointError) as error:
        if isinstance(error, RecordingError):
            raise
        raise RecordingError(f"{where}: {error}") from None


def read_leapjs(path: str | Path) -> Recording:
    """The frames of a LeapJS v2 recording, in SI units, as a ``Recording``."""
    path = Path(path)
    document = _load_json(path)
    if not isinstance(document, dict) or not isinstance(document.get("frames"), list):
        raise RecordingError(f"{path}: frames is missing or not a list; not a LeapJS v2 recording")
    metadata = document.get("metadata") or {}
    if not isinstance(metadata, dict):
        raise RecordingError(f"{path}: metadata = {str(metadata)[:60]!r}: must be an object")
    listed = document["frames"]
    origin = _timestamp(f"{path}: frames[0]", listed[0]) if listed else 0
    frames = tuple(_frame(f"{path}: frames[{i}]", frame, origin) for i, frame in enumerate(listed))
    rates = [r for f in listed if (r := _float(f.get("currentFrameRate"))) is not None and np.isfinite(r)]
    try:
        frame_rate = float(metadata["frameRate"])
    except (KeyError, TypeError, ValueError, OverflowError):
        frame_rate = float(np.median(rates)) if rates else float("nan")
    device = (f"Leap Motion (LeapJS recording, protocol {metadata.get('protocolVersion', '?')}, "
              f"{metadata.get('generatedBy', 'unknown recorder')})")
    notes = " - ".join(str(metadata[k]) for k in ("title", "description") if metadata.get(k))
    info = RecordingInfo(source=f"leapjs:{path.name}", device=device, frame_rate=frame_rate,
                         start_time=UNKNOWN, notes=notes)
    return Recording(path, info, frames)
