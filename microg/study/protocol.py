"""Protocol files: what a study is, read from TOML and validated once, here.

A protocol declares the groups and their balancing, the objects and the order scheme, the
pick-and-place task and its rules, the phases and the interaction model each one runs, the
training and the timeline, which places the questionnaires: entries with ``instruments`` (files
of ``microg.instruments``: SSQ, IPQ, NASA-TLX, SUS, the paper's items, a study's own), asked
before, between or after the phases, once or about each interaction model.
``protocols/paper.toml`` is the paper's study (section 4.3) and documents every key;
``protocols/paper-vr.toml`` adds the questionnaires of VR research. A file may start from another one with
``extends = "other.toml"``: its tables are merged key by key over the other's, and lists
(``groups``, ``phases``, ``timeline``, ...) replace the other's lists whole.

Every error names the file, the key and the value::

    protocols/mine.toml: task.hold_s = -3: must be a positive number (seconds)

Values must also be sizes a study can have (``LIMITS`` below): a protocol file of at most a
megabyte, whole numbers the study database stores, positions within ``MAX_DISTANCE`` of the
tracker, a session of at most a day, a physics that steps at most ``MAX_STEP_RATE`` times a second.

Each section of the file has its own reader below (``_read_scene``, ``_read_groups``, ...); the
checks that span sections (every object in every phase's world, object codes, the timeline's
minutes) run once all sections are read. What only simulated participants need (skill profiles,
instruments the rating model answers) is reported by ``Protocol.simulation_problems``:
``microg study init`` warns about it, and a simulated session refuses to start.
"""

from __future__ import annotations

import base64
import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from microg.hands.filter import FILTER_WINDOW
from microg.hands.guard import GuardConfig
from microg.instruments import IDENTIFIER, Instrument, InstrumentError, instrument_file, read_instrument, \
    shipped_instruments
from microg.paths import OBJECTS, POPULATIONS
from microg.sim import INTERACTION_MODELS, ObjectSpec, PlacedObject, Scene, SceneError, TableParameters, compose_scene
from microg.sim.bodies import object_from_dict
from microg.sim.rotation import quat_to_matrix
from microg.skeleton import SIDES
from microg.task import KINDS, PICK_AND_PLACE, TaskRules
from microg.task.kind import MAX_DISTANCE, inside

if TYPE_CHECKING:
    from microg.participant import Population, SkillProfile

PRACTICE = "practice"
"""The simulated profile of the default population: every participant draws their own parameters,
and practice improves them with each task done (``microg.study.inputs.SimulatedInputs``)."""
PHASES_INFO = ("orientation", "instructions")
"""Timeline phases that show text and log their start and end."""
ABOUT_EACH = "each"
"""A questionnaire's ``about``: asked once about each interaction model the phases compare."""
ORDER_SCHEMES = ("latin_square", "permutation")
BALANCING = ("gender", "none")
SCENE_OPTIONS = ("tracking_rate", "substeps", "penetration_stiffness", "angular_integrator", "resting_tolerance")
"""Physics settings a protocol may set besides gravity (see ``microg.sim.Scene``)."""
LABEL = re.compile(r"[A-Za-z0-9]+")
"""What a name must be when it becomes a BIDS label or a file name part (ASCII letters and digits)."""

# ---------------------------------------------------------------- LIMITS: sizes a study can have
MAX_FILE_BYTES = 1 << 20
"""A protocol or object file is a few kilobytes; a megabyte is not one."""
MAX_INTEGER = 2**63 - 1
"""Whole numbers (seeds, counts) are stored by the study database, whose integers are 64-bit."""
MAX_GRAVITY = 100.0
"""m/s^2: ten times Earth's."""
MAX_MINUTES = 24 * 60
"""A session is one sitting: at most a day."""
MAX_STEP_RATE = 100_000
"""Physics steps per second of session time (tracking_rate x substeps); a step of the paper's scene
costs about 12 us here, so more would run slower than real time."""
MAX_FILTER_WINDOW = 100
"""Frames in the window filter (F); its lag is (F - 1) / 2 frames: 0.45 s at 110 Hz."""
MAX_FRAME_BATCH = 10_000
"""Frames per database transaction: a crash loses at most these (90 s at 110 Hz)."""
MAX_PLACES = 100
MAX_TASKS = 10_000
"""The most tasks a phase that trains to a criterion runs, and its tasks in a row."""
MAX_AGE = 150
FOV_RANGE = (10.0, 120.0)
"""Degrees: the vertical field of view a screen may span from the eyes (as ``--fov``)."""
MAX_ADDED_LATENCY_MS = 1000.0
"""ms a phase may add to what the participant's page shows: studies of latency and agency vary it
up to 350 ms (Waltemate et al., VRST 2016); a second is already no real-time view."""


class ProtocolError(ValueError):
    """A protocol file that cannot be used; the message names the file, key and value."""


@dataclass(frozen=True)
class Group:
    code: str
    name: str
    size: int
    training: bool
    simulated_profile: str
    """What a simulated participant of this group plays, as the protocol names it: ``practice``
    (the default population), a population file ``FILE.toml`` (relative to the protocol), or one
    of the fixed skills ``veteran`` and ``beginner``."""
    player: Population | SkillProfile | None = field(default=None, compare=False)
    """That profile, read (``simulated_player``); None where it names nothing a simulated
    participant can play (``Protocol.simulation_problems`` says so)."""


@dataclass(frozen=True)
class StudyObject:
    """An object of the study: its physics definition and the code the paper gives it (C, F, L)."""

    name: str
    code: str
    spec: ObjectSpec
    source: str = field(repr=False)
    """The object file's text, kept with the study so a session can be re-simulated exactly."""


@dataclass(frozen=True)
class Viewpoint:
    """The participant's view on a screen (the protocol's ``display`` table): where the eyes are
    relative to the tracker and where the view centres (m, tracker frame), and the vertical field
    of view the screen spans (degrees). None: frame the task's start and places."""

    eye: tuple[float, float, float] | None = None
    look_at: tuple[float, float, float] | None = None
    fov_deg: float = 40.0


STAIRCASE_RULES = {"1-up-1-down": 1, "2-down-1-up": 2, "3-down-1-up": 3}
"""Levitt's (1971) transformed up-down rules: how many successes in a row make the task harder (one
failure makes it easier): they converge on 50 %, 70.7 % and 79.4 % successes."""


@dataclass(frozen=True)
class Criterion:
    """A proficiency criterion (a phase's ``until``): a task counts when it was completed within
    ``time_s`` with at most ``attempts``; ``consecutive`` counting tasks in a row meet it. An
    object's own thresholds (``objects``: its code, then time_s and attempts) replace the phase's for
    that object's tasks."""

    time_s: float
    attempts: int
    consecutive: int
    objects: tuple[tuple[str, float, int], ...] = ()

    def counts(self, object_code: str, completed: bool, time_s: float | None, attempts: int | None) -> bool:
        """Whether a task of ``object_code`` that ended so counts toward the criterion."""
        limit, most = next(((t, a) for code, t, a in self.objects if code == object_code),
                           (self.time_s, self.attempts))
        return bool(completed) and time_s is not None and time_s <= limit and (attempts or 0) <= most


@dataclass(frozen=True)
class Staircase:
    """A phase's adaptive difficulty (``[phases.staircase]``): one number of its task kind
    (``parameter``, one the kind declares: ``Kind.difficulty``) starts at ``start`` and moves by
    ``step`` (added) or ``factor`` (multiplied) after each task by a transformed up-down ``rule``
    (``STAIRCASE_RULES``), within ``minimum`` .. ``maximum``. A success is a task that meets the
    phase's criterion (or is completed, without one)."""

    parameter: str
    start: float
    step: float | None
    factor: float | None
    rule: str
    minimum: float
    maximum: float


