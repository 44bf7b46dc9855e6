"""Placing a recording in the workspace: a rigid transform applied to every hand it replays.

A recording is in its own tracker's coordinates, which rarely line up with a protocol's object.
``Alignment`` moves and turns every hand of a frame (joints, palm position and orientation) by one
rigid transform, x' = R x + offset. It is given (``--align X,Y,Z[,RX,RY,RZ]``: metres, then degrees
about x, y and z, applied in that order) or found from the recording and the task:

- ``start``: the recording's first palm position goes to where the task's hand starts;
- ``grasp``: where the hand is most closed (thumb and index tips nearest each other), the point
  between those tips goes to the object's start, so a real grab closes on the object.

Both found alignments only translate (a tracker's frame is y up, like the workspace). The session
logs the transform with each run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from microg.skeleton import Hand, HandFrame, at_tracker_precision
from microg.sim.rotation import quat_from_euler_deg, quat_multiply, quat_to_matrix

FOUND = ("start", "grasp")
THUMB_TIP, INDEX_TIP = (0, 4), (1, 4)


class AlignmentError(ValueError):
    """An ``--align`` that cannot be used; the message says what is expected."""


@dataclass(frozen=True)
class Alignment:
    """x' = R x + offset, R from the unit quaternion ``rotation`` (w, x, y, z)."""

    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    how: str = "given"
    """``given``, ``start`` or ``grasp``: for the log."""

    def hand(self, hand: Hand) -> Hand:
        """The hand placed, at the tracker's precision (``microg.skeleton.TRACKER_FLOAT``) as it came."""
        turn = quat_to_matrix(np.asarray(self.rotation))
        offset = np.asarray(self.offset)
        placed = (hand.joints @ turn.T + offset, hand.widths, turn @ hand.palm_position + offset,
                  quat_multiply(np.asarray(self.rotation), hand.palm_orientation))
        return Hand(hand.side, *map(at_tracker_precision, placed), hand.track_id)

    def frame(self, frame: HandFrame) -> HandFrame:
        return HandFrame(frame.timestamp, tuple(self.hand(h) for h in frame.hands))

    def as_dict(self) -> dict:
        return {"how": self.how, "offset_m": list(self.offset), "rotation_wxyz": list(self.rotation)}


def parse_alignment(text: str) -> str | Alignment:
    """``start``, ``grasp`` (found per task) or a given ``X,Y,Z[,RX,RY,RZ]``."""
    if text in FOUND:
        return text
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in (3, 6) or not all(math.isfinite(v) for v in values):
        raise AlignmentError(f"--align {text!r}: give start, grasp, or X,Y,Z (m) with optional RX,RY,RZ (degrees)")
    rotation = quat_from_euler_deg(*values[3:]) if len(values) == 6 else np.array([1.0, 0.0, 0.0, 0.0])
    return Alignment(tuple(values[:3]), tuple(float(q) for q in rotation))


def find_alignment(how: str, frames: list[HandFrame], hand_start, object_start) -> Alignment:
    """The translation ``how`` (``start`` or ``grasp``) asks for, from the frames to replay."""
    hands = [(f, h) for f in frames for h in f.hands if np.isfinite(h.palm_position).all()]
    if not hands:
        raise AlignmentError("--align: the recording has no tracked hand to align")
    if how == "start":
        return Alignment(tuple(np.asarray(hand_start) - hands[0][1].palm_position), how=how)
    pinches = [(np.linalg.norm(h.joints[THUMB_TIP] - h.joints[INDEX_TIP]), h) for _, h in hands
               if np.isfinite(h.joints[THUMB_TIP]).all() and np.isfinite(h.joints[INDEX_TIP]).all()]
    if not pinches:
        raise AlignmentError("--align grasp: the recording never tracks both the thumb tip and the index tip")
    _, closed = min(pinches, key=lambda pair: pair[0])
    between = 0.5 * (closed.joints[THUMB_TIP] + closed.joints[INDEX_TIP])
    return Alignment(tuple(np.asarray(object_start) - between), how=how)


class Aligned:
    """A hand source whose frames come through ``alignment``."""

    def __init__(self, source, alignment: Alignment):
        self.source, self.alignment = source, alignment
        self.description = source.description

    def next_frame(self, observation=None) -> HandFrame | None:
        frame = self.source.next_frame(observation)
        return None if frame is None else self.alignment.frame(frame)

    def close(self) -> None:
        self.source.close()
