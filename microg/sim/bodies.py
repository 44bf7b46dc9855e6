"""Rigid objects: shape, mass, principal inertia and surface material, read from object files.

An object file is TOML (see ``protocols/objects/``)::

    name = "cube"
    shape = "box"               # "box", "sphere" or "mesh"
    size = [0.06, 0.06, 0.06]   # box: full edge lengths along the body x, y, z axes (m)
    # radius = 0.035            # sphere: radius (m)
    # mesh = "bracket.obj"      # mesh: a closed OBJ or STL file (m), relative to this file (``mesh``)
    mass = 0.151                # kg
    # density = 2700            # kg/m^3, instead of mass (mesh only)
    # inertia = [Ixx, Iyy, Izz] # optional principal moments (kg m^2); default: solid body
    [material]
    restitution = 0.4           # e in (0, 1), Eq. 10
    static_friction = 0.8       # mu, Eq. 19
    dynamic_friction = 0.5      # phi, Eq. 20; phi <= mu

The body frame is the principal frame, centred at the centre of mass, so the body inertia is
diagonal. A mesh's mass properties come from the solid it bounds (``mesh.load_mesh``).

An object file describes something a hand can pick up: its mass must lie in ``MASS_LIMITS`` and
its extent along each axis in ``SIZE_LIMITS`` (a mesh written in millimetres is 1000 times too big).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .mesh import MeshError, MeshShape, load_mesh

SHAPES = ("box", "sphere", "mesh")
BOX, SPHERE, MESH = 0, 1, 2
MASS_LIMITS = (1e-4, 1e3)
"""kg: from a tenth of a gram to a tonne (the physics' tests span 1 g to 10 kg)."""
SIZE_LIMITS = (1e-3, 10.0)
"""m: an object's extent along a body axis, from a millimetre to ten metres."""


class SceneError(ValueError):
    """A scene, object or hand input that the physics cannot accept; the message names the field."""


def _float(value: object) -> float | None:
    """``value`` as a float when it is a finite number (not a bool, not an integer beyond floats), else None."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def _positive(where: str, name: str, value: object, limits: tuple[float, float] | None = None,
              unit: str = "") -> float:
    """``value`` as a float, if it is a positive number (within ``limits``, when given)."""
    number = _float(value)
    if number is None or number <= 0:
        raise SceneError(f"{where}: {name} = {value!r}: must be a positive number")
    if limits is not None and not limits[0] <= number <= limits[1]:
        raise SceneError(f"{where}: {name} = {value!r}: must lie from {limits[0]:g} to {limits[1]:g}{unit}")
    return number


@dataclass(frozen=True)
class Material:
    """Surface parameters of the paper's contact model."""

    restitution: float = 0.4
    static_friction: float = 0.8
    dynamic_friction: float = 0.5

    def validate(self, where: str) -> None:
        e, mu, phi = self.restitution, self.static_friction, self.dynamic_friction
        for name, value in (("restitution", e), ("static_friction", mu), ("dynamic_friction", phi)):
            if _float(value) is None:
                raise SceneError(f"{where}: material.{name} = {value!r}: must be a number")
        if not 0 < e < 1:
            raise SceneError(f"{where}: material.restitution = {e}: must lie in (0, 1) (paper, Eq. 10)")
        if mu < 0:
            raise SceneError(f"{where}: material.static_friction = {mu}: must be >= 0")
        if not 0 <= phi <= mu:
            raise SceneError(f"{where}: material.dynamic_friction = {phi}: must lie in [0, static_friction = {mu}]")


@dataclass(frozen=True)
class ObjectSpec:
    """An object's shape and mass properties; where it sits belongs to the scene."""

    name: str
    shape: str
    size: tuple[float, float, float]
    """Box: full edge lengths; sphere: (diameter, diameter, diameter); mesh: its extent along the
    body axes."""
    mass: float
    material: Material = Material()
    inertia: tuple[float, float, float] | None = None
    """Principal moments (kg m^2); None means a solid body of uniform density."""
    mesh: MeshShape | None = field(default=None, compare=False, repr=False)
    """A mesh object's geometry (shape "mesh")."""

    def validate(self, where: str) -> None:
        if self.shape not in SHAPES:
            raise SceneError(f"{where}: shape = {self.shape!r}: must be one of {SHAPES}")
        if (self.shape == "mesh") != (self.mesh is not None):
            raise SceneError(f"{where}: shape = {self.shape!r} needs a mesh exactly when it is 'mesh'")
        _positive(where, "mass", self.mass)
        for axis, value in zip("xyz", self.size):
            _positive(where, f"size.{axis}", value)
        self.material.validate(where)
        moments = self.principal_inertia
        if not np.all(np.isfinite(moments)) or np.any(moments <= 0):
            raise SceneError(f"{where}: inertia = {moments.tolist()}: principal moments must be positive")
        a, b, c = sorted(moments)
        if a + b < c * (1 - 1e-9):
            raise SceneError(f"{where}: inertia = {moments.tolist()}: violates the triangle inequality "
                             "(no rigid body has these moments)")

    @property
    def half_extents(self) -> np.ndarray:
        return 0.5 * np.asarray(self.size, dtype=np.float64)

    @property
    def principal_inertia(self) -> np.ndarray:
        """Body-frame principal moments of inertia (kg m^2)."""
        if self.inertia is not None:
            return np.asarray(self.inertia, dtype=np.float64)
        if self.mesh is not None:
            return self.mass * self.mesh.unit_inertia
        if self.shape == "sphere":
            r = 0.5 * self.size[0]
            return np.full(3, 0.4 * self.mass * r * r)
        x, y, z = self.size
        return self.mass / 12.0 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])


