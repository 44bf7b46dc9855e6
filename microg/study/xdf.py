"""An XDF recording (LabRecorder's, with the session's ``--lsl`` streams) lined up with the study's log.

The session's ``Markers`` stream says which session it comes from (``lsl.session_tags``) and carries
the session's events in order, as the log has them. ``line_up`` matches each marker to its logged
event, fits the line from the session's clock to the LSL clock through the pairs (offset, and a
slope for the clocks' drift; one line per part of a resumed session) and reports how far each marker lies from it; then it puts every task
run on the LSL clock (to cut EEG or eye-tracking epochs per task) and gives the ``MoCap`` samples the
session's time and the run and frame they show. ``pyxdf`` reads the file (``pip install 'microg[lsl]'``).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .lsl import MARKERS_NAME, MOCAP_CHANNELS, MOCAP_NAME, session_tags
from .store import Store

MIN_MARKERS = 3
"""Matched markers needed to fit the line and see how well it fits."""
TABLES = ("tasks", "markers", "mocap")
"""``write_lineups`` writes ``xdf_<table>.<format>`` for each."""


class XdfError(ValueError):
    """The XDF file cannot be lined up with the study; the message names the file and what is wrong."""


@dataclass(frozen=True)
class Fit:
    """LSL time = offset + slope × session time, through the matched markers: one line per part of
    the session. A resumed session's clock carries on from where it stopped while the LSL clock ran
    on through the crash, so each resume (``session_resume``) starts a new part and a new line."""

    starts: np.ndarray
    """Session time at which each part begins (-inf for the first)."""
    offsets: np.ndarray
    slopes: np.ndarray
    residuals: np.ndarray
    """Seconds each matched marker lies after its part's line (LSL clock)."""

    @property
    def offset(self) -> float:
        return float(self.offsets[0])

    @property
    def slope(self) -> float:
        return float(self.slopes[0])

    def lsl(self, t):
        t = np.asarray(t, dtype=float)
        part = np.searchsorted(self.starts, t, side="right") - 1
        return self.offsets[part] + self.slopes[part] * t

    def study(self, lsl):
        lsl = np.asarray(lsl, dtype=float)
        known = np.flatnonzero(np.isfinite(self.offsets))  # parts without a marker have no line
        begins = self.offsets[known] + self.slopes[known] * self.starts[known]
        begins[0] = -np.inf
        part = known[np.searchsorted(begins, lsl, side="right") - 1]
        return (lsl - self.offsets[part]) / self.slopes[part]

    @property
    def max_residual_ms(self) -> float:
        return float(np.max(np.abs(self.residuals)) * 1e3)

    def describe(self) -> str:
        """The lines, as the CLI prints them."""
        return "; ".join(f"LSL time = {o:.6f} s + {k:.9f} x session time" + ("" if start == -np.inf else
                         f" from the resume at {start:g} s") for start, o, k in zip(self.starts, self.offsets,
                                                                                      self.slopes))


def fit_parts(t: np.ndarray, lsl: np.ndarray, part: np.ndarray, starts: np.ndarray) -> Fit:
    """The line of each part through its (session time, LSL time) pairs; a part with markers at one
    time only keeps the slope of the part before (the clocks' drift does not change at a resume), a
    part without markers (not recorded) has none: its times map to NaN."""
    offsets, slopes = np.empty(len(starts)), np.empty(len(starts))
    residuals = np.empty(len(t))
    for k in range(len(starts)):
        mine = part == k
        if len(np.unique(t[mine])) >= 2:
            slopes[k], offsets[k] = np.polyfit(t[mine], lsl[mine], 1)
        else:
            slopes[k] = slopes[k - 1] if k else 1.0
            offsets[k] = np.mean(lsl[mine] - slopes[k] * t[mine]) if mine.any() else np.nan
        residuals[mine] = lsl[mine] - (offsets[k] + slopes[k] * t[mine])
    return Fit(starts, offsets, slopes, residuals)


@dataclass(frozen=True)
class Lineup:
    """One session of the study found in the XDF file, lined up."""

    participant: str
    session: int
    clock: str
    """The session's clock: ``wall`` (live input) lines up; ``simulation`` times are simulated seconds."""
    fit: Fit
    markers: pd.DataFrame
    tasks: pd.DataFrame
    mocap: pd.DataFrame | None
    """None when the file holds no MoCap stream of the session."""


def load_xdf(path: Path) -> list[dict]:
    """The streams of an XDF file, with the timestamps as recorded (clock offsets applied, no dejitter:
    a sample's time is when the session sent it)."""
    try:
        import pyxdf
    except ImportError:
        raise ImportError("reading XDF needs pyxdf: pip install 'microg[lsl]'") from None
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such XDF file")
    try:
        streams, _ = pyxdf.load_xdf(str(path), dejitter_timestamps=False)
    except (OSError, ValueError, KeyError, IndexError, EOFError, struct.error) as error:  # pyxdf fails in many ways
        raise XdfError(f"{path}: not a readable XDF file ({type(error).__name__}: {error})") from None
    return streams


