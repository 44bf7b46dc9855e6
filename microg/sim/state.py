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

import textwrap
from collections import namedtuple
from functools import lru_cache
from typing import Callable, NamedTuple

import numpy as np
from numba import types
from numba.core import cgutils
from numba.experimental import structref
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from microg.skeleton import SLOTS
from .bodies import SHAPES
from .scene import ANGULAR_INTEGRATORS
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


class Place(NamedTuple):
    """Where a field lies in its buffer for n objects: from ``start + n * start_per_object``, with
    extents ``extent[i] + n * extent_per_object[i]`` (linear in n: a shape names N at most once);
    the extents past a field's dimensions are 1 and 0."""

    buffer: int
    start: int
    start_per_object: int
    extent: tuple[int, int, int]
    extent_per_object: tuple[int, int, int]


def size(place: Place) -> tuple[int, int]:
    """A field's number of entries as (fixed, per object): it holds fixed + n * per_object."""
    entries = int(np.prod([e for e, p in zip(place.extent, place.extent_per_object) if not p]))
    return (0, entries) if any(place.extent_per_object) else (entries, 0)


def places(declaration, opening: tuple[int, ...]):
    """The ``Place`` of every declared field, laid out in declaration order in its buffer after the
    ``opening`` entries of each; a named tuple by field name."""
    start = [(first, 0) for first in opening]
    laid = {}
    for name, buffer, shape, *_ in declaration:
        extent = tuple(0 if d == "N" else SLOTS if d == "K" else d for d in shape) + (1,) * (3 - len(shape))
        per_object = tuple(1 if d == "N" else 0 for d in shape) + (0,) * (3 - len(shape))
        laid[name] = place = Place(buffer, *start[buffer], extent, per_object)
        fixed, by_object = size(place)
        start[buffer] = (start[buffer][0] + fixed, start[buffer][1] + by_object)
    return namedtuple("Places", laid)(**laid)


def tail(laid, buffer: int) -> Place:
    """The empty place just past the last field of ``buffer``: where what follows them starts."""
    last = [place for place in laid if place.buffer == buffer][-1]
    fixed, by_object = size(last)
    return Place(buffer, last.start + fixed, last.start_per_object + by_object, (0, 1, 1), (0, 0, 0))


PLACES = places(FIELDS, opening=(0, 0, 0))
PARAMETER_PLACES = places(PARAMETERS, opening=(0, 1))
"""The model's places: its reals start with the parameters, its ints with the number of objects
(``OBJECT_COUNT``)."""
MESH_REALS, MESH_INTS = tail(PARAMETER_PLACES, MODEL_REALS), tail(PARAMETER_PLACES, MODEL_INTS)
"""Where the model's buffers' mesh tails start (``unpack_mesh``)."""


def where(place: Place, n_objects: int, dimensions: int) -> tuple[int, int, tuple[int, ...]]:
    """A field's start, stop and shape in its buffer for ``n_objects`` objects."""
    start = place.start + n_objects * place.start_per_object
    shape = tuple(e + n_objects * p for e, p in zip(place.extent, place.extent_per_object))[:dimensions]
    return start, start + int(np.prod(shape)), shape


def _array(dtype, ndim: int):
    return types.Array(dtype, ndim, "C")