def load_object(path: str | Path) -> ObjectSpec:
    """Read an object file; errors name the file, the field and the value."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise SceneError(f"{path}: cannot read object file: {error}") from None
    except RecursionError:
        raise SceneError(f"{path}: not an object file: its tables or arrays are nested too deeply") from None
    return object_from_dict(data, str(path), path.parent)


def _mesh_object(data: dict, where: str, folder: Path,
                 content: bytes | None) -> tuple[MeshShape, tuple[float, float, float], float]:
    """A mesh object's geometry, extent and mass (given, or its density times its volume)."""
    name = data.get("mesh")
    if not isinstance(name, str) or not name:
        raise SceneError(f"{where}: mesh = {name!r}: must name an OBJ or STL file")
    try:
        mesh = load_mesh(folder / name, content)
    except MeshError as error:
        raise SceneError(f"{where}: mesh = {name!r}: {error}") from None
    if ("mass" in data) == ("density" in data):
        raise SceneError(f"{where}: a mesh object needs exactly one of 'mass' and 'density'")
    extent = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
    if not (SIZE_LIMITS[0] <= extent.min() and extent.max() <= SIZE_LIMITS[1]):
        raise SceneError(f"{where}: mesh = {name!r}: extent {[round(float(v), 6) for v in extent]} m: must lie from "
                         f"{SIZE_LIMITS[0]:g} to {SIZE_LIMITS[1]:g} m along each axis (a mesh is in metres)")
    if "mass" in data:
        mass = _positive(where, "mass", data["mass"], MASS_LIMITS, " kg")
    else:
        mass = _positive(where, "density", data["density"]) * mesh.volume
        if not MASS_LIMITS[0] <= mass <= MASS_LIMITS[1]:
            raise SceneError(f"{where}: density = {data['density']!r}: gives a mass of {mass:g} kg; the mass must "
                             f"lie from {MASS_LIMITS[0]:g} to {MASS_LIMITS[1]:g} kg")
    return mesh, tuple(float(v) for v in extent), mass


def object_from_dict(data: dict, where: str, folder: Path = Path("."), mesh_content: bytes | None = None) -> ObjectSpec:
    """An object from the fields of an object file; its mesh file is resolved against ``folder``,
    or given as ``mesh_content`` (the file's bytes, kept with a study's protocol)."""
    known = {"name", "code", "shape", "size", "radius", "mesh", "density", "mass", "inertia", "material",
             "description"}
    unknown = set(data) - known
    if unknown:
        raise SceneError(f"{where}: unknown field {sorted(unknown)[0]!r} (known: {sorted(known)})")
    for required in ("name", "shape"):
        if required not in data:
            raise SceneError(f"{where}: missing field {required!r}")
    if not isinstance(data["name"], str) or not data["name"].strip():
        raise SceneError(f"{where}: name = {data['name']!r}: must be a non-empty string")
    shape, mesh = data["shape"], None
    if shape not in SHAPES:
        raise SceneError(f"{where}: shape = {shape!r}: must be one of {SHAPES}")
    if shape != "mesh":
        for misplaced in ("mesh", "density"):
            if misplaced in data:
                raise SceneError(f"{where}: {misplaced} = {data[misplaced]!r}: only for shape = 'mesh'")
        if "mass" not in data:
            raise SceneError(f"{where}: missing field 'mass'")
        mass = _positive(where, "mass", data["mass"], MASS_LIMITS, " kg")
    if shape == "mesh":
        mesh, size, mass = _mesh_object(data, where, folder, mesh_content)
    elif shape == "sphere":
        radius = _positive(where, "radius", data.get("radius"), tuple(v / 2 for v in SIZE_LIMITS), " m")
        size = (2 * radius,) * 3
    else:
        size = data.get("size")
        if not isinstance(size, list) or len(size) != 3:
            raise SceneError(f"{where}: size = {size!r}: must be three edge lengths [x, y, z] in metres")
        size = tuple(_positive(where, f"size.{axis}", v, SIZE_LIMITS, " m") for axis, v in zip("xyz", size))
    material = data.get("material", {})
    if not isinstance(material, dict):
        raise SceneError(f"{where}: material = {material!r}: must be a table ([material]) of restitution, "
                         "static_friction and dynamic_friction")
    known_material = {"restitution", "static_friction", "dynamic_friction"}
    if set(material) - known_material:
        raise SceneError(f"{where}: unknown field material.{sorted(set(material) - known_material)[0]}")
    inertia = data.get("inertia")
    if inertia is not None:
        if not isinstance(inertia, list) or len(inertia) != 3:
            raise SceneError(f"{where}: inertia = {inertia!r}: must be three principal moments")
        inertia = [_positive(where, f"inertia[{i}]", v, unit=" kg m^2") for i, v in enumerate(inertia)]
    spec = ObjectSpec(name=data["name"], shape=shape, size=size, mass=mass,
                      material=Material(**material), inertia=tuple(inertia) if inertia else None, mesh=mesh)
    spec.validate(where)
    return spec
