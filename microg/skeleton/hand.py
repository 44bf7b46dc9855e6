"""The tracked hand: the Leap Motion skeleton in SI units, one type for every hand source.

A hand is a palm pose plus 5 digits x 4 bones (metacarpal, proximal, intermediate, distal).
Bone ``b`` of digit ``d`` runs from ``joints[d, b]`` (its ``prev_joint``) to ``joints[d, b + 1]``
(its ``next_joint``), so the 20 bones share 25 joints. The thumb's metacarpal has zero length,
as in the Leap skeleton. A value the tracker did not deliver is NaN and stays NaN: a recording
without metacarpal bases, for example, has ``joints[:, 0]`` all NaN. Nothing unknown becomes zero.

Each bone with known ends and positive length is a *phalanx* for contact purposes: a sphere at
its centroid with radius ``width / 2`` (paper, section 3.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numba import njit

DIGITS = ("thumb", "index", "middle", "ring", "pinky")
BONES = ("metacarpal", "proximal", "intermediate", "distal")
SIDES = ("left", "right")
N_DIGITS = len(DIGITS)
N_BONES = len(BONES)
BONES_PER_HAND = N_DIGITS * N_BONES
SLOTS = len(SIDES) * BONES_PER_HAND
"""Phalanx slots in the physics: left hand 0..19, right hand 20..39, digit-major."""

MAX_BONE_WIDTH = 0.05
"""m: the widest bone a hand may have (a finger 5 cm thick; the Leap reports 8 to 22 mm)."""
MAX_REACH = 10.0
"""m: the farthest from the tracker a joint or palm may be (no tracker sees a hand farther away)."""
MIN_PHALANX_LENGTH = 1e-4
"""Bones shorter than this (m) are not phalanges: the thumb's metacarpal is one."""
POINTS = 1 + N_DIGITS * (N_BONES + 1)
"""A hand's palm and its 25 joints: the points a jump is measured on (``Hand.points``)."""
TRACKER_FLOAT = np.float32
"""The precision a hand has where it enters the frame path: a tracker's. LeapC's vectors and
quaternions and WebXR's joint poses (a Float32Array) are 32-bit floats; what a source derives from
them (a length in metres, a palm from joints) and the simulated participant's hands are rounded to
it too (``at_tracker_precision``), so the frame log keeps every bit the physics received of a hand
in 4 bytes a number (``microg.study.framelog``)."""


def at_tracker_precision(values) -> np.ndarray:
    """``values`` rounded to ``TRACKER_FLOAT``, held as float64 (NaN stays NaN)."""
    return np.asarray(values, dtype=TRACKER_FLOAT).astype(np.float64)


JUMP_DISTANCE = 0.10
"""m: how far a hand may move between two frames before it jumped (``is_jump``): 11 m/s at the Leap
Motion's 110 Hz, faster than a hand moves. The tracking guard's and the physics' default; a protocol
may set another (``scene.jump_distance``)."""
JUMP_ROUNDING = 1e-12
"""m: a move this much shorter than the jump distance still counts as reaching it (``is_jump``):
positions within ``MAX_REACH`` are rounded to about 1e-15 m, so a move of 10 cm written in
decimals (y from 0.3 to 0.2) measures 0.09999999999999998 m. No tracker resolves a picometre."""


def slot(side: str, digit: int, bone: int) -> int:
    """Index of a bone in the physics' phalanx arrays."""
    return SIDES.index(side) * BONES_PER_HAND + digit * N_BONES + bone


def side_slots(side: int) -> slice:
    """The slots of one hand's bones (side 0: left, 1: right), in digit-major order."""
    return slice(side * BONES_PER_HAND, (side + 1) * BONES_PER_HAND)


def slot_name(index: int) -> str:
    """Readable name of a phalanx slot, e.g. ``right.index.distal``."""
    side, rest = divmod(index, BONES_PER_HAND)
    digit, bone = divmod(rest, N_BONES)
    return f"{SIDES[side]}.{DIGITS[digit]}.{BONES[bone]}"


