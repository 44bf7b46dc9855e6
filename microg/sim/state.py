"""The world's changing state as three flat buffers, and the named views the physics reads.

Everything that changes while a world runs lives in three arrays: ``reals`` (float64), ``flags``
(bool) and ``counts`` (int64). Copying a world's state is three ``memcpy``s, a batch of worlds is
the same three arrays with a leading world axis, and a compiled call takes three arguments
whatever the scene. The named fields (``position``, ``active``, ...) are views into them, laid out
in ``FIELDS`` order: ``layout`` gives Python their place, ``unpack`` gives the compiled kernels
the same views as a ``STATE`` StructRef (tests check that the two agree).

Shapes: N objects, K = 40 phalanx slots (``hand.SLOTS``); contact arrays are (K, N, ...), anchors
and normals in the object's body frame.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import types
from numba.experimental import structref

from microg.skeleton import SLOTS
from .vec import kernel

CLOCK_TIME, CLOCK_START, CLOCK_FRAME, CLOCK_PREVIOUS_FRAME, CLOCK_DRIFT = 0, 1, 2, 3, 4
"""Indices into ``clock``: simulated time, time of the first frame, of this frame, of the frame before,
and the length of the last physics step (or part of one) the objects drifted over (0 before the
first): the sweep takes the objects back by it (s). ``clock`` opens ``reals``, so these index the
buffer too."""
COUNT_STEPS, COUNT_FRAMES = 0, 1
"""Indices into ``counter``: physics steps taken, hand frames taken; ``counter`` opens ``counts``."""
POINTS = 26
"""A hand's palm and 25 joints: what a frame gives the physics per side (``world.HandFrames``)."""

REALS, FLAGS, COUNTS = 0, 1, 2
FIELDS: tuple[tuple[str, int, tuple], ...] = (
    ("clock", REALS, (5,)),
    ("position", REALS, ("N", 3)),
    ("orientation", REALS, ("N", 4)),
    ("velocity", REALS, ("N", 3)),
    ("angular_velocity", REALS, ("N", 3)),
    ("hand_position", REALS, ("K", 3)),
    ("hand_previous", REALS, ("K", 3)),
    ("hand_from", REALS, ("K", 3)),
    ("hand_to", REALS, ("K", 3)),
    ("hand_velocity", REALS, ("K", 3)),
    ("radius", REALS, ("K",)),
    ("anchor", REALS, ("K", "N", 3)),
    ("normal", REALS, ("K", "N", 3)),
    ("depth", REALS, ("K", "N")),
    ("normal_velocity", REALS, ("K", "N")),
    ("impulse", REALS, ("K", "N")),
    ("valid", FLAGS, ("K",)),
    ("fresh", FLAGS, ("K",)),
    ("present", FLAGS, (2,)),
    ("active", FLAGS, ("K", "N")),
    ("ghost", FLAGS, ("K", "N")),
    ("onset", FLAGS, ("K", "N")),
    ("sliding", FLAGS, ("K", "N")),
    ("counter", COUNTS, (2,)),
    ("track_id", COUNTS, (2,)),
)
"""Every field of the state: name, buffer, shape (N: objects, K: phalanx slots)."""

@structref.register
class StructType(types.StructRef):
    """Named fields passed by reference (a numba StructRef): what the kernels get as the state and the
    model's numbers. A kernel's signature is one pointer however many fields there are; a named tuple
    of 26 arrays would be passed, and compiled, field by field (it made the step three times slower
    to compile)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


def _array(dtype, ndim: int):
    return types.Array(dtype, ndim, "C")


STATE = StructType([(name, _array({REALS: types.float64, FLAGS: types.bool_, COUNTS: types.int64}[buffer],
                                  len(shape))) for name, buffer, shape in FIELDS])


@lru_cache(maxsize=None)
def layout(n_objects: int) -> tuple[dict[str, tuple[int, int, int, tuple[int, ...]]], tuple[int, int, int]]:
    """Where each field lives for ``n_objects`` objects: name -> (buffer, start, stop, shape), and
    the three buffer sizes."""
    sizes = [0, 0, 0]
    places = {}
    for name, buffer, template in FIELDS:
        shape = tuple(n_objects if d == "N" else SLOTS if d == "K" else d for d in template)
        size = int(np.prod(shape))
        places[name] = (buffer, sizes[buffer], sizes[buffer] + size, shape)
        sizes[buffer] += size
    return places, (sizes[0], sizes[1], sizes[2])


def empty_buffers(n_objects: int, worlds: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zeroed buffers for one world (1-D) or ``worlds`` worlds (2-D, world axis first)."""
    _, sizes = layout(n_objects)
    lead = () if worlds is None else (worlds,)
    return (np.zeros(lead + (sizes[0],)), np.zeros(lead + (sizes[1],), dtype=np.bool_),
            np.zeros(lead + (sizes[2],), dtype=np.int64))


