"""The numba machinery of the compiled physics (and of every compiled frame), in one place.

Everything the compiled code runs on is plain data: flat buffers (numpy arrays) and records
(numpy structured scalars). This module turns declarations of that data into what compiled code
reads, so that nobody writes an offset by hand:

- ``kernel`` and ``entry``: the two ways a function is compiled. A kernel is called from compiled
  code (linked into its caller, inlined by LLVM); an entry is called from Python.
- ``places`` lays out a declaration (name, buffer, shape; N: objects, K: phalanx slots) in flat
  buffers; ``views`` makes the kernel that gives those fields to compiled code as a ``StructType``
  of views (``borrow``: no reference counts, no slices); ``attach`` gives them to Python as
  attributes of a class (read on first access).
- ``specialised`` composes compiled functions into one: a function made from a template with the
  functions it calls as globals of their own names, so that numba's disk cache keys it (it
  cannot key a function that closes over a compiled one); ``entry_point`` calls such a function
  without numba's dispatch, for a loop that calls it with arguments of the same types again and again.

Recipe:

- *A state field* (something of a world that changes): one line in ``microg.sim.state.FIELDS``
  (name, buffer, shape); kernels read it as ``s.name``, Python as ``world.data.name``.
- *A loop over the phalanges that writes the state*: read the fields it uses into locals before
  it (``active, onset = s.active, s.onset``): a field read through ``s`` after a write is read
  again from the state's memory, its pointer and shape each time (the compiler cannot tell that
  the write left them alone); a loop that only looks pays nothing for ``s.``.
- *A parameter* (a number of the scene): one line in ``microg.sim.state.PARAMETERS`` (name, buffer,
  shape, where ``make_model`` takes it from); kernels read it as ``p.name``, Python as
  ``world.model.name``.
- *An effect*: its name in ``microg.sim.scene.EFFECTS`` (and in the interaction models that use it),
  its kernel, and its stage in ``microg.sim.pipeline.specialise``'s step under ``if effect:``: the
  step is compiled per set of effects, so an effect a scene does not name costs nothing.
"""

from __future__ import annotations

import textwrap
from collections import namedtuple
from typing import Callable, NamedTuple

import numpy as np
from numba import njit, typeof, types
from numba.core import cgutils
from numba.core.registry import CPUDispatcher
from numba.experimental import structref
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from microg.skeleton import SLOTS

entry = njit(cache=True, error_model="numpy", no_cfunc_wrapper=True)
"""A compiled entry point (called from Python): cached on disk, numpy's float semantics (x / 0 is
inf, not an error). No C-callable wrapper (nothing takes its address)."""


class Kernel(CPUDispatcher):
    """A compiled physics function, called from compiled code: numba links its code into the
    caller's. It is compiled without the wrappers that let Python (and C) call it, which are a
    third of what compiling a small kernel costs; a call from Python (a test, a tool) goes to a
    twin compiled with them, not cached on disk (numba's cache index would not tell the two apart)."""

    def __call__(self, *args, **kwargs):
        twin = self.__dict__.get("_python_twin")
        if twin is None:
            twin = self._python_twin = njit(error_model="numpy")(self.py_func)
        return twin(*args, **kwargs)

    def __repr__(self) -> str:
        return f"CPUDispatcher({self.py_func})"  # what numba's typed code shows for any compiled function


def kernel(func):
    """A ``Kernel``: cached on disk, numpy's float semantics. Each is compiled on its own
    (numba-level inlining makes a step this size several times slower to compile) and marked for
    LLVM to inline (``forceinline``): numba prunes the reference counts of a kernel's arguments (the
    state, the model, the wrench) only within one function, so a kernel left as a call pays an
    atomic increment and decrement for each of them on every call, several times a substep (an
    in-silico study took 15 % more CPU time so)."""
    compiled = Kernel(py_func=func, locals={}, targetoptions={
        "nopython": True, "boundscheck": None, "error_model": "numpy", "no_cpython_wrapper": True,
        "no_cfunc_wrapper": True, "forceinline": True})
    compiled.enable_caching()
    return compiled


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


def where(place: Place, n_objects: int, dimensions: int) -> tuple[int, int, tuple[int, ...]]:
    """A field's start, stop and shape in its buffer for ``n_objects`` objects."""
    start = place.start + n_objects * place.start_per_object
    shape = tuple(e + n_objects * p for e, p in zip(place.extent, place.extent_per_object))[:dimensions]
    return start, start + int(np.prod(shape)), shape


