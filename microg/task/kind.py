"""What a task kind is: the declaration every kind module makes, and the compiled parts they share.

A kind (``microg.task.kinds``: the pick-and-place, the catch, ...) is one module that declares a
``Kind``: its stages, its events, the numbers of its rules and its protocol table, its compiled
``judge``, its measures and their columns, what its page says at each stage, and what the
simulated participant does (``Play``). Everything else (the protocol reader, the frame path, the
frame log, the export, the report, the page, the in-silico engine) reads the declaration.

The rules run in compiled code on plain records: every kind's task state is a record whose first
fields are ``HEADER`` (the stage, the clock, the hold, the attempts, the place) followed by its
own; its numbers a record of ``RULES_HEADER`` (the limits every kind shares) and its own; what a
frame shows it an ``OBSERVED`` record; what happened an ``EVENT`` array. ``judge(task, rules,
seen, events)`` returns how many events it wrote. ``hold`` is the hold every kind judges, the
same rule everywhere.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
from numba import njit
from numba.core.errors import NumbaExperimentalFeatureWarning

from microg.skeleton import SIDES, SLOTS

COMPLETED, TIMEOUT = "completed", "timeout"
"""The two stages that end every task."""
EPS = 1e-9
"""s: times that differ by less are equal (frame times are sums of float intervals)."""
MAX_DISTANCE = 10.0
"""m: positions and distances a protocol gives lie within this of the tracker."""
MAX_LAUNCH_SPEED = 10.0
"""m/s: an object's speed as a task starts it; a tossed tool in a station's cabin moves well under it."""
MAX_SPIN = 100.0
"""rad/s: about 16 turns a second, beyond what a tracked hand can follow."""
MAX_EVENTS = 8
"""The most events one frame can make."""
EVENT_VALUES = 6
"""The numbers an event carries (``EVENT.values``)."""


class Stage(NamedTuple):
    """A stage of a kind's task: its name, what the participant's page says then (``{first}`` and
    ``{other}`` stand for the hands of a kind that names them: ``View.first_hand``), and what it tells
    a simulated participant: ``loose``, the task shows the object not held (go and take it again);
    ``release``, let go now."""

    name: str
    text: str
    loose: bool = False
    release: bool = False


FINAL = (Stage(COMPLETED, "Done"), Stage(TIMEOUT, "Time is up"))


STAGE, PLACE_OR_NONE, NUMBER, NUMBER_OR_NONE, COUNT, FLAG, HAND, VECTOR = range(8)
"""How an event's value reads (``EventSpec``): a stage's name; a place (left out when negative); a
number; a number or None (NaN); a whole number; yes or no; a hand's side; three numbers."""


class EventSpec(NamedTuple):
    """An event of a kind: its name and its data, each key with how its value reads from the
    event's numbers (in order; a ``VECTOR`` takes three)."""

    name: str
    data: tuple[tuple[str, int], ...] = ()


RESPAWN = EventSpec("respawn", (("position", VECTOR),))
"""The event every kind has: the object left the workspace and was put back (``microg.task.play``)."""


class Measure(NamedTuple):
    """One of a kind's own measures of a finished task, a column of the trials table: its name,
    dtype, unit, how a reader sees it (``label``: "time to catch"), what it means, the task state's
    field it is read from (NaN: empty), and how a report treats it (``proportion``: yes or no per
    task; ``signed``: may be negative)."""

    name: str
    dtype: str
    unit: str
    label: str
    meaning: str
    field: str
    proportion: bool = False
    signed: bool = False


class Play(NamedTuple):
    """What a simulated participant does in a task of this kind (``microg.participant.actions``):
    how it goes for the object (``reach`` for it, or ``intercept`` it in its path when it moves), how
    it takes it (``grasp`` it, or ``touch`` it with the index fingertip), then what (``carry`` it
    to the places and let go, ``keep`` it where it was taken until the task is over, ``push`` it off
    to a target, ``hand_over`` it from one hand to the other), and which way its grip squeezes most
    (``user``: toward the user; ``path``: across the object's path)."""

    approach: str = "reach"
    take: str = "grasp"
    then: str = "carry"
    squeeze: str = "user"


