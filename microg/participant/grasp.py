"""Grasp planning: where the hand goes around an object, and how its digits close.

Two grasps cover the shipped objects:

- ``side``: palm over the object, thumb on the near face and the pressing fingers on the far face
  (a precision grip across the object's narrowest horizontal extent): the cube (index, middle),
  the ball (index, middle), the long bar across its 2.5 cm (index, middle, ring).
- ``flat``: a thin plate (thinnest extent at most 2 cm, lying flat) is clamped palm up: it lies on
  the extended fingers and the thumb reaches round its near edge onto its top. Its weight rests on
  the fingers, so it does not tip out of the grip as a plate hanging from a palm-down pinch does.

A grasp is planned in the object's frame from its current pose: which body axis is up, which
one the digits squeeze along. It is a *template*: the object's centre in the hand frame, the
hand's orientation relative to the object, and joint angles at a ladder of closures q (m):
q < 0 leaves each pressing phalanx |q| short of its face (the pre-shape), q = 0 touches, q > 0
presses q into it. The participant interpolates the ladder, so closing costs nothing per frame;
the inverse kinematics (``scipy.optimize.least_squares``) runs once per grasp shape.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numba import njit
from scipy.optimize import least_squares

from microg.skeleton import bone_centres
from microg.sim.rotation import quat_from_matrix, quat_to_matrix
from .anatomy import DIP_PER_PIP, KNUCKLES, LOWER, PHALANGES, RADII, REST, UPPER, local_joints

CLOSURES = np.array([-0.012, -0.008, -0.004, 0.0, 0.006, 0.012, 0.018, 0.024])
"""The closure ladder (m) at which postures are solved."""
_LADDER = [float(q) for q in CLOSURES]
MAX_APERTURE = 0.085
"""Widest object extent (m) squeezed in a side grasp."""
FLAT_THICKNESS = 0.02
"""Objects no thicker than this (m), and wide both ways, are clamped flat."""
PALM_CLEARANCE = 0.016
"""Gap (m) kept between the palm's contact spheres and the object's top in a side grasp."""
FLAT_CLEARANCE = 0.004
"""Gap (m) between the palm's contact spheres and a clamped plate (only its near edge is under them)."""
PALM_BOTTOM = float(np.max(RADII[1:] - KNUCKLES[1:, 1]))
"""Depth (m) of the metacarpal spheres below the palm plane (their centres lie at knuckle height)."""
INTERMEDIATE, DISTAL = 2, 3
FLAT_EDGE = -0.006
"""Hand-frame z of a clamped plate's near edge (m): the thumb passes round it behind the knuckles."""
FLAT_THUMB_INSET = 0.004
"""How far in from a clamped plate's near edge the thumb's distal phalanx presses (m)."""
CLEARANCE = 0.003
"""Gap (m) the planner keeps between the object and the phalanges that are not meant to press; an
intrusion weighs three times a miss of the pressing phalanx's target."""
FLAT_APPROACH = 0.11
"""A flat clamp starts this far (m) behind the grasp, so the extended fingers begin clear of the plate."""
OPEN_LIFT = 0.6
"""In a side grasp an opening digit also rises (m per m of opening): it uncurls along an arc."""

ROUND_LATITUDE = math.radians(20.0)
"""Latitude (rad) above a ball's equator where a side grasp's pressing phalanges touch it: each
press also pushes the ball away from the palm by sin(latitude) of its force (``actions._squeeze_depth``)."""

RELAXED_FINGER = np.radians([0.0, 5.0, 10.0, 7.0])
"""Fingers that do not press in a side grasp stay nearly straight, above the object; under a
clamped plate they lie straight."""