@structref.register
class StructType(types.StructRef):
    """Named fields passed by reference (a numba StructRef): what the kernels get as the state and the
    model's numbers. A kernel's signature is one pointer however many fields there are; a named tuple
    of 26 arrays would be passed, and compiled, field by field (it made the step three times slower
    to compile)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


STATE = StructType([(name, _array({REALS: types.float64, FLAGS: types.bool_, COUNTS: types.int64}[buffer],
                                  len(shape))) for name, buffer, shape in FIELDS])
PARAMS = StructType([(name, _array(dtype, len(shape)) if shape else dtype)
                     for name, buffer, shape, _ in PARAMETERS
                     for dtype in ({MODEL_REALS: types.float64, MODEL_INTS: types.int64}[buffer],)])
"""What the kernels read of the model (``world.Model``)."""


def _span(place: Place, dimensions: int) -> tuple[str, str]:
    """A field's start and shape for n objects as source text: ``5``, ``(n, 3)`` (``(5,)``)."""
    fixed, per_object = place.start, place.start_per_object
    start = " + ".join([str(fixed)] * bool(fixed or not per_object)
                       + [f"{per_object} * n" if per_object > 1 else "n"] * bool(per_object))
    extents = ["n" if p else str(e) for e, p in zip(place.extent, place.extent_per_object)][:dimensions]
    return start, f"({', '.join(extents)}{',' * (dimensions == 1)})"


@intrinsic
def borrow(typingctx, buffer, start, shape):
    """``buffer[start:start + prod(shape)]`` as a C-contiguous view of ``shape`` that holds no
    reference to its memory (its meminfo is null): what ``unpack`` makes its fields of. A field is
    read in every kernel of every step, and a counted view pays an atomic increment and decrement on
    each read (an in-silico study ran 20 % faster without them); made in place, it needs neither a
    slice nor a reshape, which each frame's ``unpack`` would otherwise pay for every field. Safe
    because a state lives only inside the compiled call whose arguments own its buffers (laid out by
    ``layout``, so every field fits); nothing returns a field to Python without copying it."""
    ndim = len(shape)
    view_type = types.Array(buffer.dtype, ndim, "C")

    def codegen(context, builder, signature, args):
        source = make_array(buffer)(context, builder, value=args[0])
        extents = cgutils.unpack_tuple(builder, args[2], ndim)
        strides, step = [], source.itemsize
        for extent in reversed(extents):  # C order: the last axis is contiguous
            strides.insert(0, step)
            step = builder.mul(step, extent)
        view = make_array(view_type)(context, builder)
        populate_array(view, data=builder.gep(source.data, [args[1]]), shape=extents, strides=strides,
                       itemsize=source.itemsize, meminfo=None)
        return view._getvalue()

    return view_type(buffer, start, shape), codegen


def views(name: str, struct: str, declaration, laid, buffers: tuple[str, ...], doc: str):
    """The kernel ``name(*buffers, n)`` that gives the ``declaration``'s fields as a ``struct`` of
    views into the buffers (the number, for a field of shape ()), made from their places ``laid``:
    one line a field, ``s.position = borrow(reals, 5, (n, 3))``, and no offset written by
    hand. The source is compiled as code of this file, in its namespace, so numba caches the kernel
    like any other (across processes: checked with ``NUMBA_DEBUG_CACHE=1``), and it compiles to what
    a hand-written one would: the cold start did not grow (written as calls of view helpers instead,
    it grew by about 1 s in 20). The kernel's docstring shows its source."""
    lines = [f"def {name}({', '.join(buffers)}, n):", f"    s = structref.new({struct})"]
    for field, buffer, shape, *_ in declaration:
        start, extents = _span(getattr(laid, field), len(shape))
        lines.append(f"    s.{field} = " + (f"{buffers[buffer]}[{start}]" if not shape else
                                           f"borrow({buffers[buffer]}, {start}, {extents})"))
    source = "\n".join(lines + ["    return s"])
    namespace = {}
    exec(compile(source, __file__, "exec"), globals(), namespace)
    function = namespace[name]
    function.__module__, function.__doc__ = __name__, f"{doc}\n\n{textwrap.indent(source, '    ')}"
    return kernel(function)


unpack = views("unpack", "STATE", FIELDS, PLACES, ("reals", "flags", "counts"),
               "One world's buffers as a ``STATE`` of views, at their ``PLACES``:")
unpack_params = views("unpack_params", "PARAMS", PARAMETERS, PARAMETER_PLACES, ("reals", "ints"),
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