SLOT_DIGIT = np.array([(i % BONES_PER_HAND) // N_BONES for i in range(SLOTS)], dtype=np.int64)


def bone_lengths(joints: np.ndarray) -> np.ndarray:
    """(5, 4) bone lengths of a (5, 5, 3) joint array; NaN where an end is unknown."""
    return np.linalg.norm(joints[:, 1:] - joints[:, :-1], axis=-1)


def bone_centres(joints: np.ndarray) -> np.ndarray:
    """(5, 4, 3) bone centroids of a (5, 5, 3) joint array: the phalanx sphere centres."""
    return 0.5 * (joints[:, 1:] + joints[:, :-1])


def phalanx_mask(joints: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """(5, 4) True where a bone is a contact sphere: known ends and width, length at least
    ``MIN_PHALANX_LENGTH``."""
    lengths = bone_lengths(joints)
    with np.errstate(invalid="ignore"):
        return np.isfinite(lengths) & (lengths >= MIN_PHALANX_LENGTH) & (widths > 0)


@njit(cache=True)
def displacement(points, previous):
    """The largest distance (m) any point known in both (palm, joints: ``Hand.points``) moved."""
    largest = 0.0
    for i in range(points.shape[0]):
        distance = math.sqrt((points[i, 0] - previous[i, 0]) ** 2 + (points[i, 1] - previous[i, 1]) ** 2
                             + (points[i, 2] - previous[i, 2]) ** 2)
        if math.isfinite(distance):
            largest = max(largest, distance)
    return largest


@njit(cache=True)
def is_jump(points, previous, jump_distance):
    """The jump rule: a hand whose palm or some joint moved ``jump_distance`` or more between two
    frames (give or take ``JUMP_ROUNDING``) did not get there by moving; it is a new track (no
    velocity, no filter history, no contact). The tracking guard asks it of every hand it admits
    (``microg.hands.guard``: a jump that stays gets a new track id), and the world asks it again of
    every frame it takes (``microg.sim.hand_path``, from compiled code), for callers of the physics
    that pass no guard: a hand that jumped on the same id starts a new track there too."""
    return displacement(points, previous) >= jump_distance - JUMP_ROUNDING


@njit(cache=True)
def jumped(palm, joints, last_palm, last_joints, jump_distance):
    """``is_jump`` between two hands' points (``Hand.points``), read from their palm and joint
    arrays as they are."""
    return (is_jump(palm.reshape((1, 3)), last_palm.reshape((1, 3)), jump_distance)
            or is_jump(joints.reshape((-1, 3)), last_joints.reshape((-1, 3)), jump_distance))


def hand_jumped(hand: Hand, last: Hand, jump_distance: float) -> bool:
    """``is_jump`` between two hands, without building their ``points``."""
    return jumped(hand.palm_position, hand.joints, last.palm_position, last.joints, jump_distance)


def _arrays_equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))


@dataclass(frozen=True, eq=False)
class Hand:
    """One tracked hand, in metres, in the tracker's frame (y up). Construction refuses what no real
    hand can be (infinite values, bones wider than ``MAX_BONE_WIDTH``, points farther than
    ``MAX_REACH``, a palm orientation that is not a unit quaternion), naming the field and value.

    The checks are skipped in three places only, each a copy of a checked hand (``checked_copy``)
    made every frame, where a profile of a session showed the checks cost more than the rest of the
    step: the tracking guard renumbering a track (``renumbered``), the window filter's smoothed
    joints (``with_joints``: weighted means of checked joints) and the simulated participant's
    posed hand (``microg.participant.anatomy.posed_hand``: its checked skeleton, posed). A checked
    ``Hand(...)`` costs about 50 times the copy (some 100 us against 2-5 us a hand here)."""

    side: str
    joints: np.ndarray
    """(5, 5, 3) joint positions, digit-major; NaN where unknown."""
    widths: np.ndarray
    """(5, 4) bone widths; NaN where unknown."""
    palm_position: np.ndarray
    """(3,) palm centre."""
    palm_orientation: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    """(4,) unit quaternion (w, x, y, z) from the hand frame to the world; NaN where unknown."""
    track_id: int = 0
    """The tracker's id for this hand; a new id means the track was lost and found again."""

    def __post_init__(self) -> None:
        if self.side not in SIDES:
            raise ValueError(f"Hand.side = {self.side!r}: must be one of {SIDES}")
        for name, shape in (("joints", (N_DIGITS, N_BONES + 1, 3)), ("widths", (N_DIGITS, N_BONES)),
                            ("palm_position", (3,)), ("palm_orientation", (4,))):
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.shape != shape:
                raise ValueError(f"Hand({self.side}).{name} has shape {value.shape}, expected {shape}")
            if np.isinf(value).any():
                index = tuple(int(i) for i in np.argwhere(np.isinf(value))[0])
                raise ValueError(f"Hand({self.side}).{name}{list(index)} = {value[index]}: infinite")
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        wide = self.widths > MAX_BONE_WIDTH  # NaN (unknown) compares False
        if wide.any():
            d, b = (int(i) for i in np.argwhere(wide)[0])
            raise ValueError(f"{self.side} widths[{d}, {b}] = {self.widths[d, b]:g} m: wider than any finger "
                             f"(at most {MAX_BONE_WIDTH:g} m)")
        for name in ("joints", "palm_position"):
            values = getattr(self, name)
            far = np.abs(values) > MAX_REACH
            if far.any():
                index = tuple(int(i) for i in np.argwhere(far)[0])
                raise ValueError(f"{self.side} {name}{list(index)} = {values[index]:g} m: farther from the "
                                 f"tracker than {MAX_REACH:g} m")
        q = self.palm_orientation
        if np.isnan(q).any() and not np.isnan(q).all():
            raise ValueError(f"{self.side} palm_orientation = {q.tolist()}: partly unknown")
        if np.isfinite(q).all() and abs(float(np.sqrt(q @ q)) - 1.0) > 1e-3:
            raise ValueError(f"{self.side} palm_orientation = {q.tolist()}: not a unit quaternion")
        known = np.isfinite(self.joints).all(axis=-1)
        bone_known = known[:, :-1] & known[:, 1:]
        bad = bone_known & np.isfinite(self.widths) & (self.widths <= 0) & (self.bone_lengths >= MIN_PHALANX_LENGTH)
        if bad.any():
            d, b = (int(i) for i in np.argwhere(bad)[0])
            raise ValueError(
                f"Hand({self.side}).widths[{d}, {b}] ({DIGITS[d]} {BONES[b]}) = {self.widths[d, b]}: "
                "a tracked bone must have a positive width")

    @property
    def bone_lengths(self) -> np.ndarray:
        """(5, 4) bone lengths; NaN where an end is unknown."""
        return bone_lengths(self.joints)

    @property
    def bone_centres(self) -> np.ndarray:
        """(5, 4, 3) bone centroids: the phalanx sphere centres."""
        return bone_centres(self.joints)

    @property
    def phalanx_mask(self) -> np.ndarray:
        """(5, 4) True where the bone is a contact sphere (``phalanx_mask``)."""
        return phalanx_mask(self.joints, self.widths)

    @property
    def points(self) -> np.ndarray:
        """(26, 3) palm and joints: the points a jump is measured on."""
        return np.vstack([self.palm_position, self.joints.reshape(-1, 3)])

    def checked_copy(self, **fields) -> Hand:
        """This hand with ``fields`` replaced, without the checks: only for the three callers the
        class docstring names, whose new fields are valid by construction (read-only float64
        arrays of the same shapes, derived from checked hands)."""
        hand = object.__new__(Hand)
        hand.__dict__.update(self.__dict__, **fields)
        return hand

    def renumbered(self, track_id: int) -> Hand:
        """The same hand under another track id, sharing its read-only arrays (a ``checked_copy``)."""
        return self.checked_copy(track_id=track_id)

    def with_joints(self, joints: np.ndarray) -> Hand:
        """The same hand with other joint positions of the same shape, e.g. the window filter's
        weighted mean of this track's checked joints (a ``checked_copy``)."""
        joints = np.asarray(joints, dtype=np.float64)
        joints.setflags(write=False)
        return self.checked_copy(joints=joints)

    def moved(self, offset: np.ndarray) -> Hand:
        """The same hand translated by ``offset`` (m)."""
        offset = np.asarray(offset, dtype=np.float64)
        return Hand(self.side, self.joints + offset, self.widths, self.palm_position + offset,
                    self.palm_orientation, self.track_id)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Hand):
            return NotImplemented
        return (self.side == other.side and self.track_id == other.track_id
                and all(_arrays_equal(getattr(self, n), getattr(other, n))
                        for n in ("joints", "widths", "palm_position", "palm_orientation")))

    __hash__ = None