def _field(stream: dict, key: str) -> str:
    return (stream["info"].get(key) or [""])[0]


def _tags(stream: dict) -> dict[str, str] | None:
    desc = (stream["info"].get("desc") or [None])[0]
    microg = (desc or {}).get("microg") or [None]
    if not microg[0]:
        return None
    return {key: values[0] for key, values in microg[0].items()}


def _describe(stream: dict) -> str:
    return f"'{_field(stream, 'name')}' ({_field(stream, 'type')})"


def line_up(store: Store, path: str | Path) -> list[Lineup]:
    """Every session of ``store`` whose markers the XDF file at ``path`` holds, lined up."""
    path = Path(path)
    streams = load_xdf(path)
    ours = [s for s in streams if _field(s, "type") == "Markers" and _field(s, "name") == MARKERS_NAME]
    if not ours:
        raise XdfError(f"{path}: no Markers stream named '{MARKERS_NAME}' (the markers of microg session run --lsl); "
                       f"it holds {', '.join(_describe(s) for s in streams) or 'no streams'}")
    lineups, strangers = [], []
    for markers in ours:
        tags = _tags(markers)
        if tags is None:
            raise XdfError(f"{path}: the Markers stream '{MARKERS_NAME}' names no session (no <desc><microg> in its "
                           "header); it was sent by an older microg")
        session_id = int(tags.get("session", "0"))
        known = store.db.execute("SELECT 1 FROM sessions WHERE id = ?", (session_id,)).fetchone()
        if known is None or session_tags(store, session_id) != tags:
            strangers.append(tags)
            continue
        mocap = [s for s in streams if _field(s, "type") == "MoCap" and _field(s, "name") == MOCAP_NAME
                 and _tags(s) == tags]
        lineups.append(_line_up(store, path, session_id=session_id, stream=markers, mocap=mocap[0] if mocap else None))
    if not lineups:
        described = "; ".join(f"participant {t.get('participant')}, session {t.get('session')} (created "
                              f"{t.get('session_created')}) of study '{t.get('study')}'" for t in strangers)
        raise XdfError(f"{path}: its Markers streams '{MARKERS_NAME}' are of {described}: no session of the study in "
                       f"{store.dir}")
    return lineups


def _logged_events(store: Store, session_id: int) -> list[dict]:
    rows = store.db.execute("SELECT run_id, t, kind, data FROM events WHERE session_id = ? ORDER BY id",
                            (session_id,))
    return [{"run_id": r["run_id"], "t": r["t"], "kind": r["kind"], "data": json.loads(r["data"])} for r in rows]


def _match(markers: list[dict], events: list[dict]) -> list[int | None]:
    """For each marker in order, the index of its logged event (same kind, and the marker's data as
    logged), or None. The log has more than the markers (runs skipped, the tracking guard's counts,
    answers), so a marker is matched with the next logged event like it, within its part of the
    session: a marker sent as the session died was never logged, and must not take the like event
    the resumed session logged when it did that task again."""
    resumes = [i for i, e in enumerate(events) if e["kind"] == "session_resume"] + [len(events)]
    matched, start = [], 0
    for marker in markers:
        data = {k: v for k, v in marker.items() if k != "kind"}
        resume = marker.get("kind") == "session_resume"
        stop = len(events) if resume else next(r for r in resumes if r >= start)
        found = next((i for i in range(start, stop) if events[i]["kind"] == marker.get("kind")
                      and all(events[i]["data"].get(k, object()) == v for k, v in data.items())), None)
        matched.append(found)
        if found is not None:
            start = found + 1
    return matched


def _parse(sample: str) -> dict:
    try:
        parsed = json.loads(sample)
    except ValueError:
        return {}
    return parsed if isinstance(parsed, dict) else {}