class Aims(NamedTuple):
    """What a simulated participant aims at in a task (its kind's ``aims`` of the task's rules): the
    places it carries the object to and their radius, how long it holds (at a place, a catch, a rest,
    in the zone), a target it sends the object to and the drift's time, the object's path (a
    direction its grip squeezes across: ``Play.squeeze`` ``path``), the hand that takes the object
    first (a handover)."""

    places: tuple = ()
    place_radius: float = 0.0
    hold_s: float = 0.0
    target: tuple | None = None
    arrival_s: float = 0.0
    path: tuple | None = None
    first_hand: str | None = None


class Difficulty(NamedTuple):
    """A number of a kind's task that a phase's staircase may adapt (``Kind.difficulty``): how to read
    it from a ``TaskRules`` and set it in one, whether a larger value makes the task harder
    (``harder`` 1) or easier (-1), and its unit."""

    get: Callable
    set: Callable
    harder: int
    unit: str


class View(NamedTuple):
    """What the participant's page and a picture show of a kind's task: the task's ``places`` (the
    pick-and-place's marks), the ``zone`` the object must reach (``zone(rules) -> (centre, radius)``),
    the object's launch ``path`` (``path(rules) -> direction``), the hand a task takes the object with
    first (``first_hand(rules)``, filling the stages' texts), and how pictures label the frame the
    object was first held (``taken``) and the last frame of a completed task (``done``)."""

    places: bool = False
    zone: Callable | None = None
    path: Callable | None = None
    first_hand: Callable | None = None
    taken: str = "taken"
    done: str = "done"


APPROACHES, TAKES, THENS, SQUEEZES = ("reach", "intercept"), ("grasp", "touch"), ("carry", "keep", "push",
                                                                                  "hand_over"), ("user", "path")


HEADER = [("stage", "i8"), ("started", "f8"), ("ended", "f8"), ("attempts", "i8"), ("held", "u1"),
          ("grasp_since", "f8"), ("loose_since", "f8"), ("place", "i8"), ("lit_since", "f8")]
"""The fields every kind's task state opens with: its stage (an index into the kind's stages), when
its first frame came and when it ended (NaN: not yet), its attempts, the hold (held, and since when
the grasp or its loss has lasted: ``hold``), and the current place and since when it is lit
(NaN: dark; a kind without places keeps place 0)."""
RULES_HEADER = [("timeout_s", "f8"), ("grasp_settle_s", "f8"), ("drop_grace_s", "f8"),
                ("workspace_min", "f8", (3,)), ("workspace_max", "f8", (3,))]
"""The numbers every kind's rules open with (``TaskRules``)."""
OBSERVED = np.dtype([("t", "f8"), ("position", "f8", (3,)), ("orientation", "f8", (4,)), ("velocity", "f8", (3,)),
                     ("angular_velocity", "f8", (3,)), ("touching", "u1", (SLOTS,)), ("grasped_by", "u1", (2,))],
                    align=True)
"""What one frame of the world shows a task's rules: the object's pose and motion (tracker frame),
which phalanx slots touch it, which hands hold it (``microg.sim``'s grasp rule)."""
EVENT = np.dtype([("kind", "i8"), ("t", "f8"), ("values", "f8", (EVENT_VALUES,))], align=True)
"""One event: its kind (an index into the kind's events), its time and its numbers."""
warnings.filterwarnings("ignore", r"Record\(.*\) has been considered a subtype of Record", NumbaExperimentalFeatureWarning)
"""Every kind's task state opens with ``HEADER``, so numba takes it for a subtype of another kind's
where a shared function (``hold_task``, the frame path's) reads only the header: as meant, and not
worth a warning every time a kind's rules compile."""


