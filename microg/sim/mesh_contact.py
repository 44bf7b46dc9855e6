"""The contact geometry of mesh objects: the box's kernels (``contact``) on a union of convex parts.

A mesh object is a union of convex polytopes (``mesh``), each given by its faces: a face plane
n . x = d (n outward) and the face's boundary edges, each with its in-plane outward normal m. The
kernels take the scene's ``MESH`` (``state.unpack_mesh``) and the object's index ``o``; body-frame
points are tuples (``vec``).

- Closest point and signed distance: per part, a point inside (n . x <= d for every face) is
  -min(d - n . x) deep and its closest surface point is its projection on that nearest face
  plane; a point outside is as far as the nearest of the faces it is above (n . x > d), the
  distance to a face being the distance to its polygon. Over the parts, the smallest signed
  distance wins.
- The normal of a mesh contact is always a face's normal: outside an edge or a corner, that of
  the face the point is most above (the box's kernels return the direction to the edge there;
  both pick the same face for ``over_face``). So every mesh contact lies in one face plane, and
  the plane, with every coplanar face of the object, is what the contact is kept on.
- Over the face: p is over the contact's face while it is over one of the coplanar faces grown by
  rho across each edge (m . (p - a) <= rho for each edge from a): for a box face, the rectangle
  grown by rho, as the box's kernel has it. Coplanar faces of different parts make one face, so a
  phalanx sliding over the seam between two parts keeps its contact.
"""

from __future__ import annotations

import math

from .mesh import COPLANAR
from .vec import add, dot, kernel, norm, scale, sub

EDGE_TOLERANCE = 1e-9
"""m: an anchor this close to a face's edge is held at it (``mesh_along_face``)."""


@kernel
def _plane(m, f):
    return (m.planes[f, 0], m.planes[f, 1], m.planes[f, 2]), m.planes[f, 3]


@kernel
def _edge(m, e):
    """An edge's start, end and in-plane outward normal."""
    r = m.edges[e]
    return (r[0], r[1], r[2]), (r[3], r[4], r[5]), (r[6], r[7], r[8])


@kernel
def _beyond_edges(m, f, x):
    """How far in-plane point x lies beyond the face's edges: max over edges of m . (x - a)
    (<= 0 inside the face's polygon)."""
    beyond = -math.inf
    for e in range(m.face_edges[f, 0], m.face_edges[f, 1]):
        start, _, outward = _edge(m, e)
        beyond = max(beyond, dot(outward, sub(x, start)))
    return beyond