@dataclass(frozen=True)
class TaskPhase:
    """One of the protocol's ``[[phases]]``: a block of tasks the study compares (the paper's stage 1
    and stage 2), or trains with. Its name is also a phase of the timeline (``Phase``). A phase with
    a criterion (``until``) repeats its task, its objects in turn, until the criterion is met or
    ``max_tasks`` were done; a staircase adapts one number of its task from task to task."""

    name: str
    interaction: str
    """The interaction model the phase's tasks run (``microg.sim.INTERACTION_MODELS``)."""
    label: str
    """How the interaction model is named to the participant (the questionnaire asks about it by this)."""
    added_latency_ms: float = 0.0
    """Display latency the phase adds (ms): the participant's page shows each frame this much later
    than the physics had it (the physics and the log are not delayed)."""
    kind: str = PICK_AND_PLACE
    """The task kind its tasks are (``microg.task.KINDS``; default: the ``task`` table's ``kind``)."""
    until: Criterion | None = None
    max_tasks: int | None = None
    """The most tasks a phase with a criterion runs (its bound)."""
    staircase: Staircase | None = None
    cycle: tuple[str, ...] = ()
    """The objects (names) a phase with a criterion gives in turn (empty: the protocol's ``objects``)."""


@dataclass(frozen=True)
class SessionPlan:
    """One of the protocol's ``[[sessions]]``: a sitting of a training program, its ``phases`` (names
    of ``[[phases]]`` and ``training``, in the timeline's order), at least ``after_days`` days after
    the participant's previous session (0 for the first) and, with ``within_days``, due within that
    many days more (past it, overdue: still runnable); ``groups``: only these groups have it (None:
    everyone)."""

    name: str
    phases: tuple[str, ...]
    after_days: int
    within_days: int | None = None
    groups: tuple[str, ...] | None = None


ONE_SESSION = "main"
"""The name of the one session of a protocol without ``[[sessions]]``."""


@dataclass(frozen=True)
class Training:
    groups: tuple[str, ...]
    interaction: str
    objects: tuple[StudyObject, ...]
    tasks: int
    """How many tasks training runs, going through ``objects`` in turn (default: one per object)."""
    timeout_s: float
    """A training task's time limit (s; default: the ``task`` table's ``timeout_s``)."""
    kind: str = PICK_AND_PLACE
    """The task kind training runs (default: the ``task`` table's ``kind``)."""

    @property
    def object_names(self) -> tuple[str, ...]:
        """The object of each training task, in order."""
        return tuple(self.objects[i % len(self.objects)].name for i in range(self.tasks))


@dataclass(frozen=True)
class Phase:
    name: str
    minutes: float
    text: str = ""
    groups: tuple[str, ...] | None = None
    """Only these groups go through the phase; None: everyone."""
    instruments: tuple[str, ...] = ()
    """A questionnaire phase: the instruments it asks, in order (``Protocol.instruments``)."""
    about: str | None = None
    """What a questionnaire asks about: the interaction model of one of ``[[phases]]`` (its name), each
    interaction model (``each``), or none (None)."""
    administration: str = ""
    """The name its answers are kept under (``pre``, ``post``, ...): its ``administration``, else its name."""
    session: str | None = None
    """The session it runs in (a training program's); None: every session that runs its phase of
    tasks, or the first session for a phase without tasks."""


