"""Protocol files: what a study is, read from TOML and validated once, here.

A protocol declares the groups and their balancing, the objects and the order scheme, the
pick-and-place task and its rules, the stages and the interaction model each one runs, the
training, the questionnaire and the timeline. ``protocols/paper.toml`` is the paper's study
(section 4.3) and documents every key. A file may start from another one with
``extends = "other.toml"``: its tables are merged key by key over the other's, and lists
(``groups``, ``stages``, ``timeline``, ...) replace the other's lists whole.

Every error names the file, the key and the value::

    protocols/mine.toml: task.hold_s = -3: must be a positive number (seconds)
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from microg.paths import OBJECTS
from microg.sim import INTERACTION_MODELS, ObjectSpec, PlacedObject, Scene, SceneError
from microg.sim.bodies import object_from_dict
from microg.sim.rotation import quat_to_matrix
from microg.task.rules import TaskRules

PHASES_INFO = ("orientation", "instructions")
"""Timeline phases that show text and log their start and end."""
ORDER_SCHEMES = ("latin_square", "permutation")
BALANCING = ("gender", "none")
SCENE_OPTIONS = ("tracking_rate", "substeps", "penetration_stiffness", "angular_integrator", "resting_tolerance",
                 "jump_distance")
"""Physics settings a protocol may set besides gravity (see ``microg.sim.Scene``)."""
FILTER_WINDOW = 3
"""F in Eq. 1 unless the protocol's ``scene.filter_window`` says otherwise; the paper found 3 best."""


class ProtocolError(ValueError):
    """A protocol file that cannot be used; the message names the file, key and value."""


@dataclass(frozen=True)
class Group:
    code: str
    name: str
    size: int
    training: bool
    simulated_profile: str
    """Skill profile a simulated participant of this group plays (``veteran``, ``beginner``)."""


@dataclass(frozen=True)
class StudyObject:
    """An object of the study: its physics definition and the code the paper gives it (C, F, L)."""

    name: str
    code: str
    spec: ObjectSpec
    source: str = field(repr=False)
    """The object file's text, kept with the study so a session can be re-simulated exactly."""


@dataclass(frozen=True)
class Stage:
    name: str
    system: str
    """The interaction model the stage runs (``microg.sim.INTERACTION_MODELS``)."""
    label: str
    """How the system is named to the participant (the questionnaire asks about it by this)."""


@dataclass(frozen=True)
class Training:
    groups: tuple[str, ...]
    system: str
    objects: tuple[StudyObject, ...]


@dataclass(frozen=True)
class Item:
    name: str
    question: str
    low: str
    high: str


@dataclass(frozen=True)
class Questionnaire:
    scale_min: int
    scale_max: int
    items: tuple[Item, ...]


@dataclass(frozen=True)
class Phase:
    name: str
    minutes: float
    text: str = ""
    groups: tuple[str, ...] | None = None
    """Only these groups go through the phase; None: everyone."""


@dataclass(frozen=True)
class Protocol:
    name: str
    title: str
    where: str
    """The file it was read from (or the study database), for messages."""
    seed: int | None
    duration_minutes: float
    gravity: tuple[float, float, float]
    table_height: float | None
    """y of the table the object starts on (m); None: no table (microgravity)."""
    scene_options: dict
    filter_window: int
    """F of the window filter on the tracked hand (Eq. 1, ``microg.hands.filter``)."""
    total_participants: int
    balance: str
    age_range: tuple[int, int] | None
    groups: tuple[Group, ...]
    objects: tuple[StudyObject, ...]
    order: str
    task: TaskRules
    training: Training | None
    stages: tuple[Stage, ...]
    questionnaire: Questionnaire | None
    timeline: tuple[Phase, ...]
    frame_batch: int
    resolved: dict = field(repr=False, compare=False)
    """The merged protocol as plain data, with object file texts: what the study database keeps."""

    def group(self, code: str) -> Group:
        return next(g for g in self.groups if g.code == code)

    def object(self, name: str) -> StudyObject:
        known = {o.name: o for o in self.objects + (self.training.objects if self.training else ())}
        return known[name]

    def start_pose(self, name: str) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """Where the object ``name`` waits at the start of a task: at ``task.start``, or, with a
        table, standing on it below that point (its lowest point on the table top)."""
        x, y, z = self.task.start
        if self.table_height is not None:
            rot = quat_to_matrix(np.asarray(self.task.start_orientation, dtype=float))
            y = self.table_height + float(np.abs(rot[1]) @ self.object(name).spec.half_extents)
        return (x, y, z), self.task.start_orientation

    def phases_for(self, group: str) -> tuple[Phase, ...]:
        """The timeline as a participant of ``group`` goes through it."""
        return tuple(p for p in self.timeline if p.groups is None or group in p.groups)

    @property
    def systems(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(s.system for s in self.stages))

    @property
    def tracking_rate(self) -> float:
        """Nominal hand-frame rate (Hz): the protocol's scene option, else the physics' default."""
        return float(self.scene_options.get("tracking_rate", Scene.tracking_rate))

    @property
    def sha256(self) -> str:
        return hashlib.sha256(canonical_json(self.resolved).encode()).hexdigest()