def array_type(dtype, ndim: int):
    """A C-contiguous array of ``dtype`` and ``ndim`` dimensions, as a ``StructType``'s field."""
    return types.Array(dtype, ndim, "C")


@structref.register
class StructType(types.StructRef):
    """Named fields passed by reference (a numba StructRef): what the kernels get as the state and the
    model's numbers. A kernel's signature is one pointer however many fields there are; a named tuple
    of 26 arrays would be passed, and compiled, field by field (it made the step three times slower
    to compile)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


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


def views(name: str, struct: StructType, declaration, laid, buffers: tuple[str, ...], doc: str):
    """The kernel ``name(*buffers, n)`` that gives the ``declaration``'s fields as a ``struct`` of
    views into the buffers (the number, for a field of shape ()), made from their places ``laid``:
    one line a field, ``s.position = borrow(reals, 5, (n, 3))``, and no offset written by
    hand. The source is compiled as code of this file, in its namespace, so numba caches the kernel
    like any other (across processes: checked with ``NUMBA_DEBUG_CACHE=1``), and it compiles to what
    a hand-written one would: the cold start did not grow (written as calls of view helpers instead,
    it grew by about 1 s in 20). The kernel's docstring shows its source."""
    globals()[f"_{name}_struct"] = struct
    lines = [f"def {name}({', '.join(buffers)}, n):", f"    s = structref.new(_{name}_struct)"]
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


class _Kept:
    """A named part of an instance's buffers (``read(instance, name)``), read on first access and
    then kept in the instance, which answers every later access directly (each world a step returns
    makes its own views, a dozen a frame)."""

    def __init__(self, name: str, read: Callable):
        self.name, self.read = name, read

    def __get__(self, instance, owner: type):
        if instance is None:
            return self
        value = instance.__dict__[self.name] = self.read(instance, self.name)
        return value


def attach(cls: type, names, read: Callable) -> None:
    """Give ``cls`` an attribute per name, ``read(instance, name)`` on first access (``_Kept``)."""
    for name in names:
        setattr(cls, name, _Kept(name, read))


def entry_point(function, args: tuple) -> Callable:
    """The compiled code of ``function`` for arguments of the types of ``args``, to be called
    directly with such arguments: numba's dispatcher types every argument at every call, and a
    record array's type costs tens of microseconds to make, a millisecond for the frame path's
    arguments (ten for a simulated participant's); a loop that calls the same code again and
    again need not pay it each time, nor a session that plays task after task (kept per function
    and the arrays' layout)."""
    key = (function, _layout(args))
    found = _ENTRY_POINTS.get(key)
    if found is None:
        found = _ENTRY_POINTS[key] = function.compile(tuple(typeof(a) for a in args))
    return found


_ENTRY_POINTS: dict = {}


def _layout(value):
    """What decides an argument's numba type, cheaply: an array's dtype, dimensions, order and
    flags, a tuple's items', a scalar's Python type."""
    if isinstance(value, np.ndarray):
        flags = value.flags
        return value.dtype, value.ndim, flags.c_contiguous, flags.f_contiguous, flags.writeable, flags.aligned
    if isinstance(value, tuple):
        return tuple(_layout(item) for item in value)
    if isinstance(value, np.generic):  # a record's type is its dtype's
        return type(value), value.dtype
    return type(value)


def specialised(template: str, name: str, calls: dict[str, Callable], where: str, namespace: dict):
    """The compiled function ``name`` made from ``template`` (its source, with ``{name}`` and a
    ``{key}`` for each of ``calls``): each function of ``calls`` becomes a global of the module
    ``namespace`` under a name of its own (``_<key>_<name>``), so the made function calls it
    directly and numba caches it as a function of the file ``where``. ``name`` must tell apart
    every composition (e.g. the effects of the step it calls)."""
    globals_ = {}
    for key, function in calls.items():
        globals_[key] = f"_{key}_{name}"
        namespace[globals_[key]] = function
    source = template.format(name=name, **globals_)
    made = {}
    exec(compile(source, where, "exec"), namespace, made)
    return njit(cache=True, error_model="numpy")(made[name])