@dataclass(frozen=True)
class Dataset:
    """Who made the study's data and under which terms (the protocol's optional ``dataset`` table):
    what the Motion-BIDS export's dataset description and sidecars say about it."""

    authors: tuple[str, ...] = ()
    license: str = ""
    institution: str = ""
    institution_address: str = ""
    department: str = ""


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
    jump_distance: float
    """How far (m) a hand may move between two frames before the tracking guard (and the physics, with
    the same rule) calls it a jump."""
    total_participants: int
    balance: str
    age_range: tuple[int, int] | None
    groups: tuple[Group, ...]
    objects: tuple[StudyObject, ...]
    order: str
    task: TaskRules
    training: Training | None
    phases: tuple[TaskPhase, ...]
    instruments: dict[str, Instrument]
    """The instruments the timeline asks, by id, as the study keeps them."""
    timeline: tuple[Phase, ...]
    frame_batch: int
    viewpoint: Viewpoint
    resolved: dict = field(repr=False, compare=False)
    """The merged protocol as plain data, with object file texts: what the study database keeps."""
    dataset: Dataset = Dataset()
    sessions: tuple[SessionPlan, ...] = ()
    """The training program's sessions (``[[sessions]]``); one, ``ONE_SESSION``, running the whole
    timeline, for a protocol without them."""
    _rules: dict[tuple[str, float], TaskRules] = field(default_factory=dict, repr=False, compare=False)
    """``rules`` of each kind and time limit but the ``task`` table's, made once."""

    def group(self, code: str) -> Group:
        return next(g for g in self.groups if g.code == code)

    def object(self, name: str) -> StudyObject:
        known = {o.name: o for o in self.objects + (self.training.objects if self.training else ())}
        return known[name]

    def start_pose(self, name: str) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """Where the object ``name`` waits at the start of a task: at ``task.start``, or, with a
        table, standing on it below that point (its lowest point on the table top: a box's corner, a
        mesh's vertex)."""
        x, y, z = self.task.start
        if self.table_height is not None:
            rot = quat_to_matrix(np.asarray(self.task.start_orientation, dtype=float))
            spec = self.object(name).spec
            below = (-float((spec.mesh.vertices @ rot[1]).min()) if spec.mesh is not None
                     else float(np.abs(rot[1]) @ spec.half_extents))
            y = self.table_height + below
        return (x, y, z), self.task.start_orientation

    def scene(self, name: str, interaction: str, kind: str = PICK_AND_PLACE, rules: TaskRules | None = None) -> Scene:
        """The physics scene of a task of ``kind`` with object ``name`` under ``interaction``: the object
        alone at its start pose (on the table, if there is one), moving as the kind starts it by
        ``rules`` (the protocol's task, unless a staircase changed them: ``start_motion``), under the
        protocol's gravity and scene options, with the tracking guard's jump distance (the world
        applies the jump rule too: ``microg.sim.hand_path``)."""
        position, orientation = self.start_pose(name)
        velocity, angular_velocity = self.start_motion(kind, rules)
        placed = PlacedObject(self.object(name).spec, position, orientation, velocity, angular_velocity)
        table = None if self.table_height is None else TableParameters(height=self.table_height)
        return compose_scene([placed], interaction, self.gravity, table=table, jump_distance=self.guard.jump_distance,
                             **self.scene_options)

    def start_motion(self, kind: str, rules: TaskRules | None = None
                     ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The velocity (m/s) and angular velocity (rad/s, tracker frame) a task of ``kind`` starts its
        object with by ``rules`` (default: the protocol's task): the kind's ``start_motion`` (a
        catch's launch, a stop of a spin's spin); at rest for a kind without one."""
        start_motion = KINDS[kind].start_motion
        return ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) if start_motion is None else start_motion(rules or self.task)

    def kind(self, phase: str) -> str:
        """The task kind of a phase of tasks (the training, or one of ``[[phases]]``)."""
        if phase == "training" and self.training is not None:
            return self.training.kind
        return next((p.kind for p in self.phases if p.name == phase), self.task.kind)

    def rules(self, phase: str, difficulty: float | None = None) -> TaskRules:
        """The rules a phase's tasks are judged by: the ``task`` table's, of the phase's kind and, for
        the training, with its own time limit (one object per kind and limit, made once); with a
        staircase's ``difficulty``, its number set to that value (``Kind.difficulty``)."""
        if difficulty is not None:
            staircase = self.phase(phase).staircase
            return KINDS[self.kind(phase)].difficulty[staircase.parameter].set(self.rules(phase), difficulty)
        kind = self.kind(phase)
        timeout_s = self.training.timeout_s if phase == "training" and self.training is not None else \
            self.task.timeout_s
        if kind == self.task.kind and timeout_s == self.task.timeout_s:
            return self.task
        if (kind, timeout_s) not in self._rules:
            self._rules[kind, timeout_s] = replace(self.task, kind=kind, timeout_s=timeout_s)
        return self._rules[kind, timeout_s]

    def simulation_problems(self) -> list[str]:
        """What a simulated participant could not do with this protocol (each names file, key and
        value): a group's skill profile that does not exist, an instrument the rating model does not
        answer. Empty when simulated sessions can run it (it plays every task kind)."""
        from microg.participant.ratings import unanswered

        problems = self.player_problems()
        for i, phase in enumerate(self.timeline):
            for name in phase.instruments:
                why = unanswered(self.instruments[name])
                if why:
                    problems.append(f"{self.where}: timeline[{i}].instruments = {list(phase.instruments)}: {name}: "
                                    f"{why}")
        return problems

    def player_problems(self) -> list[str]:
        """Each group whose ``simulated_profile`` names nothing a simulated participant can play."""
        return [f"{self.where}: groups[{i}].simulated_profile = {group.simulated_profile!r}: simulated participants "
                f"play a population file (FILE.toml) or one of {profile_names()} (the default is the group's name)"
                for i, group in enumerate(self.groups) if group.player is None]

    def about(self, phase: Phase) -> tuple[TaskPhase | None, ...]:
        """The phases of tasks whose interaction models a questionnaire phase asks about, in order (None:
        about no interaction model)."""
        return _about(phase, self.phases)

    def phases_for(self, group: str, session: str | None = None) -> tuple[Phase, ...]:
        """The timeline as a participant of ``group`` goes through it in ``session`` (default: the
        group's first): the phases of tasks the session runs, the entries that name it, and, in the
        group's first session, the other entries that name no session."""
        plans = self.sessions_for(group)
        plan = plans[0] if session is None else self.session(session)
        out = []
        for entry in self.timeline:
            if entry.groups is not None and group not in entry.groups:
                continue
            if entry.session is not None:
                keep = entry.session == plan.name
            elif self.runs_tasks(entry):
                keep = entry.name in plan.phases
            else:
                keep = plan.name == plans[0].name
            if keep:
                out.append(entry)
        return tuple(out)

    def sessions_for(self, group: str) -> tuple[SessionPlan, ...]:
        """The sessions a participant of ``group`` has, in order."""
        return tuple(s for s in self.sessions if s.groups is None or group in s.groups)

    def session(self, name: str) -> SessionPlan:
        """The session called ``name`` (KeyError naming the protocol's sessions for another)."""
        for plan in self.sessions:
            if plan.name == name:
                return plan
        raise KeyError(f"protocol {self.name!r} has no session {name!r} (its sessions: "
                       f"{', '.join(s.name for s in self.sessions)})")

    @property
    def program(self) -> bool:
        """Whether the protocol declares sessions (a training program) rather than one sitting."""
        return "sessions" in self.resolved

    def phase(self, name: str) -> TaskPhase | None:
        """The one of ``[[phases]]`` called ``name`` (None: the training, or no phase of tasks)."""
        return next((p for p in self.phases if p.name == name), None)

    def added_latency_ms(self, phase: str) -> float:
        """The display latency a phase of tasks adds (ms; 0 for the training and any other phase)."""
        return next((p.added_latency_ms for p in self.phases if p.name == phase), 0.0)

    def runs_tasks(self, phase: Phase) -> bool:
        """Whether the timeline phase is one of tasks (the training, or one of ``[[phases]]``)."""
        return phase.name == "training" or any(p.name == phase.name for p in self.phases)

    @property
    def interactions(self) -> tuple[str, ...]:
        """The interaction models the phases compare, in the phases' order."""
        return tuple(dict.fromkeys(p.interaction for p in self.phases))

    @property
    def tracking_rate(self) -> float:
        """Nominal hand-frame rate (Hz): the protocol's scene option, else the physics' default."""
        return float(self.scene_options.get("tracking_rate", Scene.tracking_rate))

    @property
    def guard(self) -> GuardConfig:
        """The tracking guard's settings for this protocol: its frame rate and jump distance."""
        return GuardConfig(nominal_rate=self.tracking_rate, jump_distance=self.jump_distance)

    @property
    def sha256(self) -> str:
        return hashlib.sha256(canonical_json(self.resolved).encode()).hexdigest()


def canonical_json(data: dict) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"))


# ---------------------------------------------------------------- reading files


def _read_text(path: Path, what: str) -> str:
    """A file's text, or ProtocolError naming the file and why it cannot be read."""
    try:
        with open(path, "rb") as stream:
            raw = stream.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise ProtocolError(f"{path}: cannot read {what}: {error.strerror or error}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ProtocolError(f"{path}: over {MAX_FILE_BYTES >> 20} MiB: not a {what} (a few kilobytes of TOML)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ProtocolError(f"{path}: not UTF-8 text (byte {raw[error.start]:#04x} at position {error.start}); "
                            f"save the {what} as UTF-8") from None


def _read_toml(path: Path) -> tuple[dict, str]:
    text = _read_text(path, "protocol file")
    return _parse_toml(text, str(path), "protocol file"), text


def _parse_toml(text: str, where: str, what: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ProtocolError(f"{where}: not valid TOML: {error}") from None
    except RecursionError:
        raise ProtocolError(f"{where}: not a {what}: its tables or arrays are nested too deeply") from None


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
    if not isinstance(base_name, str) or not base_name:
        raise ProtocolError(f"{path}: extends = {base_name!r}: must be a file name")
    base_path = path.parent / base_name
    if not base_path.is_file():
        raise ProtocolError(f"{path}: extends = {base_name!r}: no such file {base_path}")
    base, base_sources = _resolve(base_path, chain + (path,))
    return _merge(base, data), base_sources + sources


def simulated_player(profile: str, protocol_dir: Path | None, stored: dict | None = None,
                     where: str = "") -> Population | SkillProfile | None:
    """What ``profile`` names for a simulated participant: the default population (``practice``), a
    population shipped with microg by its name (``literature``: ``POPULATIONS / NAME.toml``), a
    population file (``FILE.toml``: its text in ``stored`` when the protocol comes from a study's
    database, else read relative to ``protocol_dir``), a fixed skill (``veteran``, ``beginner``), or
    None for any other name. A population file that cannot be used raises PopulationError."""
    from microg.participant import PROFILES, PopulationError, default_population, read_population
    from microg.participant.population import population_from_dict

    if profile == PRACTICE:
        return default_population()
    if profile in PROFILES:
        return PROFILES[profile]
    if profile in shipped_populations():
        return read_population(POPULATIONS / f"{profile}.toml")
    if not profile.endswith(".toml"):
        return None
    if stored is not None and profile in stored:
        try:
            data = tomllib.loads(stored[profile])
        except tomllib.TOMLDecodeError as error:
            raise PopulationError(f"{where}: population {profile}: cannot be read as TOML: {error}") from None
        return population_from_dict(data, f"{where}: population {profile}")
    return read_population((protocol_dir or Path.cwd()) / profile)


def profile_names() -> list[str]:
    """The names a simulated participant's profile may be besides a population file: the default
    population, the shipped ones, the fixed skills."""
    from microg.participant import PROFILES

    return [PRACTICE] + shipped_populations() + sorted(PROFILES)


def shipped_populations() -> list[str]:
    """The names of the populations shipped with microg besides the default (``POPULATIONS``)."""
    return sorted(path.stem for path in POPULATIONS.glob("*.toml") if path.stem != "default")


def _object_file(name: str, protocol_dir: Path | None) -> Path | None:
    if not LABEL.fullmatch(name.replace("_", "").replace("-", "")):
        return None  # not a file name of an object (the validation below names the key)
    for folder in ([protocol_dir / "objects"] if protocol_dir else []) + [OBJECTS]:
        candidate = folder / f"{name}.toml"
        if candidate.is_file():
            return candidate
    return None


def _mesh_file(text: str, object_file: Path) -> Path | None:
    """The mesh file a mesh object's file names, when it is there (else the object's validation
    names what is wrong)."""
    try:
        name = tomllib.loads(text).get("mesh")
    except (tomllib.TOMLDecodeError, RecursionError):
        return None
    path = object_file.parent / name if isinstance(name, str) and name else None
    return path if path is not None and path.is_file() else None


def load_protocol(path: str | Path) -> Protocol:
    """Read and validate a protocol file (and the files it extends, and its object files)."""
    path = Path(path)
    data, sources = _resolve(path)
    objects, files, meshes = {}, {}, {}
    for section, key in (("objects", "names"), ("training", "objects")):
        table = data.get(section)
        names = table.get(key) if isinstance(table, dict) else None
        for i, name in enumerate(names if isinstance(names, list) else ()):
            if not isinstance(name, str) or not name or name in objects:
                continue  # reported by the validation below, with its key
            found = _object_file(name, path.parent)
            if found is None:
                known = sorted(p.stem for p in OBJECTS.glob("*.toml"))
                raise ProtocolError(f"{path}: {section}.{key}[{i}] = {name!r}: no object file {name}.toml next to "
                                    f"the protocol (objects/) or shipped (shipped objects: {known})")
            objects[name], files[name] = _read_text(found, "object file"), str(found)
            mesh = _mesh_file(objects[name], found)
            if mesh is not None:
                meshes[name] = base64.b64encode(mesh.read_bytes()).decode("ascii")
    instruments = _instrument_files(path, data, files)
    resolved = dict(data, object_files=objects, sources=sources)
    if meshes:
        resolved["mesh_files"] = meshes
    populations = {}
    for i, group in enumerate(data.get("groups") if isinstance(data.get("groups"), list) else ()):
        profile = group.get("simulated_profile") if isinstance(group, dict) else None
        if isinstance(profile, str) and profile.endswith(".toml") and profile not in populations:
            found = path.parent / profile
            if not found.is_file():
                raise ProtocolError(f"{path}: groups[{i}].simulated_profile = {profile!r}: no such population file "
                                    f"{found}")
            populations[profile] = _read_text(found, "population file")
    if populations:
        resolved["population_files"] = populations
    if instruments:
        resolved["instrument_files"] = instruments
    return _build(_Reader(str(path), data), resolved, files)


def _instrument_files(path: Path, data: dict, files: dict) -> dict[str, str]:
    """The texts of the instrument files the timeline names (next to the protocol in instruments/,
    else shipped); ``files`` gets where each came from."""
    texts = {}
    timeline = data.get("timeline")
    for i, entry in enumerate(timeline if isinstance(timeline, list) else ()):
        names = entry.get("instruments") if isinstance(entry, dict) else None
        for name in names if isinstance(names, list) else ():
            if not isinstance(name, str) or name in texts:
                continue  # reported by the validation below, with its key
            found = instrument_file(name, path.parent)
            if found is None:
                raise ProtocolError(f"{path}: timeline[{i}].instruments = {names!r}: no instrument {name!r}: no "
                                    f"file instruments/{name}.toml next to the protocol, and no shipped one "
                                    f"(shipped: {shipped_instruments()})")
            texts[name], files[f"instrument:{name}"] = _read_text(found, "instrument file"), str(found)
    return texts


def protocol_from_resolved(resolved: dict, where: str) -> Protocol:
    """The protocol a study database keeps (see ``Protocol.resolved``)."""
    if not isinstance(resolved, dict) or not isinstance(resolved.get("object_files", {}), dict):
        raise ProtocolError(f"{where}: the stored protocol is not a protocol table")
    data = {k: v for k, v in resolved.items() if k not in ("object_files", "mesh_files", "population_files",
                                                           "instrument_files", "sources")}
    return _build(_Reader(where, data), resolved, {})


# ---------------------------------------------------------------- validation

_MISSING = object()


def _is_number(value) -> bool:
    """A finite number that is not a bool (and not an integer beyond what a float holds)."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


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

    def label(self, key: str, why: str) -> str:
        """A name that becomes part of file names and BIDS labels: ASCII letters and digits."""
        value = self.text(key)
        if not LABEL.fullmatch(value):
            raise self.fail(key, value, f"must be ASCII letters and digits only ({why})")
        return value

    def number(self, key: str, default=_MISSING, *, positive: bool = True, unit: str = "",
               maximum: float | None = None) -> float:
        value = self.raw(key, default)
        if not _is_number(value) or (positive and value <= 0) or (not positive and value < 0):
            raise self.fail(key, value, f"must be a {'positive' if positive else 'non-negative'} number{unit}")
        if maximum is not None and value > maximum:
            raise self.fail(key, value, f"must be at most {maximum:g}{unit}")
        return float(value)

    def integer(self, key: str, default=_MISSING, minimum: int = 1, maximum: int = MAX_INTEGER):
        value = self.raw(key, default)
        if value is None and default is None:
            return None
        if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
            raise self.fail(key, value, f"must be a whole number >= {minimum}")
        if value > maximum:
            raise self.fail(key, value, f"must be a whole number from {minimum} to {maximum}")
        return value

    def boolean(self, key: str, default=_MISSING) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, value, "must be true or false")
        return value

    def vector(self, key: str, *, length: int = 3, default=_MISSING, maximum: float | None = MAX_DISTANCE,
               unit: str = " (metres, tracker frame: x right, y up, z toward the user)") -> tuple[float, ...]:
        """A list of ``length`` finite numbers, each at most ``maximum`` from zero (positions: within
        ``MAX_DISTANCE`` of the tracker)."""
        value = self.raw(key, default)
        if not isinstance(value, list) or len(value) != length or not all(_is_number(v) for v in value):
            raise self.fail(key, value, f"must be a list of {length} finite numbers{unit if length == 3 else ''}")
        if maximum is not None and max(abs(v) for v in value) > maximum:
            raise self.fail(key, value, f"each number must lie within {maximum:g} of zero{unit}")
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

    def unique(self, key: str, values: list, what: str) -> None:
        """Refuse a list in which two entries are the same (case-insensitively for strings: they
        name files, and many disks do not tell case apart)."""
        folded = [v.casefold() if isinstance(v, str) else v for v in values]
        twice = next((v for v, f in zip(values, folded) if folded.count(f) > 1), None)
        if twice is not None:
            raise self.fail(key, list(values), f"{what} {twice!r} appears twice (case does not count)")

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.read, key=str)
        if unknown:
            raise ProtocolError(f"{self.where}: unknown key {self.prefix}{unknown[0]} "
                                f"(known here: {sorted(self.read)})")


# ---------------------------------------------------------------- one reader per section


def _read_scene(top: _Reader) -> tuple[tuple[float, float, float], float | None, dict, int, float]:
    """``[scene]``: gravity, table height, physics options, and hand tracking's window filter F and
    jump distance."""
    scene = top.table("scene")
    gravity = scene.vector("gravity", maximum=MAX_GRAVITY, unit=" (m/s^2)")
    table_height = scene.raw("table_height", "none")
    if table_height == "none":
        table_height = None
    elif not _is_number(table_height) or abs(table_height) > MAX_DISTANCE:
        raise scene.fail("table_height", table_height, f'must be a height (m, within {MAX_DISTANCE:g} of the '
                                                       'tracker) or "none"')
    options = {key: scene.raw(key) for key in SCENE_OPTIONS if key in scene.data}
    for key in options:  # the physics checks them all; here only that they are numbers it can hold
        if key == "substeps":
            scene.integer(key)
        elif key != "angular_integrator":
            scene.number(key)
    steps = float(options.get("tracking_rate", Scene.tracking_rate)) * options.get("substeps", Scene.substeps)
    if steps > MAX_STEP_RATE:
        key = "substeps" if "substeps" in options else "tracking_rate"
        raise scene.fail(key, options[key], f"the physics would step {steps:g} times a second "
                                            f"(tracking_rate x substeps); at most {MAX_STEP_RATE} run")
    filter_window = scene.integer("filter_window", FILTER_WINDOW, maximum=MAX_FILTER_WINDOW)
    jump_distance = scene.number("jump_distance", GuardConfig.jump_distance, unit=" (m)", maximum=MAX_DISTANCE)
    scene.done()
    return gravity, None if table_height is None else float(table_height), options, filter_window, jump_distance


def _read_participants(top: _Reader) -> tuple[_Reader, int, str, tuple[int, int] | None]:
    """``[participants]``: how many, the balancing, the age range."""
    people = top.table("participants")
    total = people.integer("total")
    balance = people.text("balance", "gender", BALANCING)
    age_range = people.raw("age_range", None)
    if age_range is not None:
        if not (isinstance(age_range, list) and len(age_range) == 2
                and all(isinstance(a, int) and not isinstance(a, bool) for a in age_range)
                and 0 < age_range[0] <= age_range[1] <= MAX_AGE):
            raise people.fail("age_range", age_range, f"must be [youngest, oldest] in whole years (at most {MAX_AGE})")
        age_range = tuple(age_range)
    people.done()
    return people, total, balance, age_range


def _read_groups(top: _Reader, people: _Reader, total: int, populations: dict) -> tuple[Group, ...]:
    """``[[groups]]``: codes, names, sizes (adding up to the total), who trains, what a simulated
    participant of the group plays (its population file's text from ``populations``)."""
    from microg.participant import PopulationError

    groups = []
    for g in top.tables("groups"):
        code = g.label("code", "it names the group in every table")
        profile = g.text("simulated_profile", g.data.get("name", code))
        try:
            player = simulated_player(profile, None, populations, top.where)
        except PopulationError as error:
            raise g.fail("simulated_profile", profile, str(error)) from None
        groups.append(Group(code=code, name=g.text("name"), size=g.integer("size"),
                            training=g.boolean("training", False), simulated_profile=profile, player=player))
        g.done()
    top.unique("groups", [g.code for g in groups], "group code")
    if sum(g.size for g in groups) != total:
        raise people.fail("total", total, f"the group sizes add up to {sum(g.size for g in groups)}")
    return tuple(groups)


def _study_object(reader: _Reader, key: str, *, name: str, sources: dict, files: dict, meshes: dict) -> StudyObject:
    """One object from its file's text (and its mesh file's content, base64); errors name the object
    file (or, for a study's stored copy, the database and the file's name)."""
    text = sources.get(name)
    if not isinstance(text, str):
        raise reader.fail(key, name, "no object file for this object in the protocol's data")
    where = files.get(name) or f"{reader.where}: object file {name}.toml (as kept with the protocol)"
    mesh = meshes.get(name)
    data = _parse_toml(text, where, "object file")
    try:
        spec = object_from_dict(data, where, Path(files[name]).parent if name in files else Path("."),
                                base64.b64decode(mesh) if isinstance(mesh, str) else None)
    except SceneError as error:
        raise ProtocolError(str(error)) from None
    except (TypeError, ValueError) as error:
        raise ProtocolError(f"{where}: not a usable object file: {error}") from None
    code = data.get("code", name)
    if not isinstance(code, str) or not code.strip():
        raise ProtocolError(f"{where}: code = {code!r}: must be a non-empty string (it names the object in tables)")
    return StudyObject(name=name, code=code, spec=spec, source=text)


def _read_objects(top: _Reader, sources: dict, files: dict, meshes: dict) -> tuple[tuple[StudyObject, ...], str]:
    """``[objects]``: the tested objects (from their object files) and the order scheme."""
    table = top.table("objects")
    names = table.strings("names")
    table.unique("names", list(names), "object")
    objects = tuple(_study_object(table, f"names[{i}]", name=n, sources=sources, files=files, meshes=meshes) for i,
                    n in enumerate(names))
    order = table.text("order", choices=ORDER_SCHEMES)
    table.done()
    return objects, order


def _read_task(top: _Reader) -> TaskRules:
    """``[task]``: the default kind, start, places, radii, holds, timeouts, the workspace, and each
    kind's own numbers from its table (``[task.catch]`` ...: ``microg.task.Kind.read``)."""
    t = top.table("task")
    kind = t.text("kind", PICK_AND_PLACE, tuple(KINDS))
    places = t.raw("places")
    if not isinstance(places, list) or not places:
        raise t.fail("places", places, "must be a non-empty list of positions [x, y, z] (m)")
    if len(places) > MAX_PLACES:
        raise ProtocolError(f"{t.where}: {t.prefix}places: {len(places)} positions; at most {MAX_PLACES}")
    place_reader = _Reader(t.where, {f"places[{i}]": p for i, p in enumerate(places)}, t.prefix)
    task = TaskRules(
        start=t.vector("start"),
        start_orientation=t.vector("start_orientation", length=4, default=[1.0, 0.0, 0.0, 0.0], maximum=None),
        places=tuple(place_reader.vector(f"places[{i}]") for i in range(len(places))),
        place_radius=t.number("place_radius", unit=" (m)", maximum=MAX_DISTANCE),
        hold_s=t.number("hold_s", unit=" (seconds)"),
        timeout_s=t.number("timeout_s", unit=" (seconds)"),
        grasp_settle_s=t.number("grasp_settle_s", 0.1, positive=False, unit=" (seconds)"),
        drop_grace_s=t.number("drop_grace_s", 0.25, positive=False, unit=" (seconds)"),
        workspace_min=t.vector("workspace_min"),
        workspace_max=t.vector("workspace_max"),
    )
    if len(task.places) * task.hold_s >= task.timeout_s:
        raise t.fail("timeout_s", task.timeout_s, f"the {len(task.places)} holds of hold_s = {task.hold_s:g} s take "
                     "longer: no task could be completed")
    if abs(math.hypot(*task.start_orientation) - 1.0) > 1e-6:
        raise t.fail("start_orientation", list(task.start_orientation), "must be a unit quaternion [w, x, y, z]")
    if not all(lo < hi for lo, hi in zip(task.workspace_min, task.workspace_max)):
        raise t.fail("workspace_max", list(task.workspace_max), f"must exceed workspace_min = "
                     f"{list(task.workspace_min)} on every axis")
    for i, point in enumerate((task.start,) + task.places):
        key = "start" if i == 0 else f"places[{i - 1}]"
        if not inside(point, task):
            raise t.fail(key, list(point), "lies outside the workspace (workspace_min .. workspace_max)")
    tables = []
    for known in KINDS.values():
        table = t.table(known.table, None) if known.table else None
        if table is not None:
            tables.append((known.name, known.read(table, task)))
    task = replace(task, kind=kind, tables=tuple(tables))
    _needs_numbers(t, "kind", kind, task)
    t.done()
    return task


def _needs_numbers(reader: _Reader, key: str, kind: str, task: TaskRules) -> None:
    """Refuse a task kind whose table of numbers the ``task`` table lacks (``[task.catch]`` ...)."""
    table = KINDS[kind].table
    if table is not None and getattr(task, kind) is None:
        raise reader.fail(key, kind, f"a {kind} task needs its numbers: add a [task.{table}] table")


def _renamed(reader: _Reader, old: str, message: str) -> None:
    """Refuse a key an older protocol used: the message names the file and what the key became."""
    if old in reader.data:
        raise ProtocolError(f"{reader.where}: {message}")


def _read_phases(top: _Reader, task: TaskRules, objects: tuple[StudyObject, ...]) -> tuple[TaskPhase, ...]:
    """``[[phases]]``: each phase's name, the interaction model it runs, how the participant
    hears it named, the display latency it adds, its task kind, and for a phase that trains to a
    criterion its ``until``, ``max_tasks`` and ``staircase``. The report compares interaction models
    within each task kind, so no two phases of tests run the same model with the same kind (a phase
    that trains to a criterion may); phases of one model share its label (the participant hears one
    name for it, and is asked about it once)."""
    _renamed(top, "stages", "`[[stages]]` is now `[[phases]]`: rename the tables (their keys stay the same, "
                            "but `system` is now `interaction`)")
    phases = []
    for p in top.tables("phases"):
        _renamed(p, "system", f"{p.prefix}system is now {p.prefix}interaction (the interaction model the phase "
                              "runs)")
        interaction = p.text("interaction", choices=tuple(INTERACTION_MODELS))
        kind = p.text("kind", task.kind, tuple(KINDS))
        _needs_numbers(p, "kind", kind, task)
        until, max_tasks, cycle = _read_until(p, objects)
        phases.append(TaskPhase(name=p.label("name", "it names files in exports"), interaction=interaction,
                                label=p.text("label"),
                                added_latency_ms=p.number("added_latency_ms", 0.0, positive=False, unit=" (ms)",
                                                          maximum=MAX_ADDED_LATENCY_MS),
                                kind=kind, until=until, max_tasks=max_tasks, cycle=cycle,
                                staircase=_read_staircase(p, task, kind)))
        p.done()
    top.unique("phases", [p.name for p in phases], "phase name")
    for i, phase in enumerate(phases):
        for j, other in enumerate(phases[:i]):
            if (other.interaction, other.kind) == (phase.interaction, phase.kind) and not (other.until or phase.until):
                raise top.fail(f"phases[{i}].interaction", phase.interaction, f"phases[{j}] runs this interaction "
                               f"model already with the same task kind ({phase.kind}); the report compares "
                               "interaction models within each task kind: give this phase another model or kind")
            if (other.interaction == phase.interaction) != (other.label == phase.label):
                same = other.interaction == phase.interaction
                raise top.fail(f"phases[{i}].label", phase.label, f"phases[{j}] runs "
                               f"{'the same' if same else 'another'} interaction model and is labelled "
                               f"{other.label!r}: the participant hears each interaction model named by one label "
                               "of its own"
                               + ("" if same else f" ({phase.label!r} appears twice)"))
    return tuple(phases)


def _read_until(p: _Reader, objects: tuple[StudyObject, ...]
                ) -> tuple[Criterion | None, int | None, tuple[str, ...]]:
    """A phase's ``until`` (``time_s``, ``attempts``, ``consecutive``, and ``objects``: an object's code
    with its own ``time_s`` and ``attempts``), the ``max_tasks`` that bounds it (both or neither), and
    the ``objects`` it gives in turn (names of the protocol's objects; default: all of them)."""
    until = p.table("until", None)
    names = [o.name for o in objects]
    cycle = p.strings("objects") if "objects" in p.data else ()
    for name in cycle:
        if name not in names:
            raise p.fail("objects", list(cycle), f"names object {name!r}; the protocol's objects are {names}")
    if cycle and until is None:
        raise p.fail("objects", list(cycle), "only a phase trained to a criterion (until) chooses its objects; "
                     "the other phases give each participant's object order")
    max_tasks = p.integer("max_tasks", None, maximum=MAX_TASKS)
    if until is not None and max_tasks is None:
        raise p.fail("until", p.data["until"], "a criterion needs its bound: add max_tasks = N, the most tasks "
                     "the phase runs before it ends without the criterion met")
    if until is None and max_tasks is not None:
        raise p.fail("max_tasks", max_tasks, "bounds a phase that repeats its task until a criterion: add until = "
                     "{ time_s = ..., attempts = ..., consecutive = ... }")
    if until is None:
        return None, None, ()
    time_s = until.number("time_s", unit=" (seconds)")
    attempts = until.integer("attempts", minimum=0)
    own = []
    codes = {o.code for o in objects}
    by_object = until.table("objects", {})
    for code in list(by_object.data):
        if code not in codes:
            raise by_object.fail(code, by_object.data[code], f"names no object of the protocol (codes: {sorted(codes)})")
        one = by_object.table(code)
        own.append((code, one.number("time_s", time_s, unit=" (seconds)"), one.integer("attempts", attempts, minimum=0)))
        one.done()
    by_object.done()
    criterion = Criterion(time_s, attempts, until.integer("consecutive", 1, maximum=MAX_TASKS), tuple(own))
    until.done()
    return criterion, max_tasks, cycle


def _read_staircase(p: _Reader, task: TaskRules, kind: str) -> Staircase | None:
    """A phase's ``[phases.staircase]``: the number of its kind it adapts (``parameter``), ``start``,
    ``step`` or ``factor``, ``rule``, ``min`` and ``max``."""
    st = p.table("staircase", None)
    if st is None:
        return None
    adaptable = KINDS[kind].difficulty
    parameter = st.text("parameter")
    if parameter not in adaptable:
        raise st.fail("parameter", parameter, f"a {kind} task adapts none such: one of {sorted(adaptable)}"
                      if adaptable else f"a {kind} task has no number a staircase adapts")
    unit = f" ({adaptable[parameter].unit})"
    if ("step" in st.data) == ("factor" in st.data):
        raise st.fail("step", st.data.get("step"), "give the staircase either step = (added) or factor = "
                      "(multiplied), not both or neither")
    step = st.number("step", unit=unit) if "step" in st.data else None
    factor = st.number("factor") if "factor" in st.data else None
    if factor is not None and factor <= 1:
        raise st.fail("factor", factor, "must exceed 1 (the number is multiplied or divided by it)")
    rule = st.text("rule", choices=tuple(STAIRCASE_RULES))
    low, high = st.number("min", unit=unit), st.number("max", unit=unit)
    if low >= high:
        raise st.fail("min", low, f"must be below max = {high:g}")
    start = st.number("start", unit=unit)
    if not low <= start <= high:
        raise st.fail("start", start, f"must lie within min = {low:g} .. max = {high:g}")
    st.done()
    staircase = Staircase(parameter, start, step, factor, rule, low, high)
    for value in (low, high):
        try:
            KINDS[kind].difficulty[parameter].set(task, value)
        except (ValueError, ZeroDivisionError) as error:
            raise st.fail("min" if value == low else "max", value, f"cannot be set: {error}") from None
    return staircase


def _read_sessions(top: _Reader, *, phases: tuple[TaskPhase, ...], training: Training | None,
                   groups: tuple[Group, ...], timeline_phases: list[str]) -> tuple[SessionPlan, ...]:
    """``[[sessions]]``: each session's name, its phases, ``after_days``, ``within_days``, ``groups``;
    without it, one session (``ONE_SESSION``) that runs every phase of tasks."""
    runnable = [name for name in timeline_phases
                if name == "training" and training is not None or any(p.name == name for p in phases)]
    if "sessions" not in top.data:
        return (SessionPlan(ONE_SESSION, tuple(runnable), 0),)
    codes = [g.code for g in groups]
    plans = []
    for s in top.tables("sessions"):
        name = s.label("name", "it names the session in tables and files (BIDS ses-)")
        names = s.strings("phases")
        for phase in names:
            if phase not in runnable:
                raise s.fail("phases", list(names), f"names phase {phase!r}; the phases of tasks are {runnable}")
        s.unique("phases", list(names), "phase")
        after = s.integer("after_days", minimum=0)
        if not plans and after != 0:
            raise s.fail("after_days", after, "the first session's after_days is 0 (it follows no session)")
        within = s.integer("within_days", None, minimum=0)
        session_groups = s.strings("groups") if "groups" in s.data else None
        for code in session_groups or ():
            if code not in codes:
                raise s.fail("groups", list(session_groups), f"names group {code!r}; groups are {codes}")
        plans.append(SessionPlan(name, tuple(sorted(names, key=timeline_phases.index)), after, within,
                                 session_groups))
        s.done()
    top.unique("sessions", [p.name for p in plans], "session name")
    missing = [name for name in runnable if not any(name in p.phases for p in plans)]
    if missing:
        raise top.fail("sessions", [p.name for p in plans], f"no session runs phase {missing[0]!r}")
    return tuple(plans)


def _read_training(top: _Reader, *, groups: tuple[Group, ...], task: TaskRules, sources: dict, files: dict,
                   meshes: dict) -> Training | None:
    """``[training]``: who trains (the groups marked ``training = true``), with what interaction model,
    objects and task kind."""
    tr = top.table("training", None)
    if tr is None:
        return None
    codes = [g.code for g in groups]
    training_groups = tr.strings("groups")
    for code in training_groups:
        if code not in codes:
            raise tr.fail("groups", list(training_groups), f"names group {code!r}; groups are {codes}")
    names = tr.strings("objects")
    tr.unique("objects", list(names), "object")
    _renamed(tr, "system", "training.system is now training.interaction (the interaction model training runs)")
    training = Training(groups=training_groups,
                        interaction=tr.text("interaction", choices=tuple(INTERACTION_MODELS)),
                        objects=tuple(_study_object(tr, f"objects[{i}]", name=n, sources=sources, files=files,
                                                    meshes=meshes) for i, n in enumerate(names)),
                        kind=tr.text("kind", task.kind, tuple(KINDS)),
                        tasks=tr.integer("tasks", len(names)),
                        timeout_s=tr.number("timeout_s", task.timeout_s, unit=" (seconds)"))
    _needs_numbers(tr, "kind", training.kind, task)
    need, seconds = _least_time(task, training.kind)
    if seconds >= training.timeout_s:
        raise tr.fail("timeout_s", training.timeout_s, f"must exceed {need} = {seconds:g} s: no training task "
                      "could be completed")
    tr.done()
    flagged = tuple(g.code for g in groups if g.training)
    if set(flagged) != set(training_groups):
        raise tr.fail("groups", list(training_groups), f"differs from the groups marked training = true "
                      f"({list(flagged)})")
    return training


def _least_time(task: TaskRules, kind: str) -> tuple[str, float]:
    """What a task of ``kind`` needs at least (its key) and how long (s): the kind's ``least_time``."""
    return KINDS[kind].least_time(task)


def _timeout_key(protocol: Protocol, phase: str) -> str:
    """The protocol key that sets a phase's time limit per task."""
    own = protocol.training is not None and protocol.training.timeout_s != protocol.task.timeout_s
    return "training.timeout_s" if phase == "training" and own else "task.timeout_s"


def _read_instruments(top: _Reader, resolved: dict, files: dict) -> dict[str, Instrument]:
    """The instruments the timeline asks, from their files' texts (``microg.instruments``); errors name
    the instrument file (or, for a study's stored copy, the database and the file's name)."""
    _renamed(top, "questionnaire", "[questionnaire] is now an instrument file: move its items into "
                                   "instruments/NAME.toml next to the protocol (in the form of the shipped "
                                   "protocols/instruments/paper.toml: id, text, anchors) and ask it in the timeline: "
                                   'phase = "questionnaire", instruments = ["NAME"], about = "each"')
    texts = resolved.get("instrument_files", {})
    if not isinstance(texts, dict):
        raise ProtocolError(f"{top.where}: the stored protocol's instrument files are not a table of texts")
    instruments = {}
    for name, text in texts.items():
        where = files.get(f"instrument:{name}") or f"{top.where}: instrument file {name}.toml (as kept with the protocol)"
        if not isinstance(text, str):
            raise ProtocolError(f"{where}: no text kept for it (found {type(text).__name__})")
        try:
            instruments[name] = read_instrument(text, where, name)
        except InstrumentError as error:
            raise ProtocolError(str(error)) from None
    return instruments


def _read_timeline(top: _Reader, *, groups: tuple[Group, ...], phases: tuple[TaskPhase, ...],
                   training: Training | None, instruments: dict[str, Instrument]) -> tuple[Phase, ...]:
    """``[[timeline]]``: the phases in order; every one of ``[[phases]]`` and the training exactly once,
    and questionnaires (entries with ``instruments``) where the protocol wants them (``_read_asking``)."""
    codes = [g.code for g in groups]
    required = (("training",) if training else ()) + tuple(p.name for p in phases)
    timeline = []
    for p in top.tables("timeline"):
        asks = "instruments" in p.data
        name = p.text("phase") if asks else p.text("phase", choices=PHASES_INFO + required)
        phase_groups = p.strings("groups") if "groups" in p.data else None
        for code in phase_groups or ():
            if code not in codes:
                raise p.fail("groups", list(phase_groups), f"names group {code!r}; groups are {codes}")
        asking = _read_asking(p, name, reserved=PHASES_INFO + required, phases=phases, instruments=instruments, before=[t.name for t in timeline]) \
            if asks else {}
        timeline.append(Phase(name=name, minutes=p.number("minutes", unit=" (minutes)"), text=p.text("text", ""),
                              groups=training.groups if name == "training" else phase_groups,
                              session=p.text("session") if "session" in p.data else None, **asking))
        p.done()
    seen = [p.name for p in timeline]
    for name in required:
        if seen.count(name) != 1:
            raise top.fail("timeline", seen, f"must list phase {name!r} exactly once")
    top.unique("timeline", seen, "phase")
    asked: dict[tuple[str, str, str], int] = {}
    for i, phase in enumerate(timeline):
        for instrument in phase.instruments:
            for about in (p.interaction if p else "" for p in _about(phase, phases)):
                key = (instrument, phase.administration, about)
                if key in asked:
                    raise top.fail(f"timeline[{i}].administration", phase.administration, f"timeline[{asked[key]}] "
                                   f"asks {instrument} in this administration about the same interaction model "
                                   "already; give each its own administration")
                asked[key] = i
    return tuple(timeline)


def _read_asking(p: _Reader, name: str, *, reserved: tuple[str, ...], phases: tuple[TaskPhase, ...],
                 instruments: dict[str, Instrument], before: list[str]) -> dict:
    """A questionnaire phase's keys: ``instruments`` (ids of instrument files), ``about`` (one of
    ``[[phases]]`` that comes before it, or ``each`` after all of them; absent: about no interaction model)
    and ``administration`` (default: the phase's name)."""
    if name in reserved or not IDENTIFIER.fullmatch(name):
        raise p.fail("phase", name, f"a questionnaire's phase is a name of its own (letters, digits and _), not one "
                     f"of {list(reserved)}")
    asked = p.strings("instruments")
    if not asked:
        raise p.fail("instruments", [], "must name one or more instruments (files in instruments/ or shipped)")
    p.unique("instruments", list(asked), "instrument")
    for instrument in asked:
        if instrument not in instruments:
            raise p.fail("instruments", list(asked), f"no instrument file {instrument}.toml kept with the protocol")
    names = [ph.name for ph in phases]
    about = p.text("about", choices=(ABOUT_EACH, *names)) if "about" in p.data else None
    missing = [n for n in (names if about == ABOUT_EACH else [about] if about else []) if n not in before]
    if missing:
        raise p.fail("about", about, f"asks about phase {missing[0]!r} before it has run (put this questionnaire "
                     "after it in the timeline)")
    administration = p.text("administration", name)
    if not IDENTIFIER.fullmatch(administration):
        raise p.fail("administration", administration, "must be letters, digits and _ (it names rows of tables)")
    return {"instruments": asked, "about": about, "administration": administration}


def _about(phase: Phase, phases: tuple[TaskPhase, ...]) -> tuple[TaskPhase | None, ...]:
    """What a questionnaire phase asks about (``Protocol.about``, before the protocol exists)."""
    if phase.about == ABOUT_EACH:
        return tuple(p for i, p in enumerate(phases) if all(q.interaction != p.interaction for q in phases[:i]))
    return tuple(p for p in phases if p.name == phase.about) or (None,)


def _read_display(top: _Reader) -> Viewpoint:
    """``[display]``: the participant's viewpoint on a screen."""
    view = top.table("display", {})
    viewpoint = Viewpoint(view.vector("eye") if "eye" in view.data else None,
                          view.vector("look_at") if "look_at" in view.data else None,
                          view.number("fov_deg", 40.0, unit=" (degrees)", maximum=FOV_RANGE[1]))
    if viewpoint.fov_deg < FOV_RANGE[0]:
        raise view.fail("fov_deg", viewpoint.fov_deg, f"must lie from {FOV_RANGE[0]:g} to {FOV_RANGE[1]:g} (degrees)")
    view.done()
    return viewpoint


def _read_dataset(top: _Reader) -> Dataset:
    """``[dataset]``: authors, licence and institution, for the Motion-BIDS export."""
    table = top.table("dataset", {})
    dataset = Dataset(authors=table.strings("authors", []), license=table.text("license", ""),
                      institution=table.text("institution", ""),
                      institution_address=table.text("institution_address", ""),
                      department=table.text("department", ""))
    table.done()
    return dataset


# ---------------------------------------------------------------- checks across sections


def _check_timeline_fits(top: _Reader, protocol: Protocol) -> None:
    """Each session's phases fit the study's minutes (a sitting), and each task phase's tasks (a
    phase with a criterion: its ``max_tasks``) fit its minutes at their timeout."""
    for group in protocol.groups:
        for plan in protocol.sessions_for(group.code):
            total = sum(p.minutes for p in protocol.phases_for(group.code, plan.name))
            if total > protocol.duration_minutes + 1e-9:
                raise top.fail("duration_minutes", protocol.duration_minutes, f"the timeline's phases take {total:g} "
                               "minutes" + (f" in session {plan.name!r}" if protocol.program else ""))
    task_phases = {p.name: p for p in protocol.phases}
    for phase in protocol.timeline:
        count = protocol.training.tasks if phase.name == "training" else \
            (task_phases[phase.name].max_tasks or len(protocol.objects)) if phase.name in task_phases else 0
        limit, key = protocol.rules(phase.name).timeout_s, _timeout_key(protocol, phase.name)
        if count * limit > phase.minutes * 60 + 1e-9:
            raise ProtocolError(
                f"{top.where}: timeline phase {phase.name!r} has minutes = {phase.minutes:g}, but its {count} "
                f"task(s) may take {count} x {key} = {count * limit / 60:g} minutes")


def _check_timeline_sessions(top: _Reader, timeline: tuple[Phase, ...], sessions: tuple[SessionPlan, ...],
                             phases: tuple[TaskPhase, ...]) -> None:
    """A timeline entry that names a session names one of ``[[sessions]]`` (a phase of tasks only one
    that runs it)."""
    names = [s.name for s in sessions]
    for i, entry in enumerate(timeline):
        if entry.session is None:
            continue
        if entry.session not in names:
            raise top.fail(f"timeline[{i}].session", entry.session, f"names no session of the protocol {names}")
        plan = sessions[names.index(entry.session)]
        runs_tasks = entry.name == "training" or any(p.name == entry.name for p in phases)
        if runs_tasks and entry.name not in plan.phases:
            raise top.fail(f"timeline[{i}].session", entry.session, f"does not run phase {entry.name!r} (its phases: "
                           f"{list(plan.phases)})")


def _check_objects(top: _Reader, protocol: Protocol) -> None:
    """Across tested and training objects: one code per object and one BIDS label per object name
    (the tables and the Motion-BIDS export tell objects apart by them)."""
    distinct = {o.name: o for o in protocol.objects + (protocol.training.objects if protocol.training else ())}
    for what, key in (("code", lambda o: o.code), ("BIDS label", lambda o: re.sub(r"[^A-Za-z0-9]", "", o.name))):
        seen: dict[str, str] = {}
        for obj in distinct.values():
            value = key(obj).casefold()
            if value in seen:
                raise ProtocolError(f"{top.where}: objects {seen[value]!r} and {obj.name!r} have the same {what} "
                                    f"{key(obj)!r} (case does not count); the tables would merge them: give each "
                                    "object its own code in its object file")
            seen[value] = obj.name


def _check_worlds(top: _Reader, protocol: Protocol) -> None:
    """Every task's world as the sessions will build it: the physics accepts each scene (each
    phase's interaction model with each object), the object waits inside the workspace (on the table, if
    there is one: else every task would end in a respawn loop and time out), and every place can
    hold the object's centre above the table top."""
    tasks = [(p.interaction, o.name, p.kind) for p in protocol.phases for o in protocol.objects]
    if protocol.training:
        tasks += [(protocol.training.interaction, o.name, protocol.training.kind) for o in protocol.training.objects]
    rules = protocol.task
    for interaction, name, kind in dict.fromkeys(tasks):
        try:
            protocol.scene(name, interaction, kind).validate("scene")
        except SceneError as error:
            raise ProtocolError(f"{top.where}: {error} (in the world of {interaction} with the {name})") from None
        if protocol.table_height is None:
            continue
        start, _ = protocol.start_pose(name)
        if not inside(start, rules):
            raise ProtocolError(
                f"{top.where}: scene.table_height = {protocol.table_height:g}: the {name} stands on the table with "
                f"its centre at {[round(v, 4) for v in start]}, outside the workspace (task.workspace_min "
                f"{list(rules.workspace_min)} .. task.workspace_max {list(rules.workspace_max)})")
        lowest = protocol.table_height + float(np.min(protocol.object(name).spec.half_extents))
        for k, place in enumerate(rules.places):
            if place[1] + rules.place_radius < lowest:
                raise ProtocolError(
                    f"{top.where}: task.places[{k}] = {list(place)}: the {name} on the table (scene.table_height = "
                    f"{protocol.table_height:g}) keeps its centre at y >= {lowest:.4f}, so it can never reach this "
                    f"place (task.place_radius = {rules.place_radius:g})")


def _build(top: _Reader, resolved: dict, files: dict) -> Protocol:
    """The protocol from its merged data: each section by its reader, then the checks across sections."""
    sources = resolved.get("object_files", {})
    meshes = resolved.get("mesh_files", {})
    name = top.text("name")
    title = top.text("title", "")
    top.text("description", "")
    seed = top.integer("seed", None, minimum=0)
    duration = top.number("duration_minutes", unit=" (minutes)", maximum=MAX_MINUTES)
    gravity, table_height, options, filter_window, jump_distance = _read_scene(top)
    people, total, balance, age_range = _read_participants(top)
    groups = _read_groups(top, people, total, resolved.get("population_files", {}))
    objects, order = _read_objects(top, sources, files, meshes)
    task = _read_task(top)
    phases = _read_phases(top, task, objects)
    training = _read_training(top, groups=groups, task=task, sources=sources, files=files, meshes=meshes)
    instruments = _read_instruments(top, resolved, files)
    timeline = _read_timeline(top, groups=groups, phases=phases, training=training, instruments=instruments)
    sessions = _read_sessions(top, phases=phases, training=training, groups=groups,
                              timeline_phases=[p.name for p in timeline])
    _check_timeline_sessions(top, timeline, sessions, phases)
    logging = top.table("logging", {})
    frame_batch = logging.integer("frame_batch", 64, maximum=MAX_FRAME_BATCH)
    logging.done()
    viewpoint = _read_display(top)
    dataset = _read_dataset(top)
    top.raw("object_files", None)
    top.raw("mesh_files", None)
    top.raw("population_files", None)
    top.raw("instrument_files", None)
    top.raw("sources", None)
    top.done()
    protocol = Protocol(name=name, title=title, where=top.where, seed=seed, duration_minutes=duration,
                        gravity=gravity, table_height=table_height, scene_options=options,
                        filter_window=filter_window, jump_distance=jump_distance, total_participants=total, balance=balance, age_range=age_range,
                        groups=groups, objects=objects, order=order, task=task, training=training, phases=phases,
                        instruments=instruments, timeline=timeline, frame_batch=frame_batch, viewpoint=viewpoint,
                        resolved=resolved, dataset=dataset, sessions=sessions)
    _check_timeline_fits(top, protocol)
    _check_objects(top, protocol)
    _check_worlds(top, protocol)
    return protocol