@dataclass(frozen=True, eq=False)
class HandFrame:
    """What a hand source delivers at one instant: a timestamp (s) and the hands it saw (left first)."""

    timestamp: float
    hands: tuple[Hand, ...] = ()

    def __post_init__(self) -> None:
        if not math.isfinite(self.timestamp):
            raise ValueError(f"HandFrame.timestamp = {self.timestamp}: must be finite")
        object.__setattr__(self, "timestamp", float(self.timestamp))
        hands = tuple(self.hands)
        if len(hands) > 1:  # one hand or none is in order as it is: most frames, built every frame
            hands = tuple(sorted(hands, key=lambda h: SIDES.index(h.side)))
            sides = [h.side for h in hands]
            if len(set(sides)) != len(sides):
                raise ValueError(f"HandFrame at t={self.timestamp}: two {sides[0]} hands in one frame")
        object.__setattr__(self, "hands", hands)

    @classmethod
    def made(cls, timestamp: float, hands: tuple[Hand, ...]) -> HandFrame:
        """A frame without the checks, for the code that makes one every frame in order by
        construction (the guard, the window filter, the simulated participant): a finite float
        time, at most one hand per side, left first. The checks cost about twice the frame."""
        frame = object.__new__(cls)
        frame.__dict__.update(timestamp=timestamp, hands=hands)
        return frame

    def hand(self, side: str) -> Hand | None:
        """The hand on ``side``, or None when it is not tracked in this frame."""
        for hand in self.hands:
            if hand.side == side:
                return hand
        return None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, HandFrame):
            return NotImplemented
        return self.timestamp == other.timestamp and self.hands == other.hands

    __hash__ = None