@kernel
def _closest_on_segment(a, b, x):
    ab = sub(b, a)
    length2 = dot(ab, ab)
    t = min(max(dot(sub(x, a), ab) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
    return add(a, scale(t, ab))


@kernel
def _closest_in_polygon(m, f, x):
    """The point of face f's polygon closest to a point x in its plane."""
    if _beyond_edges(m, f, x) <= 0.0:
        return x
    best, best_distance = x, math.inf
    for e in range(m.face_edges[f, 0], m.face_edges[f, 1]):
        start, end, _ = _edge(m, e)
        point = _closest_on_segment(start, end, x)
        distance = norm(sub(x, point))
        if distance < best_distance:
            best, best_distance = point, distance
    return best


@kernel
def mesh_closest_point(m, o, p):
    """Closest surface point to body-frame point p, the face normal there, and p's signed distance
    (negative inside), over the parts of object o (module docstring)."""
    best_point, best_normal, best_distance, best_height = p, (0.0, 1.0, 0.0), math.inf, -math.inf
    for part in range(m.object_parts[o, 0], m.object_parts[o, 1]):
        first, stop = m.part_faces[part, 0], m.part_faces[part, 1]
        nearest, nearest_height = first, -math.inf
        for f in range(first, stop):
            normal, offset = _plane(m, f)
            height = dot(normal, p) - offset
            if height > nearest_height:
                nearest, nearest_height = f, height
        if nearest_height <= 0.0:  # inside this part: out through the nearest face plane
            if nearest_height < best_distance:
                normal, _ = _plane(m, nearest)
                best_point, best_normal = sub(p, scale(nearest_height, normal)), normal
                best_distance, best_height = nearest_height, nearest_height
            continue
        for f in range(first, stop):
            normal, offset = _plane(m, f)
            height = dot(normal, p) - offset
            if height <= 0.0 or height > best_distance:
                continue
            point = _closest_in_polygon(m, f, sub(p, scale(height, normal)))
            distance = norm(sub(p, point))
            if distance < best_distance - 1e-15 or (distance <= best_distance + 1e-15 and height > best_height):
                best_point, best_normal, best_distance, best_height = point, normal, distance, height
    return best_point, best_normal, best_distance


@kernel
def _coplanar(m, f, normal, offset):
    """Face f lies in the plane n . x = offset."""
    n, d = _plane(m, f)
    return (abs(n[0] - normal[0]) <= COPLANAR and abs(n[1] - normal[1]) <= COPLANAR
            and abs(n[2] - normal[2]) <= COPLANAR and abs(d - offset) <= COPLANAR)


@kernel
def _inside(m, o, x):
    """Point x lies inside one of object o's parts."""
    for part in range(m.object_parts[o, 0], m.object_parts[o, 1]):
        height = -math.inf
        for f in range(m.part_faces[part, 0], m.part_faces[part, 1]):
            normal, offset = _plane(m, f)
            height = max(height, dot(normal, x) - offset)
        if height < -COPLANAR:
            return True
    return False


@kernel
def mesh_over_face(m, o, p, anchor, normal, rho):
    """True while body-frame point p lies over the contact's face: over one of the faces of object
    o in the anchor's plane, each grown by rho across its edges, where the centre of the phalanx
    on the face (p's foot on the plane lifted by rho: its god-object) is inside no part. Where
    another part rises from the face (the other arm of an L), a phalanx pushed into it leaves the
    face's contact once its centre enters that part, and is found against that part's face
    (inside a part, its signed distance wins), instead of sliding on under it."""
    offset = dot(normal, anchor)
    for part in range(m.object_parts[o, 0], m.object_parts[o, 1]):
        for f in range(m.part_faces[part, 0], m.part_faces[part, 1]):
            if _coplanar(m, f, normal, offset) and _beyond_edges(m, f, p) <= rho:
                return not _inside(m, o, add(p, scale(rho - dot(normal, p) + offset, normal)))
    return False


@kernel
def mesh_project(m, o, point, normal):
    """Put a point moved along a contact's face plane back on the face: the closest point of the
    object's faces in that plane (the point itself where it lies on one)."""
    offset = dot(normal, point)
    best, best_distance = point, math.inf
    for part in range(m.object_parts[o, 0], m.object_parts[o, 1]):
        for f in range(m.part_faces[part, 0], m.part_faces[part, 1]):
            if not _coplanar(m, f, normal, offset):
                continue
            candidate = _closest_in_polygon(m, f, point)
            distance = norm(sub(candidate, point))
            if distance < best_distance:
                best, best_distance = candidate, distance
    return best, normal


@kernel
def mesh_along_face(m, o, anchor, normal, tangential):
    """The part of a sliding contact's tangential offset that friction can act on (``penetration.
    along_face``): without its pull across an edge of the object (not a seam) the anchor is held at."""
    offset = dot(normal, anchor)
    result = tangential
    for part in range(m.object_parts[o, 0], m.object_parts[o, 1]):
        for f in range(m.part_faces[part, 0], m.part_faces[part, 1]):
            if not _coplanar(m, f, normal, offset) or _beyond_edges(m, f, anchor) > EDGE_TOLERANCE:
                continue
            for e in range(m.face_edges[f, 0], m.face_edges[f, 1]):
                start, _, outward = _edge(m, e)
                held = m.edges[e, 9] == 0.0 and dot(outward, sub(anchor, start)) >= -EDGE_TOLERANCE
                if held and dot(outward, tangential) < 0.0:
                    result = sub(result, scale(dot(outward, result), outward))
            return result
    return result


@kernel
def mesh_segment_entry(m, o, start, end, rho):
    """First parameter t in [0, 1] where the segment start->end enters object o grown by rho (each
    part's face planes moved out by rho, as the box's slab test has it), with the entry face's
    normal; t = -1 when it does not enter a part from outside."""
    direction = sub(end, start)
    best_t, best_normal = -1.0, (0.0, 0.0, 0.0)
    for part in range(m.object_parts[o, 0], m.object_parts[o, 1]):
        t_enter, t_exit, entry_face = 0.0, 1.0, -1
        for f in range(m.part_faces[part, 0], m.part_faces[part, 1]):
            normal, offset = _plane(m, f)
            room = offset + rho - dot(normal, start)
            approach = dot(normal, direction)
            if abs(approach) < 1e-15:
                if room < 0.0:
                    t_enter, t_exit = 1.0, 0.0
                    break
                continue
            t = room / approach
            if approach < 0.0:
                if t > t_enter:
                    t_enter, entry_face = t, f
            else:
                t_exit = min(t_exit, t)
            if t_enter > t_exit:
                break
        if entry_face >= 0 and t_enter <= t_exit and (best_t < 0.0 or t_enter < best_t):
            best_t, best_normal = t_enter, _plane(m, entry_face)[0]
    return best_t, best_normal