@dataclass(frozen=True, eq=False)
class Kind:
    """A task kind, as its module declares it (module docstring)."""

    name: str
    title: str
    """How a reader calls it ("Stop of a spin")."""
    stages: tuple[Stage, ...]
    """Its stages in order, ending with ``FINAL``; the first is where a task starts."""
    events: tuple[EventSpec, ...]
    state: list
    """Its own fields of the task state, after ``HEADER`` (numpy dtype fields)."""
    rules: list
    """Its own numbers, after ``RULES_HEADER``."""
    judge: Callable
    """The compiled rules: ``judge(task, rules, seen, events) -> events written``."""
    fill_rules: Callable
    """``fill_rules(task_rules, record)``: its own numbers of a ``TaskRules`` into a rules record."""
    aims: Callable
    """``aims(task_rules) -> Aims``: what a simulated participant aims at in its task."""
    least_time: Callable
    """``least_time(task_rules) -> (key, seconds)``: what a task of the kind takes at least (the holds,
    a drift), and the protocol key that sets it: a time limit must exceed it."""
    attempts: str
    """What its ``attempts`` count ("drops", "misses")."""
    measures: tuple[Measure, ...] = ()
    play: Play = Play()
    view: View = View()
    difficulty: dict = field(default_factory=dict)
    """The numbers of its task a staircase may adapt, by the name a protocol gives them
    (``[phases.staircase] parameter``): each a ``Difficulty``."""
    table: str | None = None
    """Its table under the protocol's ``task`` table (``[task.NAME]``); None: its numbers are the
    ``task`` table's own (the pick-and-place's places and holds)."""
    read: Callable | None = None
    """``read(table, task_rules) -> numbers``: its table read and checked, with the protocol's reader
    (``table.number``, ``vector``, ``text``, ``raw``, ``fail``, ``done``: every error names the file,
    key and value) and the shared numbers; its numbers (``TaskRules.tables``)."""
    start_motion: Callable | None = None
    """``start_motion(task_rules) -> (velocity, angular_velocity)``: how the task starts its object
    moving (tracker frame); None: at rest."""
    initial: dict = field(default_factory=dict)
    """Fields of its own state that start at a value: every other number starts NaN (not yet), every
    flag and count 0."""
    module: str = field(default="", compare=False)
    """The module that declares it (its source is part of what compiled code is cached under)."""

    @property
    def stage_names(self) -> tuple[str, ...]:
        return tuple(stage.name for stage in self.stages)

    @property
    def task_dtype(self) -> np.dtype:
        return _dtype(HEADER + self.state)

    @property
    def rules_dtype(self) -> np.dtype:
        return _dtype(RULES_HEADER + self.rules)

    @property
    def all_events(self) -> tuple[EventSpec, ...]:
        """Its events, then ``RESPAWN`` (the event of an ``EVENT`` record's ``kind`` is this index)."""
        return self.events + (RESPAWN,)

    def index(self, stage: str) -> int:
        return self.stage_names.index(stage)

    def new_task(self):
        """A task before its first frame: the first stage, no times, nothing held."""
        task = np.zeros(1, self.task_dtype)[0]
        for name, dtype, *_ in HEADER + self.state:
            if np.dtype(dtype).kind == "f":
                task[name] = math.nan
        for name, value in self.initial.items():
            task[name] = value
        return task

    def start(self) -> TaskState:
        """A task's state before its first frame, for Python (``advance``)."""
        return TaskState(self, self.new_task())

    def advance(self, state: TaskState, observation, rules) -> tuple[TaskState, list[TaskEvent]]:
        """One frame of the rules from Python (tests, tools): ``judge`` on a copy of ``state`` with
        what ``observation`` (a ``microg.task.Observation``) shows, by ``rules`` (a ``TaskRules``)."""
        task, events = state.record.copy(), np.zeros(MAX_EVENTS, EVENT)
        n = self.judge(task, self.rules_record(rules), observed(observation), events)
        return TaskState(self, task), [self.event(e) for e in events[:n]]

    def rules_record(self, rules):
        """A ``TaskRules`` as this kind's rules record."""
        record = np.zeros(1, self.rules_dtype)[0]
        record["timeout_s"], record["grasp_settle_s"], record["drop_grace_s"] = rules.timeout_s, \
            rules.grasp_settle_s, rules.drop_grace_s
        record["workspace_min"], record["workspace_max"] = rules.workspace_min, rules.workspace_max
        self.fill_rules(rules, record)
        return record

    def event(self, record) -> TaskEvent:
        """An ``EVENT`` record as a ``TaskEvent``, its data as the task's log has it."""
        spec = self.all_events[int(record["kind"])]
        values, data, i = record["values"], {}, 0
        for key, how in spec.data:
            value = float(values[i])
            i += 3 if how == VECTOR else 1
            if how == PLACE_OR_NONE:
                if value >= 0:
                    data[key] = int(value)
            elif how == STAGE:
                data[key] = self.stage_names[int(value)]
            elif how == NUMBER:
                data[key] = value
            elif how == NUMBER_OR_NONE:
                data[key] = None if math.isnan(value) else value
            elif how == COUNT:
                data[key] = int(value)
            elif how == FLAG:
                data[key] = bool(value)
            elif how == HAND:
                data[key] = SIDES[int(value)]
            else:
                data[key] = [float(v) for v in values[i - 3:i]]
        return TaskEvent(float(record["t"]), spec.name, data)

    def measured(self, task) -> dict:
        """Its own measures of a finished task (``measures``: None where its field is NaN)."""
        out = {}
        for measure in self.measures:
            value = task[measure.field]
            out[measure.name] = bool(value) if measure.dtype == "boolean" else \
                (None if math.isnan(value) else float(value))
        return out


