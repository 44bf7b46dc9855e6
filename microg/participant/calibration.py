"""Measure the simulated participant's constants on real Leap Motion recordings (LeapJS v2 JSON).

The skeleton (bone lengths, widths, knuckle positions in the hand frame), the frame-interval
distribution and the tracking noise of a still hand are taken from the recordings of
``leap-v2-recordings`` (see its README). This module recomputes them, so the constants in
``skeleton``, ``timing`` and ``noise`` can be checked against the data they came from:

    python -m microg.participant.calibration /path/to/leap-v2-recordings

The hand frame is LeapC's palm basis {normal x direction, -normal, -direction}: for a right hand
x points from the thumb side to the little finger, y out of the back of the hand, z to the wrist.
"""

from __future__ import annotations

import gzip
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import signal

RECORDINGS = ("grab.json.gz", "pinch.json.gz", "HandSplay-110fps.json.gz", "wave.json.gz")
STILL_RECORDING = "pinch.json.gz"
"""The recording whose palm and resting fingers (ring, little) move least: noise is measured there."""
STILL_DIGITS = (3, 4)
NOISE_BAND_HZ = 5.0
"""Tracking noise is the part of a still hand's motion above this frequency (voluntary drift is below)."""


@dataclass(frozen=True)
class RecordedHand:
    """One right hand through a recording, SI units, hand-frame basis per frame."""

    name: str
    time: np.ndarray
    """(T,) s from the first frame."""
    palm: np.ndarray
    """(T, 3) m."""
    basis: np.ndarray
    """(T, 3, 3) rows: hand x, y, z axes in the device frame."""
    joints: np.ndarray
    """(T, 5, 4, 3) m: knuckle (mcp; the thumb's carpometacarpal joint), pip, dip, tip."""
    widths: np.ndarray
    """(T, 5) m."""


def load_recording(path: Path) -> RecordedHand:
    """Read a LeapJS v2 recording with one right hand in every frame."""
    with gzip.open(path, "rt") as stream:
        frames = json.load(stream)["frames"]
    time, palm, basis, joints, widths = [], [], [], [], []
    for i, frame in enumerate(frames):
        if len(frame["hands"]) != 1:
            raise ValueError(f"{path}: frames[{i}] has {len(frame['hands'])} hands; calibration needs exactly one")
        hand = frame["hands"][0]
        normal, direction = np.array(hand["normal" if "normal" in hand else "palmNormal"]), np.array(hand["direction"])
        basis.append(np.stack([np.cross(normal, direction), -normal, -direction]))
        palm.append(hand["palmPosition"])
        time.append(frame["timestamp"])
        digits = sorted((p for p in frame["pointables"] if p["handId"] == hand["id"]), key=lambda p: p["type"])
        joints.append([[p[k] for k in ("mcpPosition", "pipPosition", "dipPosition", "tipPosition")] for p in digits])
        widths.append([p["width"] for p in digits])
    time = (np.array(time, dtype=np.float64) - time[0]) * 1e-6
    return RecordedHand(path.name, time, np.array(palm) * 1e-3, np.array(basis), np.array(joints) * 1e-3,
                     np.array(widths) * 1e-3)


def load_all(folder: Path) -> list[RecordedHand]:
    missing = [name for name in RECORDINGS if not (folder / name).exists()]
    if missing:
        raise FileNotFoundError(f"{folder}: missing recordings {missing}")
    return [load_recording(folder / name) for name in RECORDINGS]


def measure_skeleton(recordings: list[RecordedHand]) -> dict[str, np.ndarray]:
    """Medians over every frame: phalanx lengths (5, 3), widths (5,), knuckles in the hand frame (5, 3)."""
    joints = np.concatenate([r.joints for r in recordings])
    palm = np.concatenate([r.palm for r in recordings])
    basis = np.concatenate([r.basis for r in recordings])
    lengths = np.linalg.norm(np.diff(joints, axis=2), axis=-1)
    knuckles = np.einsum("tij,tdj->tdi", basis, joints[:, :, 0] - palm[:, None])
    return {"lengths": np.median(lengths, axis=0), "widths": np.median(np.concatenate([r.widths for r in recordings]), axis=0),
            "knuckles": np.median(knuckles, axis=0)}


