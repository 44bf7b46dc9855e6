"""The world's changing state and the model's numbers as flat buffers, and the named views the
physics reads.

Everything that changes while a world runs lives in three arrays: ``reals`` (float64), ``flags``
(bool) and ``counts`` (int64). Copying a world's state is three ``memcpy``s, a batch of worlds is
the same three arrays with a leading world axis, and a compiled call takes three arguments
whatever the scene. The model's numbers (``world.Model``) are two more, ``reals`` and ``ints``.

Each buffer's contents are declared once: ``FIELDS`` for the state, ``PARAMETERS`` for the model
(name, buffer, shape; a parameter also says where ``make_model`` takes it from). ``places`` lays a
declaration out, field after field, as ``Place``s; Python reads a field through them (``view``,
``parameter``), and the compiled kernels that give the physics its named views (``unpack``,
``unpack_params``) are made from them (``views``): no offset is written by hand, and a new field
or parameter is one line of its declaration (and its use).

Shapes: N objects, K = 40 phalanx slots (``hand.SLOTS``); contact arrays are (K, N, ...), anchors
and normals in the object's body frame.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Callable

import numpy as np
from numba import types
from numba.experimental import structref

from microg.skeleton import POINTS
from .bodies import SHAPES
from .compiled import StructType, array_type, kernel, places, tail, views, where
from .scene import ANGULAR_INTEGRATORS

CLOCK_TIME, CLOCK_START, CLOCK_FRAME, CLOCK_PREVIOUS_FRAME, CLOCK_DRIFT = 0, 1, 2, 3, 4
"""Indices into ``clock``: simulated time, time of the first frame, of this frame, of the frame before,
and the length of the last physics step (or part of one) the objects drifted over (0 before the
first): the sweep takes the objects back by it (s). ``clock`` opens ``reals``, so these index the
buffer too."""
COUNT_STEPS, COUNT_FRAMES = 0, 1
"""Indices into ``counter``: physics steps taken, hand frames taken; ``counter`` opens ``counts``."""

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
    ("last_points", REALS, (2, POINTS, 3)),  # each side's palm and joints in the last frame: for the jump rule
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

MODEL_REALS, MODEL_INTS = 0, 1
OBJECT_COUNT = 0
"""Index of the number of objects in the model's ints: it opens them, and every place depends on it."""
PARAMETERS: tuple[tuple[str, int, tuple, Callable], ...] = (
    ("angular_method", MODEL_INTS, (), lambda scene: ANGULAR_INTEGRATORS.index(scene.angular_integrator)),
    ("shape", MODEL_INTS, ("N",), lambda spec: SHAPES.index(spec.shape)),
    # a box's half extents; a sphere's radius in every column; a mesh's half extent
    ("half_size", MODEL_REALS, ("N", 3), lambda spec: spec.half_extents),
    ("mass", MODEL_REALS, ("N",), lambda spec: spec.mass),
    ("inertia", MODEL_REALS, ("N", 3), lambda spec: spec.principal_inertia),  # principal moments, body frame
    ("restitution", MODEL_REALS, ("N",), lambda spec: spec.material.restitution),
    ("static_friction", MODEL_REALS, ("N",), lambda spec: spec.material.static_friction),
    ("dynamic_friction", MODEL_REALS, ("N",), lambda spec: spec.material.dynamic_friction),
    ("gravity", MODEL_REALS, (3,), lambda scene: scene.gravity),
    ("penetration_stiffness", MODEL_REALS, (), lambda scene: scene.penetration_stiffness),
    ("resting_tolerance", MODEL_REALS, (), lambda scene: scene.resting_tolerance),
    ("jump_distance", MODEL_REALS, (), lambda scene: scene.jump_distance),
    ("dt", MODEL_REALS, (), lambda scene: scene.dt),
    ("soft_stiffness", MODEL_REALS, (), lambda scene: scene.soft_hand.stiffness),
    ("soft_damping", MODEL_REALS, (), lambda scene: scene.soft_hand.damping),
    ("soft_slip_velocity", MODEL_REALS, (), lambda scene: scene.soft_hand.slip_velocity),
    # the table's settings are 0 in a scene without one (its kernel is not compiled in then)
    ("table_height", MODEL_REALS, (), lambda scene: getattr(scene.table, "height", 0.0)),
    ("table_stiffness", MODEL_REALS, (), lambda scene: getattr(scene.table, "stiffness", 0.0)),
    ("table_damping", MODEL_REALS, (), lambda scene: getattr(scene.table, "damping", 0.0)),
    ("table_slip_velocity", MODEL_REALS, (), lambda scene: getattr(scene.table, "slip_velocity", 0.0)),
)
"""Every number of the model: name (the kernels' field, ``p.mass``, and the Model's attribute),
buffer, shape (N: objects), and where ``make_model`` takes it from: a function of each object's
``ObjectSpec`` (shape N, ...) or of the ``Scene``. A new parameter is one line here and its use."""


PLACES = places(FIELDS, opening=(0, 0, 0))
PARAMETER_PLACES = places(PARAMETERS, opening=(0, 1))
"""The model's places: its reals start with the parameters, its ints with the number of objects
(``OBJECT_COUNT``)."""
MESH_REALS, MESH_INTS = tail(PARAMETER_PLACES, MODEL_REALS), tail(PARAMETER_PLACES, MODEL_INTS)
"""Where the model's buffers' mesh tails start (``unpack_mesh``)."""