def _dtype(fields) -> np.dtype:
    return np.dtype(fields, align=True)


class TaskEvent(NamedTuple):
    t: float
    kind: str
    data: dict


class TaskDisplay(NamedTuple):
    """What the participant sees of the task besides the scene: the stage, and the place marks and
    their timer as the paper's toolkit shows them ("the mark is highlighted and the timer is
    triggered"). ``place`` is the index of the current place (the number of places, once all are
    done); ``lit`` whether it is highlighted; ``timer_s`` how long it has been lit."""

    stage: str
    place: int = 0
    lit: bool = False
    timer_s: float = 0.0


class TaskState:
    """A task's state for Python: a copy of its record, each field an attribute (the stage by its
    name, times NaN as None, flags as bools)."""

    __slots__ = ("kind", "record")

    def __init__(self, kind: Kind, record):
        self.kind, self.record = kind, record

    def __getattr__(self, name: str):
        try:
            value = self.record[name]
        except (KeyError, ValueError, IndexError):
            raise AttributeError(f"a {self.kind.name} task has no {name!r}") from None
        if name == "stage":
            return self.kind.stage_names[int(value)]
        if isinstance(value, np.ndarray):
            return value.copy()
        if value.dtype == np.uint8:
            return bool(value)
        if value.dtype.kind == "f":
            return None if math.isnan(value) else float(value)
        return int(value)

    @property
    def finished(self) -> bool:
        return self.stage in (COMPLETED, TIMEOUT)

    @property
    def completion_time(self) -> float | None:
        return self.ended - self.started if self.stage == COMPLETED else None

    def place_timer(self, t: float) -> float:
        """Seconds the current place has been lit at time ``t`` (0 when dark)."""
        return 0.0 if self.lit_since is None else t - self.lit_since

    def displayed(self, t: float) -> TaskDisplay:
        """What the task shows at time ``t``."""
        return TaskDisplay(self.stage, self.place, self.lit_since is not None, self.place_timer(t))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TaskState):
            return NotImplemented
        return self.kind is other.kind and self.record.tobytes() == other.record.tobytes()

    __hash__ = None

    def __repr__(self) -> str:
        return f"TaskState({self.kind.name}, {self.record})"


# -- compiled parts every kind shares ------------------------------------------------------------

