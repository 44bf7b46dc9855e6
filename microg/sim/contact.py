"""Phalanx-object contacts (paper, Eqs. 2-8) and the god-object proxies (section 3.3).

Each phalanx is a sphere (centre p, radius rho). Against each object it has a contact while the
sphere is *engaged*: it began when the sphere first overlapped the object (or, with continuous
collision, when its path crossed the surface), and it lasts while the sphere stays below the
tangent plane at the contact's anchor and over the face it pressed on.

The anchor is the god-object: a point on the object's surface, stored in the object's body frame
(Eq. 3-4), so it moves with the object. It is where the rendered phalanx touches; the penetration
phase slides it along the surface only when friction lets go. The rendered phalanx centre is the
anchor lifted by rho along the outward normal.

A phalanx that appears inside an object (first frame of a track, after a dropout or a jump) had
no path from outside, so it would be pushed out with a force no hand motion produced. Such a pair
is a *ghost*: it exerts nothing until the sphere has left that object once.

Sign convention (Eq. 8): n is the object's outward normal, body 1 the hand, body 2 the object,
v = n . (c1_dot - c2_dot); v > 0 separating, |v| <= tolerance resting, v < 0 colliding.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .bodies import BOX
from .rotation import cross, quat_to_matrix

SEPARATING, RESTING, COLLIDING = 1, 0, -1


@njit(cache=True)
def classify(normal_velocity, tolerance):
    """Eq. 8's three cases, with resting inside +-tolerance (m/s)."""
    if normal_velocity > tolerance:
        return SEPARATING
    if normal_velocity < -tolerance:
        return COLLIDING
    return RESTING


@njit(cache=True)
def closest_surface_point(shape, half_size, p):
    """Closest surface point to body-frame point p, the outward normal there, and p's signed
    distance from the surface (negative inside)."""
    point = np.empty(3)
    normal = np.zeros(3)
    if shape == BOX:
        outside = np.empty(3)
        for i in range(3):
            point[i] = min(max(p[i], -half_size[i]), half_size[i])
            outside[i] = p[i] - point[i]
        distance = np.sqrt(outside[0] ** 2 + outside[1] ** 2 + outside[2] ** 2)
        if distance > 0.0:
            return point, outside / distance, distance
        axis = 0
        gap = half_size[0] - abs(p[0])
        for i in range(1, 3):
            if half_size[i] - abs(p[i]) < gap:
                axis, gap = i, half_size[i] - abs(p[i])
        normal[axis] = 1.0 if p[axis] >= 0.0 else -1.0
        point[:] = p
        point[axis] = normal[axis] * half_size[axis]
        return point, normal, -gap
    radius = half_size[0]
    distance = np.sqrt(p[0] ** 2 + p[1] ** 2 + p[2] ** 2)
    if distance > 0.0:
        normal[:] = p / distance
    else:
        normal[1] = 1.0
    return radius * normal, normal, distance - radius


@njit(cache=True)
def over_face(shape, half_size, p, normal, rho):
    """True while body-frame point p lies over the face whose outward normal is ``normal``
    (box: within the face rectangle grown by rho; sphere: within its silhouette disc)."""
    if shape == BOX:
        axis = 0
        for i in range(1, 3):
            if abs(normal[i]) > abs(normal[axis]):
                axis = i
        for i in range(3):
            if i != axis and abs(p[i]) > half_size[i] + rho:
                return False
        return True
    along = p[0] * normal[0] + p[1] * normal[1] + p[2] * normal[2]
    lateral = p - along * normal
    return np.sqrt(lateral[0] ** 2 + lateral[1] ** 2 + lateral[2] ** 2) <= half_size[0] + rho


@njit(cache=True)
def project_to_surface(shape, half_size, point, normal):
    """Put a point moved along a face back on it: clamp to the face (box) or to the sphere."""
    if shape == BOX:
        out = np.empty(3)
        for i in range(3):
            out[i] = min(max(point[i], -half_size[i]), half_size[i])
        return out, normal
    length = np.sqrt(point[0] ** 2 + point[1] ** 2 + point[2] ** 2)
    unit = point / length
    return half_size[0] * unit, unit


@njit(cache=True)
def point_velocity(velocity, angular_velocity, r):
    """Velocity of a body-fixed point at offset r from the centre of mass (Eq. 7)."""
    return cross(angular_velocity, r) + velocity


@njit(cache=True)
def _detect(shape, half_size, position, orientation, velocity, angular_velocity,
            hand_position, hand_velocity, radius, valid, fresh, anchored,
            active, ghost, onset, anchor, normal, depth, normal_velocity):
    n_slots, n_objects = active.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        for k in range(n_slots):
            if not valid[k]:
                active[k, o] = False
                ghost[k, o] = False
                continue
            local = rot.T @ (hand_position[k] - position[o])
            rho = radius[k]
            if ghost[k, o]:
                _, _, distance = closest_surface_point(shape[o], half_size[o], local)
                ghost[k, o] = distance < rho
                continue
            if active[k, o] and anchored:
                c = anchor[k, o]
                nb = normal[k, o]
                delta = (c[0] - local[0]) * nb[0] + (c[1] - local[1]) * nb[1] + (c[2] - local[2]) * nb[2] + rho
                active[k, o] = delta > 0.0 and over_face(shape[o], half_size[o], local, nb, rho)
                depth[k, o] = delta if active[k, o] else 0.0
            else:
                point, surface_normal, distance = closest_surface_point(shape[o], half_size[o], local)
                overlap = distance < rho
                if overlap and fresh[k] and not active[k, o]:
                    ghost[k, o] = True
                    continue
                onset[k, o] = overlap and not active[k, o]
                active[k, o] = overlap
                depth[k, o] = rho - distance if overlap else 0.0
                if overlap:
                    anchor[k, o] = point
                    normal[k, o] = surface_normal
            if active[k, o]:
                normal_velocity[k, o] = _normal_velocity(rot, position[o], velocity[o], angular_velocity[o],
                                                         anchor[k, o], normal[k, o], hand_velocity[k])
            else:
                normal_velocity[k, o] = 0.0


