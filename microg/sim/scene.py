"""A scene: the objects, where they start, and exactly which physical effects act on them.

The step is compiled for the effects a scene names and nothing else (see ``pipeline.specialise``).
An interaction model is a named set of contact effects; the three models the toolkit compares:

- ``impulse_penetration``: the paper's model, the impulse phase at contact onset (Eqs. 9-15) plus
  the penetration phase with friction (Eqs. 16-20).
- ``penetration_only``: the prior method the paper improves on, spring forces from god-object
  proxies with friction and no impulse at contact onset.
- ``soft_hand``: a compliant soft-hand coupling (penalty spring and damper with regularised
  Coulomb friction, no god-object anchors, no impulses). It stands in for the paper's
  comparison interaction model; it is not that model.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from microg.skeleton import JUMP_DISTANCE
from .bodies import ObjectSpec, SceneError, load_object

EFFECTS: dict[str, str] = {
    "gravity": "uniform gravity on every object (the scene's gravity vector)",
    "impulse": "one impulse at the onset of each colliding contact (Eqs. 9-15)",
    "penetration": "spring force between god-object proxy and tracked phalanx (Eqs. 16-18)",
    "friction": "Coulomb cone with static mu and dynamic phi on contact forces (Eqs. 19-20)",
    "soft_hand": "compliant penalty coupling of a soft hand (comparison baseline)",
    "gyroscopic": "torque-free rotation obeys Euler's equations (angular momentum conserved)",
    "continuous_collision": "swept-sphere onset test: fast phalanges cannot pass thin objects",
    "table": "a static horizontal table the objects rest on (the scene's table settings)",
}

INTERACTION_MODELS: dict[str, frozenset[str]] = {
    "impulse_penetration": frozenset({"impulse", "penetration", "friction"}),
    "penetration_only": frozenset({"penetration", "friction"}),
    "soft_hand": frozenset({"soft_hand", "friction"}),
}

ENVIRONMENT_EFFECTS = frozenset({"gyroscopic", "continuous_collision"})
"""What every study scene adds to its interaction model (plus gravity when it is not zero)."""

ANGULAR_INTEGRATORS = ("midpoint", "semi_implicit_euler", "explicit_euler")
"""``midpoint`` conserves angular momentum and kinetic energy exactly; the Euler variants are
kept for the accuracy benchmarks."""


@dataclass(frozen=True)
class SoftHandParameters:
    """The compliant baseline's contact: normal spring and damper, regularised Coulomb friction."""

    stiffness: float = 200.0
    """N/m per contact, along the normal."""
    damping: float = 2.0
    """N s/m per contact, along the normal."""
    slip_velocity: float = 0.005
    """m/s: below this sliding speed friction is viscous, mu * f_n * v / slip_velocity."""


@dataclass(frozen=True)
class TableParameters:
    """The static table (only with the ``table`` effect): its height and its compliant contact."""

    height: float = 0.0
    """y of the table top (m) in the world (tracker) frame."""
    stiffness: float = 2000.0
    """N/m per object corner: a 150 g cube resting on four corners sinks 0.2 mm."""
    damping: float = 10.0
    """N s/m per corner: about critical for the shipped objects."""
    slip_velocity: float = 0.001
    """m/s: friction is viscous below this sliding speed, Coulomb above."""