def measure_frame_intervals(recordings: list[RecordedHand]) -> dict[str, float]:
    """Intervals as k whole periods plus jitter: the period, the jitter SD, P(k = 2), P(k = 3)."""
    intervals = np.concatenate([np.diff(r.time) for r in recordings])
    period = float(np.median(intervals))
    periods = np.rint(intervals / period).astype(int)
    single = intervals[periods == 1]
    return {"period": float(np.median(single)), "jitter_sd": float(np.std(single)),
            "p_two": float(np.mean(periods == 2)), "p_three": float(np.mean(periods == 3)),
            "count": len(intervals), "max": float(intervals.max())}


def _band_rms(values: np.ndarray, time: np.ndarray, cutoff: float) -> np.ndarray:
    """RMS of the part of ``values`` (T, ...) above ``cutoff`` Hz, on a uniform resampling."""
    period = float(np.median(np.diff(time)))
    uniform = np.arange(0.0, time[-1], period)
    flat = values.reshape(len(time), -1)
    resampled = np.stack([np.interp(uniform, time, column) for column in flat.T], axis=1)
    b, a = signal.butter(4, cutoff, "highpass", fs=1.0 / period)
    high = signal.filtfilt(b, a, resampled, axis=0)[10:-10]
    return np.sqrt(np.mean(high ** 2, axis=0)).reshape(values.shape[1:])


def measure_still_noise(recording: RecordedHand) -> dict[str, float]:
    """Tracking noise of a still hand above ``NOISE_BAND_HZ``: palm position (m, per axis),
    palm rotation (rad, per axis) and digit flexion (rad) from the resting fingers' tips."""
    palm = _band_rms(recording.palm, recording.time, NOISE_BAND_HZ)
    rotation = _band_rms(recording.basis, recording.time, NOISE_BAND_HZ)
    local = np.einsum("tij,tdj->tdi", recording.basis, recording.joints[:, :, 3] - recording.joints[:, :, 0])
    reach = np.linalg.norm(local, axis=-1).mean(axis=0)
    tips = _band_rms(local[:, list(STILL_DIGITS)], recording.time, NOISE_BAND_HZ)
    flexion = np.linalg.norm(tips, axis=-1) / reach[list(STILL_DIGITS)]
    return {"palm_position": float(np.sqrt(np.mean(palm ** 2))),
            "palm_rotation": float(np.sqrt(np.mean(rotation ** 2))),
            "flexion": float(np.sqrt(np.mean(flexion ** 2) / 2))}


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        raise SystemExit("usage: python -m microg.participant.calibration FOLDER_WITH_LEAP_V2_RECORDINGS")
    folder = Path(argv[0])
    recordings = load_all(folder)
    np.set_printoptions(precision=4, suppress=True)
    skeleton = measure_skeleton(recordings)
    print("phalanx lengths (mm; proximal, intermediate, distal; thumb: metacarpal, proximal, distal):")
    print(skeleton["lengths"] * 1e3)
    print("widths (mm):", skeleton["widths"] * 1e3)
    print("knuckles in the hand frame (mm):")
    print(skeleton["knuckles"] * 1e3)
    timing = measure_frame_intervals(recordings)
    print(f"frame intervals: period {timing['period'] * 1e3:.3f} ms, jitter SD {timing['jitter_sd'] * 1e3:.3f} ms, "
          f"P(one missing) {timing['p_two']:.4f}, P(two missing) {timing['p_three']:.4f} "
          f"over {timing['count']} intervals (longest {timing['max'] * 1e3:.1f} ms)")
    still = measure_still_noise(next(r for r in recordings if r.name == STILL_RECORDING))
    print(f"still hand above {NOISE_BAND_HZ:g} Hz ({STILL_RECORDING}): palm position {still['palm_position'] * 1e6:.1f} um, "
          f"palm rotation {still['palm_rotation'] * 1e3:.3f} mrad, flexion {still['flexion'] * 1e3:.3f} mrad (RMS per axis)")


if __name__ == "__main__":
    main()