@njit(cache=True)
def _normal_velocity(rot, position, velocity, angular_velocity, anchor, normal, hand_velocity):
    """Eq. 8 with the hand as body 1 (its contact point moves with the phalanx centre)."""
    r = rot @ anchor
    relative = hand_velocity - point_velocity(velocity, angular_velocity, r)
    n = rot @ normal
    return n[0] * relative[0] + n[1] * relative[1] + n[2] * relative[2]


def detect_contacts(model, data, h: float) -> None:
    """Start, keep or end each phalanx-object contact at the current poses (Eqs. 2-8)."""
    _detect(model.shape, model.half_size, data.position, data.orientation, data.velocity,
            data.angular_velocity, data.hand_position, data.hand_velocity, data.radius, data.valid,
            data.fresh, "soft_hand" not in model.effects, data.active, data.ghost, data.onset,
            data.anchor, data.normal, data.depth, data.normal_velocity)


@njit(cache=True)
def _segment_entry(shape, half_size, start, end, rho):
    """First parameter t in [0, 1] where the segment start->end enters the object grown by rho,
    with the entry face normal; t = -1 when it does not enter (slab test / ray-sphere)."""
    direction = end - start
    normal = np.zeros(3)
    if shape == BOX:
        t_enter, t_exit, axis = 0.0, 1.0, -1
        for i in range(3):
            bound = half_size[i] + rho
            if abs(direction[i]) < 1e-15:
                if abs(start[i]) > bound:
                    return -1.0, normal
                continue
            t1 = (-bound - start[i]) / direction[i]
            t2 = (bound - start[i]) / direction[i]
            if t1 > t2:
                t1, t2 = t2, t1
            if t1 > t_enter:
                t_enter, axis = t1, i
            t_exit = min(t_exit, t2)
            if t_enter > t_exit:
                return -1.0, normal
        if axis < 0:
            return -1.0, normal
        normal[axis] = -1.0 if direction[axis] > 0.0 else 1.0
        return t_enter, normal
    bound = half_size[0] + rho
    a = direction @ direction
    b = 2.0 * (start @ direction)
    c = start @ start - bound * bound
    disc = b * b - 4.0 * a * c
    if a < 1e-30 or disc < 0.0 or c < 0.0:
        return -1.0, normal
    t = (-b - np.sqrt(disc)) / (2.0 * a)
    if t < 0.0 or t > 1.0:
        return -1.0, normal
    hit = start + t * direction
    return t, hit / np.sqrt(hit @ hit)


@njit(cache=True)
def _sweep(shape, half_size, position, orientation, velocity, angular_velocity,
           hand_previous, hand_position, hand_velocity, radius, valid, fresh,
           active, ghost, onset, anchor, normal, depth, normal_velocity):
    n_slots, n_objects = active.shape
    for o in range(n_objects):
        rot = quat_to_matrix(orientation[o])
        for k in range(n_slots):
            if not valid[k] or fresh[k] or active[k, o] or ghost[k, o]:
                continue
            start = rot.T @ (hand_previous[k] - position[o])
            end = rot.T @ (hand_position[k] - position[o])
            t, face_normal = _segment_entry(shape[o], half_size[o], start, end, radius[k])
            if t < 0.0:
                continue
            entry = start + t * (end - start) - radius[k] * face_normal
            point, surface_normal = project_to_surface(shape[o], half_size[o], entry, face_normal)
            delta = radius[k] + ((point - end) @ surface_normal)
            if delta <= 0.0:
                continue
            active[k, o] = True
            onset[k, o] = True
            anchor[k, o] = point
            normal[k, o] = surface_normal
            depth[k, o] = delta
            normal_velocity[k, o] = _normal_velocity(rot, position[o], velocity[o], angular_velocity[o],
                                                     point, surface_normal, hand_velocity[k])


def sweep_contacts(model, data, h: float) -> None:
    """Continuous collision: a phalanx whose path this step entered an object from outside gets its
    contact where the path entered, on the face it crossed, whether the step ended inside the object
    or beyond it. Runs before ``detect_contacts``: for a thin plate hit fast, the closest face to
    the step's end point is the far face, which would let the finger through."""
    _sweep(model.shape, model.half_size, data.position, data.orientation, data.velocity,
           data.angular_velocity, data.hand_previous, data.hand_position, data.hand_velocity,
           data.radius, data.valid, data.fresh, data.active, data.ghost, data.onset, data.anchor,
           data.normal, data.depth, data.normal_velocity)