def canonical_json(data: dict) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"))


# ---------------------------------------------------------------- reading files


def _read_toml(path: Path) -> tuple[dict, str]:
    try:
        text = path.read_text()
    except OSError as error:
        raise ProtocolError(f"{path}: cannot read protocol file: {error.strerror}") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as error:
        raise ProtocolError(f"{path}: not valid TOML: {error}") from None


def _merge(base: dict, override: dict) -> dict:
    merged = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def _resolve(path: Path, chain: tuple[Path, ...] = ()) -> tuple[dict, list[dict]]:
    """The file merged over the files it extends, and the texts of all of them (base first)."""
    path = path.resolve()
    if path in chain:
        raise ProtocolError(f"{chain[-1]}: extends = {path.name!r}: the files extend each other in a circle")
    data, text = _read_toml(path)
    sources = [{"file": path.name, "text": text}]
    base_name = data.pop("extends", None)
    if base_name is None:
        return data, sources
    if not isinstance(base_name, str):
        raise ProtocolError(f"{path}: extends = {base_name!r}: must be a file name")
    base_path = path.parent / base_name
    if not base_path.exists():
        raise ProtocolError(f"{path}: extends = {base_name!r}: no such file {base_path}")
    base, base_sources = _resolve(base_path, chain + (path,))
    return _merge(base, data), base_sources + sources


def _object_file(name: str, protocol_dir: Path | None) -> Path | None:
    for folder in ([protocol_dir / "objects"] if protocol_dir else []) + [OBJECTS]:
        candidate = folder / f"{name}.toml"
        if candidate.exists():
            return candidate
    return None


def load_protocol(path: str | Path) -> Protocol:
    """Read and validate a protocol file (and the files it extends, and its object files)."""
    path = Path(path)
    data, sources = _resolve(path)
    objects = {}
    names = []
    reader = _Reader(str(path), data)
    for section, key in (("objects", "names"), ("training", "objects")):
        table = data.get(section)
        if isinstance(table, dict) and isinstance(table.get(key), list):
            names += table[key]
    for name in names:
        if not isinstance(name, str):
            continue  # reported by the validation below, with its key
        found = _object_file(name, path.parent)
        if found is None:
            known = sorted(p.stem for p in OBJECTS.glob("*.toml"))
            raise ProtocolError(f"{path}: object {name!r}: no object file {name}.toml next to the protocol "
                                f"(objects/) or shipped (shipped objects: {known})")
        objects[name] = found.read_text()
    resolved = dict(data, object_files=objects, sources=sources)
    return _build(reader, resolved)


def protocol_from_resolved(resolved: dict, where: str) -> Protocol:
    """The protocol a study database keeps (see ``Protocol.resolved``)."""
    data = {k: v for k, v in resolved.items() if k not in ("object_files", "sources")}
    return _build(_Reader(where, data), resolved)


# ---------------------------------------------------------------- validation

_MISSING = object()