@njit(cache=True)
def hold(held, grasp_since, loose_since, t, grasped, rules):
    """The hold after a frame at ``t`` in which the object was ``grasped`` (or not): held once
    grasped for ``grasp_settle_s`` without a break, let go once not grasped for ``drop_grace_s``
    without a break (shorter breaks are the flicker of contacts). Returns the new (held,
    grasp_since, loose_since) and when the hold began and ended in this frame (NaN: it did not):
    a hold begins when its grasp began and ends when its grasp went."""
    if grasped:
        if held:
            return True, math.nan, math.nan, math.nan, math.nan
        since = t if math.isnan(grasp_since) else grasp_since
        if t - since >= rules.grasp_settle_s - EPS:
            return True, math.nan, math.nan, since, math.nan
        return False, since, math.nan, math.nan, math.nan
    if not held:
        return False, math.nan, math.nan, math.nan, math.nan
    since = t if math.isnan(loose_since) else loose_since
    if t - since >= rules.drop_grace_s - EPS:
        return False, math.nan, math.nan, math.nan, since
    return True, math.nan, since, math.nan, math.nan


@njit(cache=True)
def hold_task(task, t, grasped, rules):
    """``hold`` on the task's own hold (``HEADER``); when it began and ended in this frame."""
    held, task.grasp_since, task.loose_since, began, ended = hold(task.held, task.grasp_since, task.loose_since, t,
                                                                   grasped, rules)
    task.held = held
    return began, ended


@njit(cache=True)
def emit(events, n, kind, t, a=math.nan, b=math.nan, c=math.nan, d=math.nan, e=math.nan, f=math.nan):
    """Write event ``kind`` at ``t`` with its numbers into ``events[n]``; returns n + 1."""
    event = events[n]
    event.kind, event.t = kind, t
    event.values[0], event.values[1], event.values[2] = a, b, c
    event.values[3], event.values[4], event.values[5] = d, e, f
    return n + 1


@njit(cache=True)
def start_and_time_out(task, t, rules, events, n, first_event, timeout_event, timeout_stage):
    """Every kind's first two rules: the first frame starts the task (event ``first_event`` with
    the first stage); a task still unfinished ``timeout_s`` after its first frame ends (event
    ``timeout_event`` with its stage and place, stage ``timeout_stage``). Returns the events
    written and whether the task timed out."""
    if math.isnan(task.started):
        task.started = t
        n = emit(events, n, first_event, t, 0.0, -1.0)
    if t - task.started >= rules.timeout_s - EPS:
        n = emit(events, n, timeout_event, t, task.stage, task.place)
        task.stage, task.ended, task.lit_since = timeout_stage, t, math.nan
        return n, True
    return n, False


@njit(cache=True)
def grasped(seen):
    """Whether either hand holds the object (``OBSERVED.grasped_by``)."""
    return seen.grasped_by[0] != 0 or seen.grasped_by[1] != 0


@njit(cache=True)
def touched(seen):
    """Whether a phalanx touches the object or a hand holds it."""
    for k in range(seen.touching.shape[0]):
        if seen.touching[k]:
            return True
    return grasped(seen)


@njit(cache=True)
def length(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def inside(point, rules) -> bool:
    """Whether ``point`` lies in the task's workspace (``workspace_min`` .. ``workspace_max``)."""
    return all(lo <= p <= hi for lo, p, hi in zip(rules.workspace_min, point, rules.workspace_max))


def observed(observation, out=None):
    """A ``microg.task.Observation`` as an ``OBSERVED`` record."""
    out = np.zeros(1, OBSERVED)[0] if out is None else out
    o = observation
    out["t"], out["position"], out["orientation"] = o.t, o.position, o.orientation
    out["velocity"], out["angular_velocity"] = o.velocity, o.angular_velocity
    out["touching"] = 0 if o.touching is None else np.asarray(o.touching)
    out["grasped_by"] = (bool(o.grasped), False) if o.grasped_by is None else np.asarray(o.grasped_by)
    return out


def before_timeout(table, key: str, value: float, rules, never: str = "") -> None:
    """Refuse a kind's own duration (``[task.KIND]``'s ``key``) that is not shorter than the task's
    ``timeout_s``: no such task could end well; ``never`` says what could not happen."""
    if value >= rules.timeout_s:
        raise table.fail(key, value, f"must be shorter than task.timeout_s = {rules.timeout_s:g} s"
                         + (f": {never}" if never else ""))
