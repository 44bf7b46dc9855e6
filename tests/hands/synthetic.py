"""Synthetic hands and frame streams for the hand-input tests: a flat right hand, palm down."""

from __future__ import annotations

import numpy as np

from microg.skeleton import Hand, HandFrame

RATE = 110.0
KNUCKLE_X = np.array([-0.045, -0.025, 0.0, 0.02, 0.038])
"""Hand-frame x of each digit's knuckle (thumb .. pinky), m."""
BONE_LENGTHS = np.array([[0.0, 0.042, 0.033, 0.021]] + [[0.06, 0.044, 0.027, 0.018]] * 4)
WIDTHS = np.repeat(np.array([0.0197, 0.0188, 0.0185, 0.0176, 0.0156])[:, None], 4, axis=1)


def flat_hand(palm, side: str = "right", track_id: int = 7) -> Hand:
    """A flat hand with every joint known: fingers point along -z from knuckles 3 cm ahead of the palm."""
    palm = np.asarray(palm, dtype=float)
    joints = np.empty((5, 5, 3))
    for d in range(5):
        base = palm + (KNUCKLE_X[d], 0.0, 0.03 if d else -0.01)
        joints[d, 0] = base
        for b in range(4):
            joints[d, b + 1] = joints[d, b] + (0.0, 0.0, -BONE_LENGTHS[d, b])
    return Hand(side, joints, WIDTHS, palm, np.array([1.0, 0.0, 0.0, 0.0]), track_id)


def with_nan(hand: Hand, palm: bool = False, joint: tuple[int, int] | None = None) -> Hand:
    joints, palm_position = hand.joints.copy(), hand.palm_position.copy()
    if palm:
        palm_position[:] = np.nan
    if joint is not None:
        joints[joint] = np.nan
    return Hand(hand.side, joints, hand.widths, palm_position, hand.palm_orientation, hand.track_id)


def with_joints(hand: Hand, joints: np.ndarray) -> Hand:
    return Hand(hand.side, joints, hand.widths, hand.palm_position, hand.palm_orientation, hand.track_id)


def sweep(start, velocity, n: int, rate: float = RATE, t0: float = 0.0, track_id: int = 7) -> list[HandFrame]:
    """Frames of a flat right hand moving from ``start`` at constant ``velocity`` (m/s)."""
    start, velocity = np.asarray(start, dtype=float), np.asarray(velocity, dtype=float)
    return [HandFrame(t0 + i / rate, (flat_hand(start + velocity * i / rate, track_id=track_id),))
            for i in range(n)]


class ListSource:
    """A HandSource over a list of frames; remembers the observations it was shown."""

    def __init__(self, frames, description: str = "list"):
        self.frames = list(frames)
        self.description = description
        self.observations = []
        self.closed = False

    def next_frame(self, observation=None):
        self.observations.append(observation)
        return self.frames.pop(0) if self.frames else None

    def close(self):
        self.closed = True


class Guarded:
    """``source`` through hand tracking (``microg.hands.Tracking``) with a window of one frame (no
    smoothing): the frames the tracking guard admits, one per ``next_frame``, for tests of the guard."""

    def __init__(self, source, config=None):
        from microg.hands import GuardConfig, Tracking

        self.tracking = Tracking(source, config or GuardConfig(), window=1)
        self.source, self.guard = source, self.tracking.guard

    def next_frame(self, observation=None):
        frame = self.tracking.next_frame(observation)
        return None if frame is None else frame.admitted


def run_guard(frames, config=None):
    """The frames the tracking guard passes, and its final counts."""
    guarded = Guarded(ListSource(frames), config)
    out = []
    while (frame := guarded.next_frame()) is not None:
        out.append(frame)
    return out, guarded.guard.counts