class _Reader:
    """Reads one table, checks each value as it goes, and reports keys it never read."""

    def __init__(self, where: str, data: dict, prefix: str = ""):
        self.where, self.data, self.prefix, self.read = where, data, prefix, set()

    def fail(self, key: str, value, message: str) -> ProtocolError:
        return ProtocolError(f"{self.where}: {self.prefix}{key} = {value!r}: {message}")

    def raw(self, key: str, default=_MISSING):
        self.read.add(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            raise ProtocolError(f"{self.where}: missing key {self.prefix}{key}")
        return default

    def text(self, key: str, default=_MISSING, choices: tuple[str, ...] | None = None) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str) or (not value.strip() and default is _MISSING):
            raise self.fail(key, value, "must be a non-empty string")
        if choices is not None and value not in choices:
            raise self.fail(key, value, f"must be one of {list(choices)}")
        return value

    def number(self, key: str, default=_MISSING, *, positive: bool = True, unit: str = "") -> float:
        value = self.raw(key, default)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) \
                or (positive and value <= 0):
            raise self.fail(key, value, f"must be a {'positive ' if positive else ''}number{unit}")
        return float(value)

    def integer(self, key: str, default=_MISSING, minimum: int = 1):
        value = self.raw(key, default)
        if value is None and default is None:
            return None
        if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
            raise self.fail(key, value, f"must be a whole number >= {minimum}")
        return value

    def boolean(self, key: str, default=_MISSING) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, value, "must be true or false")
        return value

    def vector(self, key: str, length: int = 3, default=_MISSING) -> tuple[float, ...]:
        value = self.raw(key, default)
        if not isinstance(value, list) or len(value) != length or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value):
            raise self.fail(key, value, f"must be a list of {length} finite numbers"
                            + (" (metres, tracker frame: x right, y up, z toward the user)" if length == 3 else ""))
        return tuple(float(v) for v in value)

    def strings(self, key: str, default=_MISSING) -> tuple[str, ...]:
        value = self.raw(key, default)
        if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
            raise self.fail(key, value, "must be a list of non-empty strings")
        return tuple(value)

    def table(self, key: str, default=_MISSING) -> _Reader | None:
        value = self.raw(key, default)
        if value is None and default is None:
            return None
        if not isinstance(value, dict):
            raise self.fail(key, value, "must be a table")
        return _Reader(self.where, value, f"{self.prefix}{key}.")

    def tables(self, key: str) -> list[_Reader]:
        value = self.raw(key)
        if not isinstance(value, list) or not value or not all(isinstance(v, dict) for v in value):
            raise self.fail(key, value, f"must be a non-empty array of tables ([[{self.prefix}{key}]])")
        return [_Reader(self.where, v, f"{self.prefix}{key}[{i}].") for i, v in enumerate(value)]

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.read)
        if unknown:
            raise ProtocolError(f"{self.where}: unknown key {self.prefix}{unknown[0]} "
                                f"(known here: {sorted(self.read)})")


def _study_object(reader: _Reader, key: str, name: str, sources: dict) -> StudyObject:
    text = sources.get(name)
    if text is None:
        raise reader.fail(key, name, "no object file for this object in the protocol's data")
    where = f"{reader.where}: object {name}"
    try:
        data = tomllib.loads(text)
        spec = object_from_dict(data, where)
    except (tomllib.TOMLDecodeError, SceneError, TypeError) as error:
        raise ProtocolError(f"{where}: {error}") from None
    return StudyObject(name=name, code=str(data.get("code", name)), spec=spec, source=text)


