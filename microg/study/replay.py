"""Replayed sessions: real recordings placed in the workspace, one recording per task.

``--input replay:FILE`` replays one recording for every task; ``--input replay:MANIFEST.toml``
gives each planned task its own recording and time window::

    # replay manifest: recordings are found relative to this file
    align = "grasp"                 # optional, for every task: start, grasp or X,Y,Z[,RX,RY,RZ]

    [[task]]
    object = "cube"                 # which planned tasks this entry plays: object (required),
    phase = "stage1"                # and optionally phase and participant
    participant = "P03"
    recording = "grab.json.gz"      # the project's recording format or LeapJS v2 JSON
    start_s = 0.5                   # optional window, seconds from the recording's first frame
    end_s = 4.0
    align = "0.0,0.1,0.05"          # optional, this entry only

The most specific entry that matches a task plays it (participant and phase before object alone);
a task with no entry is an error before the session starts. ``--align`` (or a manifest's
``align``) places the recording in the workspace (``microg.hands.align``); the transform goes into
the run's source description, so it is logged with the run.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from microg.hands import ReplaySource, load_recording
from microg.hands.align import Aligned, Alignment, AlignmentError, find_alignment, parse_alignment
from microg.hands.source import HandSource
from microg.participant.plan import TaskPlan

ABOVE_THE_OBJECT = (0.0, 0.10, 0.12)
"""Where a task's hand starts unless its plan says: this far (m) from the object's start (as the
simulated participant's hand waits)."""


class ReplayError(ValueError):
    """A replay that cannot be set up; the message names the file, key and value."""


@dataclass(frozen=True)
class Entry:
    """One manifest entry: which tasks, which recording, which window, how to place it."""

    object: str
    recording: Path
    phase: str | None = None
    participant: str | None = None
    start_s: float | None = None
    end_s: float | None = None
    align: str | Alignment | None = None

    def matches(self, plan: TaskPlan) -> int:
        """How specifically this entry names ``plan``'s task (0: it does not)."""
        if self.object != plan.object.name or (self.phase and self.phase != plan.phase) \
                or (self.participant and self.participant != plan.participant):
            return 0
        return 1 + bool(self.phase) + 2 * bool(self.participant)


def read_manifest(path: Path) -> tuple[Entry, ...]:
    """The entries of a replay manifest, checked (file, key and value in every error)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise ReplayError(f"{path}: cannot read the replay manifest: {error}") from None
    except RecursionError:
        raise ReplayError(f"{path}: not a replay manifest: its tables or arrays are nested too deeply") from None
    default = _align(path, "align", data.pop("align", None))
    tasks = data.pop("task", None)
    if data:
        raise ReplayError(f"{path}: unknown key {sorted(data)[0]!r} (known: align, task)")
    if not isinstance(tasks, list) or not tasks or not all(isinstance(t, dict) for t in tasks):
        raise ReplayError(f"{path}: task = {tasks!r}: give one [[task]] table per recording")
    entries = []
    for i, table in enumerate(tasks):
        where = f"{path}: task[{i}]"
        unknown = set(table) - {"object", "phase", "participant", "recording", "start_s", "end_s", "align"}
        if unknown:
            raise ReplayError(f"{where}: unknown key {sorted(unknown)[0]!r}")
        for key in ("object", "recording"):
            if not isinstance(table.get(key), str) or not table[key]:
                raise ReplayError(f"{where}.{key} = {table.get(key)!r}: must be a non-empty string")
        recording = path.parent / table["recording"]
        if not recording.is_file():
            raise ReplayError(f"{where}.recording = {table['recording']!r}: no such file {recording}")
        window = [table.get(k) for k in ("start_s", "end_s")]
        for key, value in zip(("start_s", "end_s"), window):
            if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                      or not 0 <= value < math.inf):
                raise ReplayError(f"{where}.{key} = {value!r}: must be seconds >= 0 from the recording's start")
        if None not in window and window[1] <= window[0]:
            raise ReplayError(f"{where}.end_s = {window[1]!r}: must be after start_s = {window[0]!r}")
        entries.append(Entry(table["object"], recording, table.get("phase"), table.get("participant"),
                             *window, _align(path, f"task[{i}].align", table.get("align")) or default))
    return tuple(entries)


def _align(path: Path, key: str, value) -> str | Alignment | None:
    if value is None:
        return None
    if not isinstance(value, str):
        raise ReplayError(f"{path}: {key} = {value!r}: must be start, grasp or \"X,Y,Z[,RX,RY,RZ]\"")
    try:
        return parse_alignment(value)
    except AlignmentError as error:
        raise ReplayError(f"{path}: {key}: {error}") from None


class ReplayInputs:
    """Each task replays a recording: the same one (``replay:FILE``) or the manifest's
    (``replay:MANIFEST.toml``), windowed and aligned as asked; as fast as it reads."""

    clock = "simulation"
    simulated = False

    def __init__(self, spec: str, target: Path, align: str | None = None):
        self.spec = spec
        given = None if align is None else _align(Path("--align"), "value", align)
        if target.suffix == ".toml":
            self.entries = read_manifest(target)
            if given is not None:
                self.entries = tuple(Entry(**{**e.__dict__, "align": given}) for e in self.entries)
        else:
            self.entries = (Entry("*", target, align=given),)
        self._recordings: dict[Path, tuple] = {}

    def entry(self, plan: TaskPlan) -> Entry:
        if self.entries[0].object == "*":
            return self.entries[0]
        ranked = sorted(((e.matches(plan), i) for i, e in enumerate(self.entries)), reverse=True)
        if not ranked or ranked[0][0] == 0:
            raise ReplayError(f"{self.spec}: no recording for the task {plan.phase} {plan.object.name} of "
                              f"{plan.participant or 'this participant'}; add a [[task]] entry for it")
        return self.entries[ranked[0][1]]

    def check(self, plans: list[TaskPlan]) -> None:
        """Every planned task has a recording (before the session starts)."""
        for plan in plans:
            self.entry(plan)

    def open(self, plan: TaskPlan, seed: int) -> HandSource:
        entry = self.entry(plan)
        frames = self._frames(entry.recording)
        if entry.start_s is not None or entry.end_s is not None:
            t0 = frames[0].timestamp
            low, high = entry.start_s or 0.0, math.inf if entry.end_s is None else entry.end_s
            frames = [f for f in frames if low <= f.timestamp - t0 <= high]
            if not frames:
                raise ReplayError(f"{self.spec}: {entry.recording.name} has no frames between {low:g} and "
                                  f"{high:g} s")
        description = f"replay:{entry.recording}" + (
            f" [{entry.start_s or 0:g}-{entry.end_s if entry.end_s is not None else 'end'} s]"
            if entry.start_s is not None or entry.end_s is not None else "")
        source = ReplaySource(frames, description)
        if entry.align is None:
            return source
        alignment = entry.align if isinstance(entry.align, Alignment) else find_alignment(
            entry.align, frames, plan.hand_start or tuple(a + b for a, b in zip(plan.start, ABOVE_THE_OBJECT)),
            plan.start)
        aligned = Aligned(source, alignment)
        aligned.description = f"{description} aligned {alignment.as_dict()}"
        return aligned

    def _frames(self, path: Path) -> tuple:
        if path not in self._recordings:
            self._recordings[path] = load_recording(path).frames
        return self._recordings[path]

    def close(self) -> None:
        pass
