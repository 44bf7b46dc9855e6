"""Scripted hands: hands of which only chosen phalanges are tracked, placed where a script says.

Useful to demonstrate or check one effect at a time (a fingertip tapping a cube, a thumb and an
index pinching it) without a tracker. Every other bone stays unknown (NaN), as a tracker would
mark it.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from microg.skeleton import BONES, DIGITS, N_BONES, N_DIGITS, Hand
from .motion import minimum_jerk

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


def pinch_and_carry(centre: Sequence[float], half_width: float, carry: Sequence[float], depth: float = 0.005,
                    approach: float = 0.5, close: float = 0.5, hold: float = 0.3, move: float = 1.5,
                    width: float = 0.016):
    """A thumb and an index fingertip that close on an object's -x and +x faces, squeeze ``depth``
    into them, carry it by ``carry`` (minimum jerk), and open again. Returns ``path(t)`` and the
    time at which the hand has let go."""
    contacts = {"thumb.distal": ((-half_width, 0.0, 0.0), (-1.0, 0.0, 0.0)),
                "index.distal": ((half_width, 0.0, 0.0), (1.0, 0.0, 0.0))}
    return grip_and_carry(centre, contacts, carry, depth, approach, close, hold, move, hold, True, width)


def grip_and_carry(centre: Sequence[float], contacts: Mapping[str, tuple[Sequence[float], Sequence[float]]],
                   carry: Sequence[float], depth: float = 0.005, approach: float = 0.5, close: float = 0.5,
                   hold: float = 0.3, move: float = 1.5, hold_after: float = 0.3, release: bool = True,
                   width: float = 0.016, opening: float = 0.03):
    """Phalanges that come down from 5 cm above an object, close onto it, carry it and hold it.

    Parameters
    ----------
    centre
        The object's centre (m) at the start.
    contacts
        For each phalanx (``"index.distal"``, ...), the point of the object's surface it closes on,
        relative to ``centre``, and the surface's outward unit normal there (m).
    carry
        How far the closed hand moves (m), with a minimum-jerk motion of ``move`` seconds.
    depth
        How far each phalanx's sphere presses past the surface (m) once closed.
    approach, close, hold, move, hold_after
        Seconds to come down (open, ``opening`` m off the surface), to close, to hold before the
        carry, to carry, and to hold after it.
    release
        Open again (``close`` seconds) after ``hold_after``; otherwise keep holding.

    Returns
    -------
    path : callable
        ``path(t)``: each phalanx's centre at time ``t`` (s), for ``probe_hand``.
    done : float
        The time at which the hand has let go (with ``release``) or ends its last hold.
    """
    centre, carry = np.asarray(centre, dtype=float), np.asarray(carry, dtype=float)
    radius = width / 2
    closed = {name: centre + np.asarray(point, dtype=float) + (radius - depth) * np.asarray(normal, dtype=float)
              for name, (point, normal) in contacts.items()}
    opened = {name: closed[name] + (opening + depth) * np.asarray(normal, dtype=float)
              for name, (_, normal) in contacts.items()}
    t_closed = approach + close
    t_moved = t_closed + hold + move
    done = t_moved + hold_after + (close if release else 0.0)

    def path(t: float) -> dict[str, np.ndarray]:
        if release and t >= t_moved:
            grip = 1.0 - minimum_jerk((t - t_moved - hold_after) / close)
        else:
            grip = minimum_jerk((t - approach) / close)
        lift = 0.05 * (1.0 - minimum_jerk(t / approach))
        offset = carry * minimum_jerk((t - t_closed - hold) / move) + (0.0, lift, 0.0)
        return {name: opened[name] + grip * (closed[name] - opened[name]) + offset for name in contacts}

    return path, done
