"""Scripted hands: hands of which only chosen phalanges are tracked, placed where a script says.

Useful to demonstrate or check one effect at a time (a fingertip tapping a cube, a thumb and an
index pinching it) without a tracker. Every other bone stays unknown (NaN), as a tracker would
mark it.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from .hand import BONES, DIGITS, N_BONES, N_DIGITS, Hand, HandFrame

PHALANX_LENGTH = 0.02
"""Length (m) of a scripted phalanx; only its centre and width matter for contact."""


def probe_hand(phalanges: Mapping[str, Sequence[float]], side: str = "right", width: float = 0.016,
               track_id: int = 0) -> Hand:
    """A hand whose named phalanges (``"index.distal"``, ``"thumb.distal"``, ...) are centred at
    the given positions (m), each a short bone along x of ``width``; the rest is untracked."""
    joints = np.full((N_DIGITS, N_BONES + 1, 3), np.nan)
    widths = np.full((N_DIGITS, N_BONES), np.nan)
    half = np.array([PHALANX_LENGTH / 2, 0.0, 0.0])
    for name, centre in phalanges.items():
        digit_name, _, bone_name = name.partition(".")
        if digit_name not in DIGITS or bone_name not in BONES:
            raise ValueError(f"phalanx {name!r}: expected 'digit.bone' with digit in {DIGITS} and bone in {BONES}")
        d, b = DIGITS.index(digit_name), BONES.index(bone_name)
        if np.isfinite(joints[d, b]).any() or np.isfinite(joints[d, b + 1]).any():
            raise ValueError(f"phalanx {name!r} shares a joint with another scripted phalanx of its digit")
        centre = np.asarray(centre, dtype=np.float64)
        joints[d, b], joints[d, b + 1] = centre - half, centre + half
        widths[d, b] = width
    palm = np.mean([np.asarray(c, dtype=np.float64) for c in phalanges.values()], axis=0)
    return Hand(side, joints, widths, palm, track_id=track_id)


def probe_frames(path, times: Sequence[float], side: str = "right", width: float = 0.016) -> list[HandFrame]:
    """Frames at ``times`` of a probe hand whose phalanges follow ``path(t) -> {name: position}``."""
    return [HandFrame(t, (probe_hand(path(t), side, width),)) for t in times]