def view(buffers, n_objects: int, name: str) -> np.ndarray:
    """The named field of one world's buffers (a view: writing to it writes the state)."""
    buffer, start, stop, shape = layout(n_objects)[0][name]
    return buffers[buffer][start:stop].reshape(shape)


@kernel
def unpack(reals, flags, counts, n):
    """One world's buffers as a ``STATE`` of views, in ``FIELDS`` order."""
    k = SLOTS
    s = structref.new(STATE)
    r = 0
    s.clock = reals[r:r + 5]
    r += 5
    s.position = reals[r:r + 3 * n].reshape((n, 3))
    r += 3 * n
    s.orientation = reals[r:r + 4 * n].reshape((n, 4))
    r += 4 * n
    s.velocity = reals[r:r + 3 * n].reshape((n, 3))
    r += 3 * n
    s.angular_velocity = reals[r:r + 3 * n].reshape((n, 3))
    r += 3 * n
    s.hand_position = reals[r:r + 3 * k].reshape((k, 3))
    r += 3 * k
    s.hand_previous = reals[r:r + 3 * k].reshape((k, 3))
    r += 3 * k
    s.hand_from = reals[r:r + 3 * k].reshape((k, 3))
    r += 3 * k
    s.hand_to = reals[r:r + 3 * k].reshape((k, 3))
    r += 3 * k
    s.hand_velocity = reals[r:r + 3 * k].reshape((k, 3))
    r += 3 * k
    s.radius = reals[r:r + k]
    r += k
    s.anchor = reals[r:r + 3 * k * n].reshape((k, n, 3))
    r += 3 * k * n
    s.normal = reals[r:r + 3 * k * n].reshape((k, n, 3))
    r += 3 * k * n
    s.depth = reals[r:r + k * n].reshape((k, n))
    r += k * n
    s.normal_velocity = reals[r:r + k * n].reshape((k, n))
    r += k * n
    s.impulse = reals[r:r + k * n].reshape((k, n))
    f = 0
    s.valid = flags[f:f + k]
    f += k
    s.fresh = flags[f:f + k]
    f += k
    s.present = flags[f:f + 2]
    f += 2
    s.active = flags[f:f + k * n].reshape((k, n))
    f += k * n
    s.ghost = flags[f:f + k * n].reshape((k, n))
    f += k * n
    s.onset = flags[f:f + k * n].reshape((k, n))
    f += k * n
    s.sliding = flags[f:f + k * n].reshape((k, n))
    s.counter = counts[0:2]
    s.track_id = counts[2:4]
    return s


PARAMS = StructType([(name, _array(types.int64 if name == "shape" else types.float64,
                                  2 if name in ("half_size", "inertia") else 1))
                    for name in ("shape", "half_size", "mass", "inertia", "restitution", "static_friction",
                                 "dynamic_friction", "gravity")]
                   + [(name, types.float64) for name in (
                       "penetration_stiffness", "resting_tolerance", "dt", "soft_stiffness",
                       "soft_damping", "soft_slip_velocity", "table_height", "table_stiffness", "table_damping",
                       "table_slip_velocity")] + [("angular_method", types.int64)])