def _build(top: _Reader, resolved: dict) -> Protocol:
    sources = resolved.get("object_files", {})
    name = top.text("name")
    title = top.text("title", "")
    top.text("description", "")
    seed = top.integer("seed", None, minimum=0)
    duration = top.number("duration_minutes", unit=" (minutes)")

    scene = top.table("scene")
    gravity = scene.vector("gravity")
    table_height = scene.raw("table_height", "none")
    if table_height == "none":
        table_height = None
    elif isinstance(table_height, bool) or not isinstance(table_height, (int, float)) \
            or not math.isfinite(table_height):
        raise scene.fail("table_height", table_height, 'must be a height (m) or "none"')
    options = {}
    for key in SCENE_OPTIONS:
        if key in scene.data:
            options[key] = scene.raw(key)
    filter_window = scene.integer("filter_window", FILTER_WINDOW)
    scene.done()

    people = top.table("participants")
    total = people.integer("total")
    balance = people.text("balance", "gender", BALANCING)
    age_range = people.raw("age_range", None)
    if age_range is not None:
        if not (isinstance(age_range, list) and len(age_range) == 2 and all(isinstance(a, int) for a in age_range)
                and 0 < age_range[0] <= age_range[1]):
            raise people.fail("age_range", age_range, "must be [youngest, oldest] in whole years")
        age_range = tuple(age_range)
    people.done()

    groups = []
    for g in top.tables("groups"):
        code = g.text("code")
        if not code.isalnum():
            raise g.fail("code", code, "must be letters and digits only")
        groups.append(Group(code=code, name=g.text("name"), size=g.integer("size"),
                            training=g.boolean("training", False),
                            simulated_profile=g.text("simulated_profile", g.data.get("name", code))))
        g.done()
    codes = [g.code for g in groups]
    if len(set(codes)) != len(codes):
        raise top.fail("groups", codes, "two groups share a code")
    if sum(g.size for g in groups) != total:
        raise people.fail("total", total, f"the group sizes add up to {sum(g.size for g in groups)}")

    objects_table = top.table("objects")
    object_names = objects_table.strings("names")
    if len(set(object_names)) != len(object_names):
        raise objects_table.fail("names", list(object_names), "an object is named twice")
    objects = tuple(_study_object(objects_table, "names", n, sources) for n in object_names)
    order = objects_table.text("order", choices=ORDER_SCHEMES)
    objects_table.done()

    t = top.table("task")
    t.text("kind", "pick_and_place", ("pick_and_place",))
    places = t.raw("places")
    if not isinstance(places, list) or not places:
        raise t.fail("places", places, "must be a non-empty list of positions [x, y, z] (m)")
    place_reader = _Reader(t.where, {f"places[{i}]": p for i, p in enumerate(places)}, t.prefix)
    task = TaskRules(
        start=t.vector("start"),
        start_orientation=t.vector("start_orientation", 4, [1.0, 0.0, 0.0, 0.0]),
        places=tuple(place_reader.vector(f"places[{i}]") for i in range(len(places))),
        place_radius=t.number("place_radius", unit=" (m)"),
        hold_s=t.number("hold_s", unit=" (seconds)"),
        timeout_s=t.number("timeout_s", unit=" (seconds)"),
        grasp_settle_s=t.number("grasp_settle_s", 0.1, positive=False, unit=" (seconds)"),
        drop_grace_s=t.number("drop_grace_s", 0.25, positive=False, unit=" (seconds)"),
        workspace_min=t.vector("workspace_min"),
        workspace_max=t.vector("workspace_max"),
    )
    if task.grasp_settle_s < 0 or task.drop_grace_s < 0:
        bad = "grasp_settle_s" if task.grasp_settle_s < 0 else "drop_grace_s"
        raise t.fail(bad, getattr(task, bad), "must be >= 0 (seconds)")
    if abs(math.hypot(*task.start_orientation) - 1.0) > 1e-6:
        raise t.fail("start_orientation", list(task.start_orientation), "must be a unit quaternion [w, x, y, z]")
    if not all(lo < hi for lo, hi in zip(task.workspace_min, task.workspace_max)):
        raise t.fail("workspace_max", list(task.workspace_max), f"must exceed workspace_min = "
                     f"{list(task.workspace_min)} on every axis")
    for i, point in enumerate((task.start,) + task.places):
        key = "start" if i == 0 else f"places[{i - 1}]"
        if not all(lo <= p <= hi for lo, p, hi in zip(task.workspace_min, point, task.workspace_max)):
            raise t.fail(key, list(point), "lies outside the workspace (workspace_min .. workspace_max)")
    t.done()
    try:
        placed = PlacedObject(objects[0].spec, task.start, task.start_orientation)
        Scene(objects=(placed,), effects=frozenset({"gravity"}), gravity=gravity, **options).validate("scene")
    except SceneError as error:
        raise ProtocolError(f"{top.where}: {error}") from None

    stages = []
    for s in top.tables("stages"):
        system = s.text("system", choices=tuple(INTERACTION_MODELS))
        stage_name = s.text("name")
        if not stage_name.isalnum():
            raise s.fail("name", stage_name, "must be letters and digits only (it names files in exports)")
        stages.append(Stage(name=stage_name, system=system, label=s.text("label")))
        s.done()
    stage_names = [s.name for s in stages]
    if len(set(stage_names)) != len(stage_names):
        raise top.fail("stages", stage_names, "two stages share a name")

    training = None
    tr = top.table("training", None)
    if tr is not None:
        training_groups = tr.strings("groups")
        for code in training_groups:
            if code not in codes:
                raise tr.fail("groups", list(training_groups), f"names group {code!r}; groups are {codes}")
        training_objects = tr.strings("objects")
        training = Training(groups=training_groups, system=tr.text("system", choices=tuple(INTERACTION_MODELS)),
                            objects=tuple(_study_object(tr, "objects", n, sources) for n in training_objects))
        tr.done()
        flagged = tuple(g.code for g in groups if g.training)
        if set(flagged) != set(training_groups):
            raise tr.fail("groups", list(training_groups), f"differs from the groups marked training = true "
                          f"({list(flagged)})")

    questionnaire = None
    q = top.table("questionnaire", None)
    if q is not None:
        scale_min = q.integer("scale_min", minimum=0)
        scale_max = q.integer("scale_max", minimum=1)
        if scale_max <= scale_min:
            raise q.fail("scale_max", scale_max, f"must exceed scale_min = {scale_min}")
        items = []
        for it in q.tables("items"):
            items.append(Item(name=it.text("name"), question=it.text("question"), low=it.text("low"),
                              high=it.text("high")))
            it.done()
        questionnaire = Questionnaire(scale_min, scale_max, tuple(items))
        q.done()

    timeline = []
    known_phases = PHASES_INFO + (("training",) if training else ()) + tuple(stage_names) \
        + (("questionnaire",) if questionnaire else ())
    for p in top.tables("timeline"):
        phase_name = p.text("phase", choices=known_phases)
        phase_groups = p.strings("groups") if "groups" in p.data else None
        for code in phase_groups or ():
            if code not in codes:
                raise p.fail("groups", list(phase_groups), f"names group {code!r}; groups are {codes}")
        if phase_name == "training":
            phase_groups = training.groups
        timeline.append(Phase(name=phase_name, minutes=p.number("minutes", unit=" (minutes)"),
                              text=p.text("text", ""), groups=phase_groups))
        p.done()
    order_seen = [p.name for p in timeline]
    for required in (("training",) if training else ()) + tuple(stage_names) \
            + (("questionnaire",) if questionnaire else ()):
        if order_seen.count(required) != 1:
            raise top.fail("timeline", order_seen, f"must list phase {required!r} exactly once")
    if questionnaire and order_seen.index("questionnaire") < max(order_seen.index(s) for s in stage_names):
        raise top.fail("timeline", order_seen, "puts the questionnaire before a stage it asks about")
    total_minutes = sum(p.minutes for p in timeline)
    if total_minutes > duration + 1e-9:
        raise top.fail("duration_minutes", duration, f"the timeline's phases take {total_minutes:g} minutes")
    for phase in timeline:
        count = len(training.objects) if phase.name == "training" else \
            len(objects) if phase.name in stage_names else 0
        if count * task.timeout_s > phase.minutes * 60 + 1e-9:
            raise ProtocolError(
                f"{top.where}: timeline phase {phase.name!r} has minutes = {phase.minutes:g}, but its {count} "
                f"task(s) may take {count} x task.timeout_s = {count * task.timeout_s / 60:g} minutes")

    logging = top.table("logging", {})
    frame_batch = logging.integer("frame_batch", 64)
    logging.done()
    top.raw("object_files", None)
    top.raw("sources", None)
    top.done()
    return Protocol(name=name, title=title, where=top.where, seed=seed, duration_minutes=duration,
                    gravity=gravity, table_height=table_height, scene_options=options, filter_window=filter_window, total_participants=total, balance=balance,
                    age_range=age_range, groups=tuple(groups), objects=objects, order=order, task=task,
                    training=training, stages=tuple(stages), questionnaire=questionnaire, timeline=tuple(timeline),
                    frame_batch=frame_batch, resolved=resolved)