@dataclass(frozen=True, eq=False)
class GraspTemplate:
    """A grasp of one object shape in one orientation class (see module doc)."""

    kind: str
    digits: tuple[int, ...]
    """Digits that press: the thumb (0) and the fingers opposing it."""
    hand_in_object: np.ndarray
    """(3, 3) the hand's axes (columns) in the object's body frame."""
    object_in_hand: np.ndarray
    """(3,) the object's centre in the hand frame at the grasp (m)."""
    approach: np.ndarray
    """(3,) hand-frame offset of the pre-grasp palm position from the grasp position (m)."""
    postures: np.ndarray
    """(len(CLOSURES), 5, 4) joint angles along the closure ladder."""
    last: list = field(default_factory=lambda: [math.nan, None], repr=False)
    """The last closure asked for and its posture: a grip holds its closure for many frames."""

    def posture(self, closure: float) -> np.ndarray:
        """Joint angles at closure ``closure`` (m), interpolated on the ladder; read-only."""
        q = min(max(float(closure), _LADDER[0]), _LADDER[-1])
        if q == self.last[0] and q != 0.0:  # (0.0 and -0.0 are equal, yet might interpolate apart)
            return self.last[1]
        i = min(bisect.bisect_right(_LADDER, q) - 1, len(_LADDER) - 2)
        w = (q - _LADDER[i]) / (_LADDER[i + 1] - _LADDER[i])
        posture = (1.0 - w) * self.postures[i] + w * self.postures[i + 1]
        posture.setflags(write=False)
        self.last[:] = q, posture
        return posture

    def hand_pose(self, object_position: np.ndarray, object_rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Palm position and hand rotation matrix that put the object where the template holds it."""
        rotation = object_rotation @ self.hand_in_object
        return object_position - rotation @ self.object_in_hand, rotation


@dataclass(frozen=True)
class Obstacle:
    """The object in the hand frame while its grasp is planned: the digits' other phalanges keep clear."""

    centre: np.ndarray
    half: np.ndarray
    round_object: bool

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) of points (..., 3) from the object's surface, negative inside."""
        offset = points - self.centre
        if self.round_object:
            return np.linalg.norm(offset, axis=-1) - self.half[0]
        excess = np.abs(offset) - self.half
        outside = np.linalg.norm(np.maximum(excess, 0.0), axis=-1)
        return outside + np.minimum(excess.max(axis=-1), 0.0)


def _digit_ik(digit: int, targets: dict[int, np.ndarray], start: np.ndarray, obstacle: Obstacle,
              clearance: float) -> np.ndarray:
    """Joint angles of one digit putting the given bones' centres on their hand-frame targets,
    its other moving phalanges ``clearance`` clear of the object where they can be."""
    bones = sorted(targets)
    goal = np.array([targets[b] for b in bones])
    others = [b for b in (1, 2, 3) if b not in bones]
    coupled = digit != 0

    def expand(x):
        angles = REST.copy()
        angles[digit] = [x[0], x[1], x[2], DIP_PER_PIP * x[2]] if coupled else x
        return angles

    def residual(x):
        centres = bone_centres(local_joints(expand(x)))[digit]
        intrusion = np.maximum(RADII[digit] + clearance - obstacle.distance(centres[others]), 0.0)
        return np.concatenate([((centres[bones] - goal) * 1e3).ravel(), 3.0 * intrusion * 1e3, 0.5 * (x - x0)])

    x0 = start[digit, :3] if coupled else start[digit]
    lower = LOWER[digit, :3] if coupled else LOWER[digit]
    upper = UPPER[digit, :3] if coupled else UPPER[digit]
    solution = least_squares(residual, np.clip(x0, lower + 1e-6, upper - 1e-6), bounds=(lower, upper), xtol=1e-8)
    return expand(solution.x)[digit]