@dataclass(frozen=True)
class PlacedObject:
    """An object and its initial state in the world frame (m, m/s, rad/s)."""

    spec: ObjectSpec
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Scene:
    """Everything the physics needs to know before the first frame."""

    objects: tuple[PlacedObject, ...]
    effects: frozenset[str]
    gravity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tracking_rate: float = 110.0
    """Nominal hand-frame rate (Hz); the Leap Motion delivers about 110."""
    substeps: int = 4
    """Physics steps per nominal tracking frame; dt = 1 / (tracking_rate * substeps). Four (dt = 1/440 s):
    impacts obey Newton's law at any step now, but the compliant table (friction, settling) and a
    pinch under gravity still need it (docs/physics.md, "What accuracy costs")."""
    penetration_stiffness: float = 100.0
    """gamma in Eq. 16 (N/m); the paper's value."""
    angular_integrator: str = "midpoint"
    resting_tolerance: float = 1e-3
    """|v| below this (m/s) classifies a contact as resting (Eq. 8)."""
    jump_distance: float = JUMP_DISTANCE
    """m: a hand that moved this far between two frames jumped (``microg.skeleton.is_jump``): the
    world starts a new track for it, as the tracking guard does (``hand_path``). A study's scene
    has its protocol's, the guard's (``scene.jump_distance``)."""
    soft_hand: SoftHandParameters = field(default_factory=SoftHandParameters)
    table: TableParameters | None = None

    @property
    def dt(self) -> float:
        return 1.0 / (self.tracking_rate * self.substeps)

    @property
    def has_meshes(self) -> bool:
        """Whether an object is a mesh: only then is the step compiled with the mesh kernels."""
        return any(placed.spec.mesh is not None for placed in self.objects)

    def validate(self, where: str = "scene") -> None:
        unknown = sorted(set(self.effects) - set(EFFECTS))
        if unknown:
            raise SceneError(f"{where}: effects contains unknown effect {unknown[0]!r} (known: {sorted(EFFECTS)})")
        if "friction" in self.effects and not self.effects & {"penetration", "soft_hand"}:
            raise SceneError(f"{where}: effects names 'friction' without a contact force ('penetration' or 'soft_hand')")
        if {"penetration", "soft_hand"} <= self.effects:
            raise SceneError(f"{where}: effects names both 'penetration' and 'soft_hand'; a scene has one hand model")
        if "continuous_collision" in self.effects and not self.effects & {"impulse", "penetration", "soft_hand"}:
            raise SceneError(f"{where}: effects names 'continuous_collision' without a contact model")
        gravity = np.asarray(self.gravity, dtype=float)
        if gravity.shape != (3,) or not np.isfinite(gravity).all():
            raise SceneError(f"{where}: gravity = {list(self.gravity)}: must be three finite numbers (m/s^2)")
        if gravity.any() and "gravity" not in self.effects:
            raise SceneError(f"{where}: gravity = {list(self.gravity)} but effects does not name 'gravity'")
        for name in ("tracking_rate", "penetration_stiffness", "resting_tolerance", "jump_distance"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise SceneError(f"{where}: {name} = {value!r}: must be a positive number")
        if not isinstance(self.substeps, int) or isinstance(self.substeps, bool) or self.substeps < 1:
            raise SceneError(f"{where}: substeps = {self.substeps!r}: must be a positive integer")
        if self.angular_integrator not in ANGULAR_INTEGRATORS:
            raise SceneError(f"{where}: angular_integrator = {self.angular_integrator!r}: "
                             f"must be one of {ANGULAR_INTEGRATORS}")
        for name in ("stiffness", "damping", "slip_velocity"):
            value = getattr(self.soft_hand, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise SceneError(f"{where}: soft_hand.{name} = {value!r}: must be a positive number")
        if ("table" in self.effects) != (self.table is not None):
            raise SceneError(f"{where}: effects {'names' if 'table' in self.effects else 'does not name'} 'table' "
                             f"but table = {self.table!r}; give both or neither")
        if self.table is not None:
            for name in ("height", "stiffness", "damping", "slip_velocity"):
                value = getattr(self.table, name)
                if not isinstance(value, (int, float)) or not math.isfinite(value) or (name != "height" and value <= 0):
                    raise SceneError(f"{where}: table.{name} = {value!r}: must be a "
                                     f"{'finite' if name == 'height' else 'positive'} number")
        if not self.objects:
            raise SceneError(f"{where}: objects is empty; a scene needs at least one object")
        names = [placed.spec.name for placed in self.objects]
        twice = sorted({name for name in names if names.count(name) > 1})
        if twice:
            raise SceneError(f"{where}: objects has two objects named {twice[0]!r}")
        for i, placed in enumerate(self.objects):
            label = f"{where}: objects[{i}] ({placed.spec.name})"
            placed.spec.validate(label)
            for name, length in (("position", 3), ("orientation", 4), ("velocity", 3), ("angular_velocity", 3)):
                value = np.asarray(getattr(placed, name), dtype=float)
                if value.shape != (length,) or not np.isfinite(value).all():
                    raise SceneError(f"{label}.{name} = {list(getattr(placed, name))}: "
                                     f"must be {length} finite numbers")
            norm = float(np.linalg.norm(placed.orientation))
            if abs(norm - 1.0) > 1e-6:
                raise SceneError(f"{label}.orientation = {list(placed.orientation)}: "
                                 f"not a unit quaternion (norm {norm:.6g})")


def compose_scene(objects: list[PlacedObject] | tuple[PlacedObject, ...], interaction: str = "impulse_penetration",
                  gravity=(0.0, 0.0, 0.0), effects=ENVIRONMENT_EFFECTS, **options) -> Scene:
    """A scene running ``interaction`` plus ``effects``, with gravity named when it is not zero and
    the table when ``table`` (TableParameters) is given."""
    if interaction not in INTERACTION_MODELS:
        raise SceneError(f"interaction = {interaction!r}: must be one of {sorted(INTERACTION_MODELS)}")
    named = set(INTERACTION_MODELS[interaction]) | set(effects)
    if any(gravity):
        named.add("gravity")
    if options.get("table") is not None:
        named.add("table")
    return Scene(objects=tuple(objects), effects=frozenset(named),
                 gravity=tuple(float(g) for g in gravity), **options)


def with_interaction(scene: Scene, interaction: str) -> Scene:
    """The same scene with its contact model swapped for another interaction model."""
    if interaction not in INTERACTION_MODELS:
        raise SceneError(f"interaction = {interaction!r}: must be one of {sorted(INTERACTION_MODELS)}")
    contact_effects = frozenset().union(*INTERACTION_MODELS.values())
    return replace(scene, effects=(scene.effects - contact_effects) | INTERACTION_MODELS[interaction])


def load_scene(path: str | Path) -> Scene:
    """Read a scene file (TOML); object files are resolved relative to it."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise SceneError(f"{path}: cannot read scene file: {error}") from None
    where = str(path)
    objects = []
    for i, entry in enumerate(data.pop("objects", [])):
        if "file" not in entry:
            raise SceneError(f"{where}: objects[{i}] has no 'file'")
        spec = load_object(path.parent / entry.pop("file"))
        unknown = set(entry) - {"position", "orientation", "orientation_deg", "velocity", "angular_velocity"}
        if unknown:
            raise SceneError(f"{where}: objects[{i}] has unknown field {sorted(unknown)[0]!r}")
        for name, value in entry.items():
            if not isinstance(value, list):
                raise SceneError(f"{where}: objects[{i}].{name} = {value!r}: must be a list of numbers")
        if "orientation_deg" in entry:
            from .rotation import quat_from_euler_deg
            angles = entry.pop("orientation_deg")
            if len(angles) != 3:
                raise SceneError(f"{where}: objects[{i}].orientation_deg = {angles!r}: must be [roll, pitch, yaw]")
            entry["orientation"] = quat_from_euler_deg(*angles)
        objects.append(PlacedObject(spec, **{k: tuple(v) for k, v in entry.items()}))
    interaction = data.pop("interaction", None)
    effects = set(data.pop("effects", []))
    if interaction is not None:
        if interaction not in INTERACTION_MODELS:
            raise SceneError(f"{where}: interaction = {interaction!r}: must be one of {sorted(INTERACTION_MODELS)}")
        effects |= INTERACTION_MODELS[interaction]
    for name, settings in (("soft_hand", SoftHandParameters), ("table", TableParameters)):
        if name in data:
            section, allowed = data[name], sorted(settings.__dataclass_fields__)
            if not isinstance(section, dict):
                raise SceneError(f"{where}: {name} = {section!r}: must be a table with fields {allowed}")
            if unknown := set(section) - set(allowed):
                raise SceneError(f"{where}: unknown field {name}.{sorted(unknown)[0]} (known: {allowed})")
            data[name] = settings(**section)
    options = {"tracking_rate" if k == "tracking_rate_hz" else k: v for k, v in data.items()}
    known = {f for f in Scene.__dataclass_fields__} - {"objects", "effects"}
    unknown = set(options) - known
    if unknown:
        raise SceneError(f"{where}: unknown field {sorted(unknown)[0]!r}")
    if "gravity" in options:
        if not isinstance(options["gravity"], list):
            raise SceneError(f"{where}: gravity = {options['gravity']!r}: must be three numbers [x, y, z] (m/s^2)")
        options["gravity"] = tuple(options["gravity"])
    scene = Scene(objects=tuple(objects), effects=frozenset(effects), **options)
    scene.validate(where)
    return scene