"""What the kernels read of the model (``world.Model``): per-object arrays, then scalars."""
PARAMS_PER_OBJECT = 10
"""Reals per object in the model buffer: half size (3), mass, inertia (3), restitution, mu, phi."""
SCALARS = ("penetration_stiffness", "resting_tolerance", "dt", "soft_stiffness", "soft_damping",
           "soft_slip_velocity", "table_height", "table_stiffness", "table_damping", "table_slip_velocity")
"""The model buffer's scalars after gravity, in order."""
SCALAR_COUNT = len(SCALARS)


def pack_params(shape, half_size, mass, inertia, restitution, static_friction, dynamic_friction, gravity,
                scalars: dict[str, float], angular_method: int, meshes=None) -> tuple[np.ndarray, np.ndarray]:
    """The model's numbers as two buffers (reals, ints) for ``unpack_params``; ``meshes``, the
    (reals, ints) of ``mesh.pack_meshes``, follow as the buffers' tails (``unpack_mesh``)."""
    mesh_reals, mesh_ints = meshes if meshes is not None else ([], [])
    reals = np.concatenate([np.ravel(half_size), mass, np.ravel(inertia), restitution, static_friction,
                            dynamic_friction, gravity, [float(scalars[name]) for name in SCALARS],
                            mesh_reals]).astype(np.float64)
    ints = np.concatenate([[len(shape), angular_method], shape, mesh_ints]).astype(np.int64)
    return reals, ints


@kernel
def unpack_params(reals, ints, n):
    """The model buffers as ``PARAMS`` (arrays are views; layout of ``pack_params``)."""
    p = structref.new(PARAMS)
    p.shape = ints[2:2 + n]
    p.half_size = reals[:3 * n].reshape((n, 3))
    p.mass = reals[3 * n:4 * n]
    p.inertia = reals[4 * n:7 * n].reshape((n, 3))
    p.restitution = reals[7 * n:8 * n]
    p.static_friction = reals[8 * n:9 * n]
    p.dynamic_friction = reals[9 * n:10 * n]
    p.gravity = reals[10 * n:10 * n + 3]
    g = reals[10 * n + 3:]
    p.penetration_stiffness, p.resting_tolerance, p.dt = g[0], g[1], g[2]
    p.soft_stiffness, p.soft_damping, p.soft_slip_velocity = g[3], g[4], g[5]
    p.table_height, p.table_stiffness, p.table_damping, p.table_slip_velocity = g[6], g[7], g[8], g[9]
    p.angular_method = ints[1]
    return p


MESH = StructType([(name, _array(types.int64, 2)) for name in ("object_parts", "object_corners", "part_faces",
                                                               "face_edges")]
                  + [(name, _array(types.float64, 2)) for name in ("planes", "edges", "corners")])
"""The convex parts of a scene's mesh objects (``mesh.pack_meshes``): [first, stop) ranges per
object (its parts, its corners), per part (its faces) and per face (its edges); the face planes
(n, d), the edges (start, end, in-plane outward normal m, seam flag) and the corners."""


@kernel
def unpack_mesh(reals, ints, n):
    """The tails of the model buffers as ``MESH`` (views; layout of ``mesh.pack_meshes``)."""
    m = structref.new(MESH)
    i = 2 + n
    parts, faces, edges, corners = ints[i], ints[i + 1], ints[i + 2], ints[i + 3]
    i += 4
    m.object_parts = ints[i:i + 2 * n].reshape((n, 2))
    i += 2 * n
    m.object_corners = ints[i:i + 2 * n].reshape((n, 2))
    i += 2 * n
    m.part_faces = ints[i:i + 2 * parts].reshape((parts, 2))
    i += 2 * parts
    m.face_edges = ints[i:i + 2 * faces].reshape((faces, 2))
    r = 10 * n + 3 + SCALAR_COUNT
    m.planes = reals[r:r + 4 * faces].reshape((faces, 4))
    r += 4 * faces
    m.edges = reals[r:r + 10 * edges].reshape((edges, 10))
    r += 10 * edges
    m.corners = reals[r:r + 3 * corners].reshape((corners, 3))
    return m