def _line_up(store: Store, path: Path, *, session_id: int, stream: dict, mocap: dict | None) -> Lineup:
    session = store.session(session_id)
    who = f"participant {session.participant_id}, session {session_id}"
    sent = [_parse(sample[0]) for sample in stream["time_series"]]
    stamps = np.asarray(stream["time_stamps"], dtype=float)
    events = _logged_events(store, session_id)
    matched = _match(sent, events)
    pairs = [(events[i]["t"], stamps[k], i) for k, i in enumerate(matched) if i is not None]
    if len(pairs) < MIN_MARKERS or len({t for t, _, _ in pairs}) < 2:
        raise XdfError(f"{path}: {len(pairs)} of the {len(sent)} markers of the Markers stream '{MARKERS_NAME}' "
                       f"({who}) match the study log's events, at {len({t for t, _, _ in pairs})} distinct times; "
                       f"fitting the clocks needs at least {MIN_MARKERS} at two or more")
    resumes = [i for i, e in enumerate(events) if e["kind"] == "session_resume"]
    starts = np.array([-np.inf] + [events[i]["t"] for i in resumes])
    part = np.searchsorted(resumes, [i for _, _, i in pairs], side="right")  # resumes up to each marker's event
    fit = fit_parts(np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]), part, starts)
    keys = {"participant": session.participant_id, "session": session_id}
    residual = dict(zip((p[2] for p in pairs), fit.residuals))
    markers = pd.DataFrame([{
        **keys, "lsl_time": stamps[k], "kind": m.get("kind"), "data": json.dumps(m, sort_keys=True),
        "matched": i is not None, "study_t": events[i]["t"] if i is not None else np.nan,
        "residual_ms": residual[i] * 1e3 if i is not None else np.nan} for k, (m, i) in enumerate(zip(sent, matched))])
    marked = {(events[i]["run_id"], events[i]["kind"]): stamps[k] for k, i in enumerate(matched)
              if i is not None and events[i]["kind"] in ("task_start", "task_end")}
    tasks = _tasks(store, session_id, keys=keys, fit=fit, marked=marked)
    samples = None
    if mocap is not None:
        samples, tasks["mocap_samples"] = _mocap(mocap, keys, fit, tasks)
    return Lineup(session.participant_id, session_id, session.clock, fit, markers, tasks, samples)


def _tasks(store: Store, session_id: int, *, keys: dict, fit: Fit, marked: dict) -> pd.DataFrame:
    rows = store.db.execute("""
        SELECT r.id AS run_id, r.task_index, t.phase, t.interaction, t.object_code, t.object, r.run, r.status,
               r.started_at, r.ended_at, r.frames
        FROM task_runs r JOIN tasks t ON t.session_id = r.session_id AND t.task_index = r.task_index
        WHERE r.session_id = ? ORDER BY r.id""", (session_id,)).fetchall()
    table = []
    for r in rows:
        start, end = marked.get((r["run_id"], "task_start")), marked.get((r["run_id"], "task_end"))
        table.append({
            **keys, "task_index": r["task_index"], "phase": r["phase"], "interaction": r["interaction"],
            "object": r["object_code"], "object_name": r["object"], "run": r["run"], "status": r["status"],
            "started_at": r["started_at"], "ended_at": r["ended_at"],
            "lsl_start": float(fit.lsl(r["started_at"])) if start is None else start,
            "lsl_end": (np.nan if r["ended_at"] is None else float(fit.lsl(r["ended_at"]))) if end is None else end,
            "lsl_start_from": "fit" if start is None else "marker", "lsl_end_from": "fit" if end is None else "marker",
            "frames": r["frames"]})
    return pd.DataFrame(table)


def _nullable(values: np.ndarray) -> pd.arrays.IntegerArray:
    return pd.arrays.IntegerArray(values.astype("int64"), values < 0)


def _mocap(stream: dict, keys: dict, fit: Fit, tasks: pd.DataFrame) -> tuple[pd.DataFrame, list[int]]:
    """The MoCap samples with the session's time, and the run and frame each shows (the session sends
    a run's frames between its task_start and task_end markers, one sample per logged frame); and
    how many samples each run has."""
    stamps = np.asarray(stream["time_stamps"], dtype=float)
    values = np.asarray(stream["time_series"], dtype=np.float32).reshape(len(stamps), len(MOCAP_CHANNELS))
    task_index = np.full(len(stamps), -1)
    run = np.full(len(stamps), -1)
    frame = np.full(len(stamps), -1)
    counts = []
    for r in tasks.itertuples():
        inside = np.flatnonzero((stamps >= r.lsl_start) & (stamps <= r.lsl_end))
        task_index[inside], run[inside], frame[inside] = r.task_index, r.run, np.arange(len(inside))
        counts.append(len(inside))
    head = pd.DataFrame({**{k: [v] * len(stamps) for k, v in keys.items()}, "lsl_time": stamps,
                         "study_t": fit.study(stamps), "task_index": _nullable(task_index), "run": _nullable(run),
                         "frame": _nullable(frame)})
    channels = pd.DataFrame(values, columns=[label for label, _, _ in MOCAP_CHANNELS])
    return pd.concat([head, channels], axis=1), counts


def write_lineups(lineups: list[Lineup], out_dir: Path, formats: tuple[str, ...], overwrite: bool) -> list[Path]:
    """``xdf_tasks``, ``xdf_markers`` and ``xdf_mocap`` (each in ``formats``) into ``out_dir``."""
    if out_dir.exists() and not overwrite:
        raise FileExistsError(f"{out_dir} exists; write into another folder or pass --overwrite")
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name in TABLES:
        parts = [getattr(lineup, name) for lineup in lineups if getattr(lineup, name) is not None]
        if not parts:
            continue
        table = pd.concat(parts, ignore_index=True)
        for fmt in formats:
            target = out_dir / f"xdf_{name}.{fmt}"
            if fmt == "csv":
                table.to_csv(target, index=False)
            else:
                table.to_parquet(target, index=False)
            written.append(target)
    return written