def _ladder(digit_targets, free_fingers, obstacle: Obstacle, free_posture: np.ndarray) -> np.ndarray:
    """Postures along CLOSURES; ``digit_targets(q)`` gives {digit: {bone: target}}; the other
    fingers keep ``free_posture`` (flexions) at their rest spread. The touching posture (q = 0) is
    solved first and each neighbour starts from it, so opening and squeezing stay on one branch."""
    postures = np.empty((len(CLOSURES), 5, 4))
    touch = int(np.argmin(np.abs(CLOSURES)))
    order = [touch] + list(range(touch - 1, -1, -1)) + list(range(touch + 1, len(CLOSURES)))
    for i in order:
        q = CLOSURES[i]
        start = REST if i == touch else postures[i + 1 if i < touch else i - 1]
        posture = REST.copy()
        for finger in free_fingers:
            posture[finger] = free_posture + [REST[finger, 0], 0.0, 0.0, 0.0]
        for digit, targets in digit_targets(q).items():
            posture[digit] = _digit_ik(digit, targets, start, obstacle, CLEARANCE + max(-q, 0.0))
        postures[i] = posture
    return postures


@lru_cache(maxsize=64)
def side_template(half: tuple[float, float, float], fingers: tuple[int, ...], round_object: bool
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Object centre in the hand frame and the closure ladder of a side grasp; ``half`` are the
    object's half extents along the hand's x, y, z. The pressing phalanges touch the near and
    far faces a little above the object's middle (on a sphere: at ``ROUND_LATITUDE``)."""
    hx, hy, hz = half
    x_centre = float(np.mean(KNUCKLES[list(fingers), 0]))
    if round_object:
        reach = hz * np.cos(ROUND_LATITUDE)
        centre = np.array([x_centre, -(PALM_BOTTOM + PALM_CLEARANCE + hy), -(0.004 + reach)])
        height = centre[1] + hy * np.sin(ROUND_LATITUDE)
    else:
        reach = hz
        centre = np.array([x_centre, -(PALM_BOTTOM + PALM_CLEARANCE + hy), -(0.012 + hz)])
        height = centre[1] + 0.35 * hy

    def targets(q):
        lift = OPEN_LIFT * max(-q, 0.0)
        out = {0: {DISTAL: np.array([x_centre, height + lift, centre[2] + reach + RADII[0] - q])}}
        for f in fingers:
            x = float(np.clip(KNUCKLES[f, 0], x_centre - hx + 0.004, x_centre + hx - 0.004))
            out[f] = {DISTAL: np.array([x, height + lift, centre[2] - reach - RADII[f] + q])}
        return out

    free = [f for f in range(1, 5) if f not in fingers]
    return centre, _ladder(targets, free, Obstacle(centre, np.array(half), round_object), RELAXED_FINGER)


@lru_cache(maxsize=64)
def flat_template(half: tuple[float, float, float], fingers: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Object centre in the hand frame and the closure ladder of a flat clamp: the plate lies on
    the palmar side of the extended fingers, its near edge ``FLAT_EDGE`` ahead of the palm, and
    the thumb reaches round that edge onto its other face."""
    hx, hy, hz = half
    x_centre = float(np.mean(KNUCKLES[list(fingers), 0]))
    face = -(PALM_BOTTOM + FLAT_CLEARANCE)
    centre = np.array([x_centre, face - hy, FLAT_EDGE - hz])
    far_edge = FLAT_EDGE - 2 * hz

    def targets(q):
        out = {0: {DISTAL: np.array([x_centre, face - 2 * hy - RADII[0] + q, FLAT_EDGE - FLAT_THUMB_INSET])}}
        for f in fingers:
            x = float(np.clip(KNUCKLES[f, 0], x_centre - hx + 0.004, x_centre + hx - 0.004))
            # A straight finger lying along the plate: intermediate and distal centres on its face.
            along = KNUCKLES[f, 2] - np.cumsum(PHALANGES[f]) + 0.5 * PHALANGES[f]
            lying = [bone for bone in (INTERMEDIATE, DISTAL) if along[bone - 1] > far_edge]
            out[f] = {bone: np.array([x, face + RADII[f] - q, along[bone - 1]]) for bone in lying}
        return out

    free = [f for f in range(1, 5) if f not in fingers]
    return centre, _ladder(targets, free, Obstacle(centre, np.array(half), False), np.zeros(4))


GRASP = np.dtype([("valid", "?"), ("flat", "?"), ("fingers", "i8"), ("hand_in_object", "f8", (3, 3)),
                  ("orientation", "f8", (4,)),
                  ("object_in_hand", "f8", (3,)), ("approach", "f8", (3,)),
                  ("postures", "f8", (len(CLOSURES), 5, 4))], align=True)
"""One grasp of an object, as the compiled participant reads it (``GraspTemplate``'s numbers;
``orientation`` is ``hand_in_object`` as a quaternion)."""
KEYS = 24
"""Grasp frames of a box: the up axis (3) and its sign, which of the other two axes the grip goes
along and its sign (``choose_grasp``)."""
UP = np.array([0.0, 1.0, 0.0])
TOWARD_USER = np.array([0.3, 0.0, 1.0])


@njit(cache=True)
def choose_grasp(round_object, half_extents, orientation, hand_in_object, toward, palm_up):
    """Which grasp the hand takes of an object lying as ``orientation`` says: its key (0 for a
    ball) and the hand's axes in the object's frame (into ``hand_in_object``, columns).

    The hand's y axis follows the object's most vertical body axis (palm down for a side grasp,
    palm up under a clamped plate; turned over with ``palm_up``: a handover's hand that takes the
    object from below), its z axis the squeezed axis (side) or the plate's axis that points most
    along ``toward`` (``TOWARD_USER``; a catch's squeezes across the launch's path), signed so the
    fingers point away from it. A ball has no faces to align with: the hand keeps the world's axes
    (palm down, fingers ahead; palm up turned over about the fingers' axis)."""
    axes = quat_to_matrix(orientation)
    flip = -1.0 if palm_up else 1.0
    if round_object:
        for i in range(3):
            hand_in_object[i, 1], hand_in_object[i, 2] = flip * axes[1, i], axes[2, i]
        _complete_frame(hand_in_object)
        return 0
    up_axis, best = 0, -1.0
    for a in range(3):
        if abs(axes[1, a]) > best:
            up_axis, best = a, abs(axes[1, a])
    others = (1, 2) if up_axis == 0 else (0, 2) if up_axis == 1 else (0, 1)
    flat = (2 * half_extents[up_axis] <= FLAT_THICKNESS and 2 * half_extents[others[0]] > 2.5 * FLAT_THICKNESS
            and 2 * half_extents[others[1]] > 2.5 * FLAT_THICKNESS)
    narrow = min(half_extents[others[0]], half_extents[others[1]])
    slot, best = -1, -1.0
    for k in range(2):
        a = others[k]
        if flat or half_extents[a] <= narrow + 1e-9:
            along_toward = abs(axes[0, a] * toward[0] + axes[1, a] * toward[1] + axes[2, a] * toward[2])
            if along_toward > best:
                slot, best = k, along_toward
    along = others[slot]
    up_sign = flip * (1.0 if axes[1, up_axis] >= 0 else -1.0)
    along_dot = axes[0, along] * toward[0] + axes[1, along] * toward[1] + axes[2, along] * toward[2]
    along_sign = 1.0 if along_dot >= 0 else -1.0
    return _grasp_frame(up_axis, up_sign, slot, along_sign, flat, hand_in_object)


@njit(cache=True)
def _grasp_frame(up_axis, up_sign, slot, along_sign, flat, hand_in_object):
    """The hand's axes for one box grasp key (see ``choose_grasp``); returns the key."""
    others = (1, 2) if up_axis == 0 else (0, 2) if up_axis == 1 else (0, 1)
    along = others[slot]
    for i in range(3):
        hand_in_object[i, 1] = (-1.0 if flat else 1.0) * up_sign * (1.0 if i == up_axis else 0.0)
        hand_in_object[i, 2] = along_sign * (1.0 if i == along else 0.0)
    _complete_frame(hand_in_object)
    return up_axis * 8 + (4 if up_sign > 0 else 0) + 2 * slot + (1 if along_sign > 0 else 0)


@njit(cache=True)
def _complete_frame(frame):
    """The x column as y x z, the hand's axes right-handed."""
    y0, y1, y2, z0, z1, z2 = frame[0, 1], frame[1, 1], frame[2, 1], frame[0, 2], frame[1, 2], frame[2, 2]
    frame[0, 0], frame[1, 0], frame[2, 0] = y1 * z2 - y2 * z1, y2 * z0 - y0 * z2, y0 * z1 - y1 * z0


@lru_cache(maxsize=32)
def grasps(shape: str, half_extents: tuple[float, float, float], side: str = "right") -> np.ndarray:
    """Every grasp a hand can take of the object, by key (``KEYS`` records of ``GRASP``): the
    postures are solved once per object (the inverse kinematics is the costly part). A key the
    choice never makes, or whose grip would be wider than ``MAX_APERTURE``, is not ``valid``."""
    half_extents = np.asarray(half_extents, dtype=np.float64)
    table = np.zeros(KEYS, GRASP)
    round_object = shape == "sphere"
    for key in range(1 if round_object else KEYS):
        frame = np.eye(3)
        flat = False
        if not round_object:
            up_axis, rest = divmod(key, 8)
            up_sign, slot, along_sign = (1.0 if rest >= 4 else -1.0), (rest % 4) // 2, (1.0 if rest % 2 else -1.0)
            others = [a for a in range(3) if a != up_axis]
            flat = bool(2 * half_extents[up_axis] <= FLAT_THICKNESS
                        and all(2 * half_extents[a] > 2.5 * FLAT_THICKNESS for a in others))
            narrow = min(half_extents[a] for a in others)
            if not flat and half_extents[others[slot]] > narrow + 1e-9:
                continue  # the choice never grips along a wider axis
            _grasp_frame(up_axis, up_sign, slot, along_sign, flat, frame)
            half = tuple(float(v) for v in np.abs(frame.T @ half_extents))
        else:
            half = (float(half_extents[0]),) * 3
        if not flat and 2 * half[2] > MAX_APERTURE:
            continue
        fingers = (1, 2, 3) if flat or max(half[0], half[2]) > 0.06 else (1, 2)
        if flat:
            centre, postures = flat_template(half, fingers)
            approach = np.array([0.0, 0.0, FLAT_APPROACH])
        else:
            centre, postures = side_template(half, fingers, round_object)
            approach = np.array([0.0, 0.05, 0.0])
        if side == "left":
            centre = centre * np.array([-1.0, 1.0, 1.0])
        table[key] = (True, flat, len(fingers), frame, quat_from_matrix(frame), centre, approach, postures)
    return table


def plan_grasp(shape: str, half_extents: np.ndarray, orientation: np.ndarray, side: str = "right") -> GraspTemplate:
    """The grasp for an object of ``shape`` ("box", "sphere" or "mesh", gripped as its box) in its
    current orientation (``choose_grasp``); ValueError when the grip would be wider than the hand."""
    half_extents = tuple(float(v) for v in np.asarray(half_extents, dtype=np.float64))
    frame = np.empty((3, 3))
    key = choose_grasp(shape == "sphere", np.asarray(half_extents), np.asarray(orientation, dtype=np.float64), frame,
                       TOWARD_USER, False)
    grasp = grasps(shape, half_extents, side)[key]
    if not grasp["valid"]:
        raise ValueError(f"plan_grasp: the {shape} of half extents {half_extents} is wider across the grip than "
                         f"{MAX_APERTURE} m in this orientation")
    fingers = tuple(range(1, 1 + int(grasp["fingers"])))
    return GraspTemplate("flat" if grasp["flat"] else "side", (0, *fingers), frame, grasp["object_in_hand"].copy(),
                         grasp["approach"].copy(), grasp["postures"].copy())
