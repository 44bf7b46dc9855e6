"""The participant's kinematic hand: a canonical Leap skeleton posed by palm pose and joint angles.

Measured on the shared Leap recordings (medians over all 1080 frames of grab, pinch, HandSplay and
wave; ``python -m microg.participant.calibration``), in the hand frame of a right hand
(LeapC's palm basis: x from the thumb side to the little finger, y out of the back of the hand,
z toward the wrist; origin at the palm position):

=======  =====================  ==========================  =========
digit    knuckle (mm)           phalanges (mm)              width (mm)
=======  =====================  ==========================  =========
thumb    (-26.1, -0.9, 54.6)    42.0, 33.1, 21.0            19.7
index    (-26.7,  2.1, -15.4)   43.6, 26.9, 18.2            18.8
middle   ( -1.4,  3.0, -21.0)   46.9, 27.6, 18.3            18.5
ring     ( 20.5,  3.3, -17.4)   43.4, 26.9, 18.2            17.6
little   ( 39.1, -3.1,  -8.6)   33.6, 19.0, 16.8            15.6
=======  =====================  ==========================  =========

The thumb's knuckle is its carpometacarpal joint and its bones are Leap's proximal, intermediate
and distal (its metacarpal has zero length, as Leap reports it). LeapJS v2 gives one width per
digit, used for all its bones. The recordings have no metacarpal bases: they are *estimated*
on a carpal row 45 mm behind the palm position, at half the knuckles' spread, which gives
metacarpals of 62, 66, 63 and 57 mm (index to little), close to anatomical means.

Posture: ``angles`` (5, 4) in radians. A finger (index..little) has [abduction toward the little
finger, MCP flexion, PIP flexion, DIP flexion]; flexion curls toward the palm. The thumb has
[azimuth of its metacarpal from straight ahead toward the thumb side, elevation below the palm
plane (palmar abduction, opposition), MCP flexion, IP flexion]; its phalanges bend toward the
fingers. A left hand is the mirror image (hand-frame x negated).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from microg.skeleton import N_BONES, SIDES, Hand
from microg.sim.rotation import quat_to_matrix

KNUCKLES = np.array([[-26.1, -0.9, 54.6], [-26.7, 2.1, -15.4], [-1.4, 3.0, -21.0],
                     [20.5, 3.3, -17.4], [39.1, -3.1, -8.6]]) * 1e-3
PHALANGES = np.array([[42.0, 33.1, 21.0], [43.6, 26.9, 18.2], [46.9, 27.6, 18.3],
                      [43.4, 26.9, 18.2], [33.6, 19.0, 16.8]]) * 1e-3
DIGIT_WIDTHS = np.array([19.7, 18.8, 18.5, 17.6, 15.6]) * 1e-3
CARPAL_ROW_Z = 0.045
"""Hand-frame z of the estimated metacarpal bases (m)."""
CARPALS = np.column_stack([0.5 * KNUCKLES[1:, 0], KNUCKLES[1:, 1], np.full(4, CARPAL_ROW_Z)])

WIDTHS = np.repeat(DIGIT_WIDTHS[:, None], N_BONES, axis=1)
RADII = DIGIT_WIDTHS / 2
DIP_PER_PIP = 2.0 / 3.0
"""DIP flexion follows PIP flexion at this ratio (the tendon coupling of the long fingers)."""

REST = np.radians([[28.0, 5.0, 10.0, 10.0],
                   [5.0, 10.0, 15.0, 10.0],
                   [9.0, 10.0, 15.0, 10.0],
                   [10.0, 10.0, 15.0, 10.0],
                   [20.0, 10.0, 15.0, 10.0]])
"""A relaxed open hand: finger spread between the recordings' splay and grab medians, thumb as in splay."""

LOWER = np.radians([[0.0, -15.0, -15.0, -20.0]] + [[-20.0, -20.0, 0.0, 0.0]] * 4)
UPPER = np.radians([[75.0, 75.0, 60.0, 80.0]] + [[20.0, 90.0, 105.0, 70.0]] * 4)
"""Joint limits of the posture angles (rows as ``REST``)."""