STATE = StructType([(name, array_type({REALS: types.float64, FLAGS: types.bool_, COUNTS: types.int64}[buffer],
                                      len(shape))) for name, buffer, shape in FIELDS])
"""What the kernels read of a world's state (``world.Data``)."""
PARAMS = StructType([(name, array_type(dtype, len(shape)) if shape else dtype)
                     for name, buffer, shape, _ in PARAMETERS
                     for dtype in ({MODEL_REALS: types.float64, MODEL_INTS: types.int64}[buffer],)])
"""What the kernels read of the model (``world.Model``)."""

unpack = views("unpack", STATE, FIELDS, PLACES, ("reals", "flags", "counts"),
               "One world's buffers as a ``STATE`` of views, at their ``PLACES``:")
unpack_params = views("unpack_params", PARAMS, PARAMETERS, PARAMETER_PLACES, ("reals", "ints"),
                      "The model's buffers as ``PARAMS`` (arrays are views), at their ``PARAMETER_PLACES``:")


@lru_cache(maxsize=None)
def layout(n_objects: int) -> tuple[dict[str, tuple[int, int, int, tuple[int, ...]]], tuple[int, int, int]]:
    """Where each field of the state lives for ``n_objects`` objects: name -> (buffer, start, stop,
    shape), and the three buffer sizes."""
    fields = {name: (buffer, *where(getattr(PLACES, name), n_objects, len(shape))) for name, buffer, shape in FIELDS}
    sizes = [0, 0, 0]
    for buffer, _, stop, _ in fields.values():
        sizes[buffer] = max(sizes[buffer], stop)
    return fields, (sizes[0], sizes[1], sizes[2])


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


def pack_params(scene, meshes=None) -> tuple[np.ndarray, np.ndarray]:
    """The scene's numbers as the model's two buffers (reals, ints) for ``unpack_params``, each
    ``PARAMETERS`` entry taken from its source; ``meshes``, the (reals, ints) of
    ``mesh.pack_meshes``, follow as the buffers' tails (``unpack_mesh``)."""
    specs = [placed.spec for placed in scene.objects]
    packed = ([], [len(specs)])
    for name, buffer, shape, source in PARAMETERS:
        value = [source(spec) for spec in specs] if shape[:1] == ("N",) else source(scene)
        _, _, shape_here = where(getattr(PARAMETER_PLACES, name), len(specs), len(shape))
        packed[buffer].extend(np.reshape(np.asarray(value, dtype=(np.float64, np.int64)[buffer]), shape_here).ravel())
    mesh_reals, mesh_ints = meshes if meshes is not None else ([], [])
    return (np.concatenate([np.asarray(packed[MODEL_REALS], dtype=np.float64), mesh_reals]).astype(np.float64),
            np.concatenate([np.asarray(packed[MODEL_INTS], dtype=np.int64), mesh_ints]).astype(np.int64))


def parameter(reals: np.ndarray, ints: np.ndarray, name: str) -> np.ndarray | float | int:
    """The named parameter of a model's buffers: a view for an array, else the number."""
    buffer, shape = next((buffer, shape) for field, buffer, shape, _ in PARAMETERS if field == name)
    start, stop, shape_here = where(getattr(PARAMETER_PLACES, name), int(ints[OBJECT_COUNT]), len(shape))
    values = (reals, ints)[buffer]
    return values[start:stop].reshape(shape_here) if shape else values[start].item()


MESH = StructType([(name, array_type(types.int64, 2)) for name in ("object_parts", "object_corners", "part_faces",
                                                                   "face_edges")]
                  + [(name, array_type(types.float64, 2)) for name in ("planes", "edges", "corners")])
"""The convex parts of a scene's mesh objects (``mesh.pack_meshes``): [first, stop) ranges per
object (its parts, its corners), per part (its faces) and per face (its edges); the face planes
(n, d), the edges (start, end, in-plane outward normal m, seam flag) and the corners."""


@kernel
def unpack_mesh(reals, ints, n):
    """The tails of the model buffers as ``MESH`` (views; layout of ``mesh.pack_meshes``)."""
    m = structref.new(MESH)
    i = MESH_INTS.start + MESH_INTS.start_per_object * n
    parts, faces, edges, corners = ints[i], ints[i + 1], ints[i + 2], ints[i + 3]
    i += 4
    m.object_parts = ints[i:i + 2 * n].reshape((n, 2))
    i += 2 * n
    m.object_corners = ints[i:i + 2 * n].reshape((n, 2))
    i += 2 * n
    m.part_faces = ints[i:i + 2 * parts].reshape((parts, 2))
    i += 2 * parts
    m.face_edges = ints[i:i + 2 * faces].reshape((faces, 2))
    r = MESH_REALS.start + MESH_REALS.start_per_object * n
    m.planes = reals[r:r + 4 * faces].reshape((faces, 4))
    r += 4 * faces
    m.edges = reals[r:r + 10 * edges].reshape((edges, 10))
    r += 10 * edges
    m.corners = reals[r:r + 3 * corners].reshape((corners, 3))
    return m


@kernel
def set_motion(reals, flags, counts, n, index, motion):
    """Put object ``index`` at ``motion``: its position, orientation, velocity and angular velocity
    (13 numbers), e.g. back at its start."""
    s = unpack(reals, flags, counts, n)
    for i in range(3):
        s.position[index, i], s.velocity[index, i], s.angular_velocity[index, i] = motion[i], motion[7 + i], \
            motion[10 + i]
    for i in range(4):
        s.orientation[index, i] = motion[3 + i]
