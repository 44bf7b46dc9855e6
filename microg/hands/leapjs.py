"""Import of LeapJS v2 recordings (JSON, plain or gzip; see data/leap-v2-recordings/README.md).

Each finger ("pointable") gives mcp, pip, dip and tip positions, i.e. the proximal, intermediate
and distal bones. There is no carpal position, so the metacarpal bases of the index to pinky
fingers stay NaN (unknown). The thumb is the exception: the Leap v2 skeleton models it with a
zero-length metacarpal, so its metacarpal base *is* its mcp position. Bone widths are the
finger's width, as in LeapJS. The palm orientation is built from ``palmNormal`` and ``direction``
with LeapC's convention (see ``units.palm_quaternion``), so recorded and live hands agree.
Frames keep their recorded timestamps: uneven spacing and missing frames are the data.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np

from microg.skeleton import N_BONES, N_DIGITS, Hand, HandFrame
from .recording import UNKNOWN, Recording, RecordingError, RecordingInfo
from .units import metres, palm_quaternion, seconds

FINGER_JOINTS = ("mcpPosition", "pipPosition", "dipPosition", "tipPosition")
"""The joints a LeapJS v2 finger gives, from knuckle to tip: joints 1..4 of a digit."""


def _load_json(path: Path) -> dict:
    try:
        with open(path, "rb") as stream:
            gzipped = stream.read(2) == b"\x1f\x8b"
        opener = gzip.open if gzipped else open
        with opener(path, "rt", encoding="utf-8") as stream:
            return json.load(stream)
    except (OSError, EOFError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RecordingError(f"{path}: not readable as LeapJS JSON: {error}") from None


def _vector(where: str, value, length: int = 3) -> np.ndarray:
    if value is None:
        return np.full(length, np.nan)
    if (not isinstance(value, list) or len(value) != length
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise RecordingError(f"{where} = {value!r}: must be {length} numbers")
    return np.asarray(value, dtype=np.float64)


def _number(where: str, value) -> float:
    if value is None:
        return np.nan
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise RecordingError(f"{where} = {value!r}: must be a number")
    return float(value)


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
    if not isinstance(track_id, int) or isinstance(track_id, bool):
        raise RecordingError(f"{where}.id = {track_id!r}: must be an integer hand id")
    return Hand(side, joints, widths, palm, orientation, track_id)


def _frame(where: str, frame: dict) -> HandFrame:
    if not isinstance(frame, dict):
        raise RecordingError(f"{where} = {str(frame)[:60]!r}: must be a frame object")
    timestamp = frame.get("timestamp")
    if not isinstance(timestamp, (int, float)) or isinstance(timestamp, bool) or not np.isfinite(timestamp):
        raise RecordingError(f"{where}.timestamp = {timestamp!r}: must be a number (microseconds)")
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
        return HandFrame(seconds(timestamp), tuple(hands))
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
    frames = tuple(_frame(f"{path}: frames[{i}]", frame) for i, frame in enumerate(document["frames"]))
    rates = [r for f in document["frames"] if isinstance(r := f.get("currentFrameRate"), (int, float))]
    try:
        frame_rate = float(metadata["frameRate"])
    except (KeyError, TypeError, ValueError):
        frame_rate = float(np.median(rates)) if rates else float("nan")
    device = (f"Leap Motion (LeapJS recording, protocol {metadata.get('protocolVersion', '?')}, "
              f"{metadata.get('generatedBy', 'unknown recorder')})")
    notes = " - ".join(str(metadata[k]) for k in ("title", "description") if metadata.get(k))
    info = RecordingInfo(source=f"leapjs:{path.name}", device=device, frame_rate=frame_rate,
                         start_time=UNKNOWN, notes=notes)
    return Recording(path, info, frames)
