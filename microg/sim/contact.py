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

The kernels work on one object ``o`` of a ``State`` (``state.unpack``) with its rotation matrix
``rot`` already computed; vectors are tuples (``vec``). ``mesh`` is the scene's mesh objects
(``state.unpack_mesh``), or None in a scene without any: then numba prunes the branches that
would call the mesh kernels (``mesh_contact``) before it compiles, and a box or a sphere takes
exactly the code it took before meshes existed.
"""

from __future__ import annotations

import math


from .bodies import BOX, MESH
from microg.skeleton import SLOTS
from .mesh_contact import mesh_closest_point, mesh_over_face, mesh_project, mesh_segment_entry
from .state import CLOCK_DRIFT
from .vec import (add, cell, cross, dot, kernel, mat_t_vec, mat_vec, norm, quat_mul, quat_turn, quat_unit, rotation,
                  row, scale, set_cell, sub)

SEPARATING, RESTING, COLLIDING = 1, 0, -1
REACH_SLACK = math.sqrt(3.0)
"""How far past an object's bounding radius, in phalanx radii, the object grown by a phalanx
reaches (a box's corner grown by rho along each axis: sqrt(3) rho)."""


@kernel
def classify(normal_velocity, tolerance):
    """Eq. 8's three cases, with resting inside +-tolerance (m/s)."""
    if normal_velocity > tolerance:
        return SEPARATING
    if normal_velocity < -tolerance:
        return COLLIDING
    return RESTING


@kernel
def _with(v, axis, value):
    """v with component ``axis`` replaced."""
    if axis == 0:
        return (value, v[1], v[2])
    if axis == 1:
        return (v[0], value, v[2])
    return (v[0], v[1], value)


@kernel
def closest_surface_point(shape, half_size, p):
    """Closest surface point to body-frame point p, the outward normal there, and p's signed
    distance from the surface (negative inside)."""
    if shape == BOX:
        point = (min(max(p[0], -half_size[0]), half_size[0]), min(max(p[1], -half_size[1]), half_size[1]),
                 min(max(p[2], -half_size[2]), half_size[2]))
        outside = sub(p, point)
        distance = norm(outside)
        if distance > 0.0:
            return point, (outside[0] / distance, outside[1] / distance, outside[2] / distance), distance
        axis = 0
        gap = half_size[0] - abs(p[0])
        for i in range(1, 3):
            if half_size[i] - abs(p[i]) < gap:
                axis, gap = i, half_size[i] - abs(p[i])
        sign = 1.0 if p[axis] >= 0.0 else -1.0
        return _with(p, axis, sign * half_size[axis]), _with((0.0, 0.0, 0.0), axis, sign), -gap
    radius = half_size[0]
    distance = norm(p)
    normal = (p[0] / distance, p[1] / distance, p[2] / distance) if distance > 0.0 else (0.0, 1.0, 0.0)
    return scale(radius, normal), normal, distance - radius


@kernel
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
    lateral = sub(p, scale(dot(p, normal), normal))
    return norm(lateral) <= half_size[0] + rho


@kernel
def project_to_surface(shape, half_size, point, normal):
    """Put a point moved along a face back on it: clamp to the face (box) or to the sphere."""
    if shape == BOX:
        return (min(max(point[0], -half_size[0]), half_size[0]), min(max(point[1], -half_size[1]), half_size[1]),
                min(max(point[2], -half_size[2]), half_size[2])), normal
    length = norm(point)
    unit = (point[0] / length, point[1] / length, point[2] / length)
    return scale(half_size[0], unit), unit


@kernel
def point_velocity(velocity, angular_velocity, r):
    """Velocity of a body-fixed point at offset r from the centre of mass (Eq. 7)."""
    return add(cross(angular_velocity, r), velocity)


@kernel
def normal_velocity(s, o, rot, k):
    """Eq. 8 for contact (k, o), the hand as body 1 (its contact point moves with the phalanx centre)."""
    r = mat_vec(rot, cell(s.anchor, k, o))
    relative = sub(row(s.hand_velocity, k), point_velocity(row(s.velocity, o), row(s.angular_velocity, o), r))
    return dot(mat_vec(rot, cell(s.normal, k, o)), relative)


@kernel
def surface_point(mesh, o, shape, half_size, p):
    """``closest_surface_point`` for object o, of any shape."""
    if mesh is not None and shape == MESH:
        return mesh_closest_point(mesh, o, p)
    return closest_surface_point(shape, half_size, p)


@kernel
def project_on_face(mesh, o, shape, half_size, point, normal):
    """``project_to_surface`` for object o, of any shape."""
    if mesh is not None and shape == MESH:
        return mesh_project(mesh, o, point, normal)
    return project_to_surface(shape, half_size, point, normal)


@kernel
def detect(p, s, o, rot, anchored, mesh):
    """Start, keep or end each phalanx's contact with object o at the current poses (Eqs. 2-8).

    A new overlap starts a contact at the closest surface point (an *onset*); an anchored contact
    (god-object models) lasts while the sphere is below the anchor's tangent plane and over its
    face. An unanchored one (the soft hand) has no god-object: its point is the one of its face
    under the phalanx, found again every step, and it lasts on the same terms, then is looked for
    afresh (a finger that slid onto another face). Kept on the face it entered, a phalanx that a
    coarse step takes past the middle of a thin plate still pushes it back, not on through its far
    face. A fresh phalanx found inside becomes a ghost."""
    shape, half_size = p.shape[o], row(p.half_size, o)
    position = row(s.position, o)
    valid, fresh, radius, hand = s.valid, s.fresh, s.radius, s.hand_position
    active, ghost, onset, depth, anchor, normal = s.active, s.ghost, s.onset, s.depth, s.anchor, s.normal
    for k in range(SLOTS):
        if not valid[k]:
            active[k, o] = False
            ghost[k, o] = False
            continue
        local = mat_t_vec(rot, sub(row(hand, k), position))
        rho = radius[k]
        if ghost[k, o]:
            ghost[k, o] = surface_point(mesh, o, shape, half_size, local)[2] < rho
            continue
        was = active[k, o]
        if was and not anchored:  # the soft hand presses on the face it entered, at the point under the phalanx
            under = add(local, scale(dot(sub(cell(anchor, k, o), local), cell(normal, k, o)), cell(normal, k, o)))
            point, surface_normal = project_on_face(mesh, o, shape, half_size, under, cell(normal, k, o))
            set_cell(anchor, k, o, point)
            set_cell(normal, k, o, surface_normal)
        if was:
            delta = dot(sub(cell(anchor, k, o), local), cell(normal, k, o)) + rho
            beyond = rho if anchored else 0.0  # a god-object rests on its face's edge; a soft hand presses the edge
            if delta <= 0.0:
                active[k, o] = False
            elif mesh is not None and shape == MESH:
                active[k, o] = mesh_over_face(mesh, o, local, cell(anchor, k, o), cell(normal, k, o), beyond)
            else:
                active[k, o] = over_face(shape, half_size, local, cell(normal, k, o), beyond)
            depth[k, o] = delta if active[k, o] else 0.0
        if not was or not (anchored or active[k, o]):  # a new contact, or the soft hand's off its face
            point, surface_normal, distance = surface_point(mesh, o, shape, half_size, local)
            overlap = distance < rho
            if overlap and fresh[k] and not was:
                ghost[k, o] = True
                continue
            onset[k, o] = overlap and not was
            active[k, o] = overlap
            depth[k, o] = rho - distance if overlap else 0.0
            if overlap:
                set_cell(anchor, k, o, point)
                set_cell(normal, k, o, surface_normal)
        s.normal_velocity[k, o] = normal_velocity(s, o, rot, k) if active[k, o] else 0.0


@kernel
def hand_reach(s):
    """The box (its low and high corners) that holds every tracked phalanx's centre at the end of
    this step and of the step before, the largest phalanx radius (NaN where a centre is not
    finite: then no object is out of reach) and how many phalanges are tracked: what the broad
    phase (``out_of_reach``) tests each object against."""
    low, high = (math.inf, math.inf, math.inf), (-math.inf, -math.inf, -math.inf)
    rho, total, tracked = 0.0, 0.0, 0
    for k in range(SLOTS):
        if not s.valid[k]:
            continue
        tracked += 1
        rho = max(rho, s.radius[k])
        now, before = row(s.hand_position, k), row(s.hand_previous, k)
        total += now[0] + now[1] + now[2] + before[0] + before[1] + before[2]
        low = (min(low[0], now[0], before[0]), min(low[1], now[1], before[1]), min(low[2], now[2], before[2]))
        high = (max(high[0], now[0], before[0]), max(high[1], now[1], before[1]), max(high[2], now[2], before[2]))
    return low, high, rho if math.isfinite(total) else math.nan, tracked


@kernel
def out_of_reach(p, s, o, reach):
    """The broad phase: True when object o (a box or a sphere) has no contact and no phalanx's path
    this step can come within its radius of it, so that ``sweep`` and ``detect`` would find
    nothing (``apart`` does what ``detect`` does then).

    Every point of a path ``sweep`` tests, put back in the world at the object's present pose, lies
    within h |v| + h |omega| (|hand a step ago - centre| + h |v|) of the segment between the
    phalanx's two centres (the object turns back by at most h |omega|), so within that of the
    ``hand_reach`` box; the object grown by a phalanx's radius rho lies within |half size| +
    sqrt(3) rho of its centre (a box's slab test grows it by rho along each axis; a sphere's
    radius + rho is less). A mesh's parts grown face by face reach further at sharp corners: a
    mesh is always looked at."""
    if p.shape[o] == MESH:
        return False
    for k in range(SLOTS):
        if s.active[k, o]:
            return False
    low, high, rho, tracked = reach
    if tracked == 0:
        return True
    x = row(s.position, o)
    nearest = (max(low[0] - x[0], 0.0, x[0] - high[0]), max(low[1] - x[1], 0.0, x[1] - high[1]),
               max(low[2] - x[2], 0.0, x[2] - high[2]))
    farthest = norm((max(abs(x[0] - low[0]), abs(x[0] - high[0])), max(abs(x[1] - low[1]), abs(x[1] - high[1])),
                     max(abs(x[2] - low[2]), abs(x[2] - high[2]))))
    h = s.clock[CLOCK_DRIFT]
    drift = h * norm(row(s.velocity, o))
    carried = drift + h * norm(row(s.angular_velocity, o)) * (farthest + drift)
    radius = norm(row(p.half_size, o)) if p.shape[o] == BOX else p.half_size[o, 0]
    return norm(nearest) - carried > radius + REACH_SLACK * rho + 1e-9 * (1.0 + farthest)


@kernel
def apart(s, o):
    """What ``detect`` finds of object o, in contact with no phalanx, when no phalanx is near it:
    still no contact, no onset, and a ghost phalanx has left it."""
    valid, ghost, onset, active, depth, normal_velocity = s.valid, s.ghost, s.onset, s.active, s.depth, \
        s.normal_velocity
    for k in range(SLOTS):
        looked_at = valid[k] and not ghost[k, o]
        active[k, o] = False
        ghost[k, o] = False
        if looked_at:
            onset[k, o] = False
            depth[k, o] = 0.0
            normal_velocity[k, o] = 0.0


@kernel
def segment_entry(shape, half_size, start, end, rho):
    """First parameter t in [0, 1] where the segment start->end enters the object grown by rho,
    with the entry face normal; t = -1 when it does not enter (slab test / ray-sphere)."""
    direction = sub(end, start)
    if shape == BOX:
        t_enter, t_exit, axis = 0.0, 1.0, -1
        for i in range(3):
            bound = half_size[i] + rho
            if abs(direction[i]) < 1e-15:
                if abs(start[i]) > bound:
                    return -1.0, (0.0, 0.0, 0.0)
                continue
            t1 = (-bound - start[i]) / direction[i]
            t2 = (bound - start[i]) / direction[i]
            if t1 > t2:
                t1, t2 = t2, t1
            if t1 > t_enter:
                t_enter, axis = t1, i
            t_exit = min(t_exit, t2)
            if t_enter > t_exit:
                return -1.0, (0.0, 0.0, 0.0)
        if axis < 0:
            return -1.0, (0.0, 0.0, 0.0)
        return t_enter, _with((0.0, 0.0, 0.0), axis, -1.0 if direction[axis] > 0.0 else 1.0)
    bound = half_size[0] + rho
    a = dot(direction, direction)
    b = 2.0 * dot(start, direction)
    c = dot(start, start) - bound * bound
    disc = b * b - 4.0 * a * c
    if a < 1e-30 or disc < 0.0 or c < 0.0:
        return -1.0, (0.0, 0.0, 0.0)
    t = (-b - math.sqrt(disc)) / (2.0 * a)
    if t < 0.0 or t > 1.0:
        return -1.0, (0.0, 0.0, 0.0)
    hit = add(start, scale(t, direction))
    length = norm(hit)
    return t, (hit[0] / length, hit[1] / length, hit[2] / length)


@kernel
def sweep(p, s, o, rot, mesh):
    """Continuous collision: a phalanx whose path this step entered object o from outside gets its
    contact where the path entered, on the face it crossed, whether the step ended inside the
    object or beyond it. Runs before ``detect``: for a thin plate hit fast, the closest face to the
    step's end point is the far face, which would let the finger through.

    The path is the phalanx's relative to the object, in the object's body frame: from where it
    was a step ago, against the object where its velocities brought it from (moved back by h v and
    turned back by h omega, h the step, or part of one, it last drifted over), to where it is now. A still fingertip that a fast plate runs into is
    crossed by the plate's motion, not its own: swept in the object's present pose only, it would
    be found past the plate's middle and get its contact on the far face, which pushes the plate
    on instead of stopping it."""
    shape, half_size = p.shape[o], row(p.half_size, o)
    position = row(s.position, o)
    velocity, angular_velocity, h = row(s.velocity, o), row(s.angular_velocity, o), s.clock[CLOCK_DRIFT]
    before = sub(position, scale(h, velocity))
    q = s.orientation[o]
    rot_before = rotation(quat_unit(quat_mul(quat_turn(scale(-h, angular_velocity)), (q[0], q[1], q[2], q[3]))))
    valid, fresh, active, ghost = s.valid, s.fresh, s.active, s.ghost
    for k in range(SLOTS):
        if not valid[k] or fresh[k] or active[k, o] or ghost[k, o]:
            continue
        rho = s.radius[k]
        start = mat_t_vec(rot_before, sub(row(s.hand_previous, k), before))
        end = mat_t_vec(rot, sub(row(s.hand_position, k), position))
        if start == end:
            continue
        if mesh is not None and shape == MESH:
            t, face_normal = mesh_segment_entry(mesh, o, start, end, rho)
        else:
            t, face_normal = segment_entry(shape, half_size, start, end, rho)
        if t < 0.0:
            continue
        entry = sub(add(start, scale(t, sub(end, start))), scale(rho, face_normal))
        point, surface_normal = project_on_face(mesh, o, shape, half_size, entry, face_normal)
        delta = rho + dot(sub(point, end), surface_normal)
        if delta <= 0.0:
            continue
        active[k, o] = True
        s.onset[k, o] = True
        set_cell(s.anchor, k, o, point)
        set_cell(s.normal, k, o, surface_normal)
        s.depth[k, o] = delta
        s.normal_velocity[k, o] = normal_velocity(s, o, rot, k)