HANDS = np.dtype([("t", "f8"), ("present", "u1", (2,)), ("track_id", "i8", (2,)),
                  ("points", "f8", (2, POINTS, 3)), ("widths", "f8", (2, N_DIGITS, N_BONES)),
                  ("orientation", "f8", (2, 4))], align=True)
"""A ``HandFrame`` as a record, what compiled code passes along (the tracking guard, the window
filter, the physics): its time, and per side (``SIDES``) whether a hand is there, its track id, its
``points`` (palm, then the joints digit-major), its bone widths and its palm orientation. The
fields of a side without a hand are NaN (its track id 0)."""


def hands_record(frame: HandFrame, out=None):
    """``frame`` as a ``HANDS`` record (written into ``out`` when given)."""
    out = np.zeros(1, HANDS)[0] if out is None else out
    out["t"] = frame.timestamp
    out["present"], out["track_id"] = False, 0
    out["points"], out["widths"], out["orientation"] = np.nan, np.nan, np.nan
    for hand in frame.hands:
        side = SIDES.index(hand.side)
        out["present"][side], out["track_id"][side] = True, hand.track_id
        out["points"][side, 0] = hand.palm_position
        out["points"][side, 1:] = hand.joints.reshape(-1, 3)
        out["widths"][side], out["orientation"][side] = hand.widths, hand.palm_orientation
    return out


def hand_frame(record) -> HandFrame:
    """The ``HandFrame`` a ``HANDS`` record holds. Its hands are made unchecked (``Hand.checked_copy``):
    a record holds what checked hands gave, passed on, bridged or averaged by compiled code."""
    hands = []
    for side, name in enumerate(SIDES):
        if record["present"][side]:
            points = record["points"][side]
            hands.append(_unchecked(name, points[1:].reshape(N_DIGITS, N_BONES + 1, 3).copy(),
                                    record["widths"][side].copy(), points[0].copy(), record["orientation"][side].copy(),
                                    int(record["track_id"][side])))
    return HandFrame.made(float(record["t"]), tuple(hands))


def _unchecked(side: str, joints, widths, palm_position, palm_orientation, track_id: int) -> Hand:
    for array in (joints, widths, palm_position, palm_orientation):
        array.setflags(write=False)
    hand = object.__new__(Hand)
    hand.__dict__.update(side=side, joints=joints, widths=widths, palm_position=palm_position,
                         palm_orientation=palm_orientation, track_id=track_id)
    return hand


class TrackedFrame(NamedTuple):
    """One frame out of hand tracking (``microg.hands.tracking``): the frame the tracking guard
    admitted (what a session logs as the tracked hand) and the same frame after the window filter
    (Eq. 1: what the physics steps with)."""

    admitted: HandFrame
    smoothed: HandFrame