@njit(cache=True)
def _local_joints(angles, knuckles, carpals, phalanges, joints):
    """``local_joints`` into ``joints``, element by element (compiled code pays for each small
    array it makes)."""
    for d in range(1, 5):
        abduction = angles[d, 0]
        forward_x, forward_z = np.sin(abduction), -np.cos(abduction)
        joints[d, 0] = carpals[d - 1]
        joints[d, 1] = knuckles[d]
        bend = 0.0
        for b in range(3):
            bend += angles[d, b + 1]
            c, length = np.cos(bend), phalanges[d, b]
            joints[d, b + 2, 0] = joints[d, b + 1, 0] + length * (c * forward_x)
            joints[d, b + 2, 1] = joints[d, b + 1, 1] + length * (c * 0.0 - np.sin(bend))
            joints[d, b + 2, 2] = joints[d, b + 1, 2] + length * (c * forward_z)
    azimuth, elevation, mcp, ip = angles[0, 0], angles[0, 1], angles[0, 2], angles[0, 3]
    metacarpal = (-np.sin(azimuth) * np.cos(elevation), -np.sin(elevation), -np.cos(azimuth) * np.cos(elevation))
    across_x = -metacarpal[0] * metacarpal[0] + 1.0
    across_y, across_z = -metacarpal[0] * metacarpal[1], -metacarpal[0] * metacarpal[2]
    norm = np.sqrt(across_x ** 2 + across_y ** 2 + across_z ** 2)
    across = (across_x / norm, across_y / norm, across_z / norm)
    joints[0, 0] = knuckles[0]
    joints[0, 1] = knuckles[0]
    bends = (0.0, mcp, mcp + ip)
    for b in range(3):
        c, s, length = np.cos(bends[b]), np.sin(bends[b]), phalanges[0, b]
        for i in range(3):
            joints[0, b + 2, i] = joints[0, b + 1, i] + length * (c * metacarpal[i] + s * across[i])


def local_joints(angles: np.ndarray) -> np.ndarray:
    """(5, 5, 3) joints of a right hand in the hand frame for a posture ``angles`` (5, 4)."""
    joints = np.empty((5, N_BONES + 1, 3))
    _local_joints(np.ascontiguousarray(angles, dtype=np.float64), KNUCKLES, CARPALS, PHALANGES, joints)
    return joints


@njit(cache=True)
def _to_world(local, position, orientation, mirror, out):
    """``to_world`` into ``out``."""
    rotation = quat_to_matrix(orientation)
    for d in range(local.shape[0]):
        for j in range(local.shape[1]):
            x = mirror * local[d, j, 0]
            for i in range(3):
                out[d, j, i] = position[i] + rotation[i, 0] * x + rotation[i, 1] * local[d, j, 1] + rotation[i, 2] * local[d, j, 2]


def to_world(local: np.ndarray, palm_position: np.ndarray, palm_orientation: np.ndarray, side: str) -> np.ndarray:
    """Hand-frame points (..., 5, 3) of a right hand to the world, mirrored for a left hand."""
    local = np.ascontiguousarray(local, dtype=np.float64)
    out = np.empty_like(local)
    _to_world(local, np.asarray(palm_position, dtype=np.float64), np.asarray(palm_orientation, dtype=np.float64),
              -1.0 if side == "left" else 1.0, out)
    return out


@njit(cache=True)
def pose_joints(angles, knuckles, carpals, phalanges, position, orientation, mirror, joints):
    """``to_world(local_joints(angles), ...)`` into ``joints`` in one compiled call (the
    participant's hand takes one a frame)."""
    local = np.empty_like(joints)
    _local_joints(angles, knuckles, carpals, phalanges, local)
    _to_world(local, position, orientation, mirror, joints)


_CHECKED = {side: Hand(side, np.zeros((5, N_BONES + 1, 3)), WIDTHS, np.zeros(3)) for side in SIDES}
"""A hand of each side with the skeleton's widths, checked once; ``make_hand`` copies it."""


def make_hand(angles: np.ndarray, palm_position: np.ndarray, palm_orientation: np.ndarray,
              side: str = "right", track_id: int = 1) -> Hand:
    """The full Leap-shaped hand for a posture and palm pose (world frame, m)."""
    palm_position = np.asarray(palm_position, dtype=np.float64)
    palm_orientation = np.asarray(palm_orientation, dtype=np.float64)
    joints = np.empty((5, N_BONES + 1, 3))
    pose_joints(np.ascontiguousarray(angles, dtype=np.float64), KNUCKLES, CARPALS, PHALANGES, palm_position,
                palm_orientation, -1.0 if side == "left" else 1.0, joints)
    return posed_hand(joints, palm_position, palm_orientation, side, track_id)


def posed_hand(joints: np.ndarray, palm_position: np.ndarray, palm_orientation: np.ndarray, side: str,
               track_id: int = 1) -> Hand:
    """The hand of the skeleton posed at ``joints`` (5, 5, 3) with its palm pose (float64 arrays,
    which it makes read-only).

    Such a hand is valid by construction (the skeleton's bones and widths, posed), so it is not
    checked again at every frame: a ``Hand.checked_copy`` of the checked skeleton (one of the three
    places ``Hand`` names), with its own read-only arrays.
    """
    joints.setflags(write=False)
    palm_position.setflags(write=False)
    palm_orientation.setflags(write=False)
    return _CHECKED[side].checked_copy(joints=joints, palm_position=palm_position, palm_orientation=palm_orientation,
                                       track_id=track_id)
