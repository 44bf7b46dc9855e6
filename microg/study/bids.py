"""Motion-BIDS export of the hand-tracking data: one recording per task run.

Layout (the run's phase is the BIDS task, its object the acquisition, its run number the run)::

    bids/dataset_description.json, participants.tsv, participants.json
    bids/sub-P01/motion/sub-P01_task-stage1_tracksys-hand_acq-cube_run-1_motion.tsv
    (a training program's: bids/sub-P01/ses-train1/motion/sub-P01_ses-train1_task-...)
                        ..._motion.json   TaskName, SamplingFrequency, TrackingSystemName, counts
                        ..._channels.tsv  name, component, type, tracked_point, units, reference_frame
                        ..._channels.json the reference frame
                        ..._events.tsv    onset, duration, trial_type, stage, place

``*_motion.tsv`` has no header; its columns are the rows of ``*_channels.tsv``: a LATENCY channel
(frames arrive unevenly), the tracked joints and palm of each hand seen in the run, the object's
position and orientation, and the rendered (god-object) phalanges. Positions in metres in the
tracker frame, orientations as quaternions; ``n/a`` where a value was not tracked.
"""

from __future__ import annotations

import json
import re
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv

from microg import __version__
from microg.skeleton import BONES, DIGITS, SIDES

from . import framelog
from .export import run_list
from .framelog import JOINT_NAMES
from .store import Store, StoreError

BIDS_VERSION = "1.10.0"
TRACKSYS = "hand"
REFERENCE_FRAME = "tracker"
REFERENCE_DESCRIPTION = ("The hand tracker's frame (Leap Motion): origin at the device, x to the right, y up, "
                         "z toward the participant; right-handed; metres. Simulated objects live in the same frame.")


ABSENT_CHANNELS = ("ACCEL", "ANGACCEL", "GYRO", "JNTANG", "MAGN", "MISC", "VEL")
"""Motion channel types the export has none of (the sidecar says 0 of each)."""
EVENTS_SIDECAR = {
    "trial_type": {"Description": "the task event (microg.task): e.g. hold, drop, place_lit, place_done, "
                                  "respawn, completed"},
    "stage": {"Description": "the task's stage at the event: manipulation, maintenance or release"},
    "place": {"Description": "index (0-based) of the place the event concerns"},
    "StimulusPresentation": {"SoftwareName": "microg", "SoftwareVersion": __version__},
}


def label(text: str) -> str:
    """A BIDS label: letters and digits only."""
    return re.sub(r"[^A-Za-z0-9]", "", text)


def recording_name(participant: str, phase: str, obj: str, run: int, session: str | None = None) -> str:
    """A recording's BIDS name; ``session``: a training program's session (the ``ses-`` entity)."""
    ses = "" if session is None else f"_ses-{label(session)}"
    return f"sub-{label(participant)}{ses}_task-{label(phase)}_tracksys-{TRACKSYS}_acq-{label(obj)}_run-{run}"


def _channels(sides: list[str], obj: str) -> list[dict]:
    rows = [dict(name="latency", component="n/a", type="LATENCY", tracked_point="n/a", units="s", source="t")]

    def add(prefix_point, columns, *, kind, components, units):
        for column, component in zip(columns, components):
            rows.append(dict(name=column, component=component, type=kind, tracked_point=prefix_point,
                             units=units, source=column))

    for side in sides:
        for d in DIGITS:
            for j in JOINT_NAMES:
                add(f"{side}_{d}_{j}", [f"{side}_{d}_{j}_{a}" for a in "xyz"], kind="POS", components="xyz", units="m")
        add(f"{side}_palm", [f"{side}_palm_{a}" for a in "xyz"], kind="POS", components="xyz", units="m")
        add(f"{side}_palm", [f"{side}_palm_q{c}" for c in "xyzw"], kind="ORNT",
            components=["quat_x", "quat_y", "quat_z", "quat_w"], units="n/a")
    add(obj, ["px", "py", "pz"], kind="POS", components="xyz", units="m")
    add(obj, ["qx", "qy", "qz", "qw"], kind="ORNT", components=["quat_x", "quat_y", "quat_z", "quat_w"], units="n/a")
    for side in sides:
        for d in DIGITS:
            for b in BONES:
                add(f"rendered_{side}_{d}_{b}", [f"rendered_{side}_{d}_{b}_{a}" for a in "xyz"], kind="POS",
                    components="xyz", units="m")
    for row in rows:
        row["reference_frame"] = "n/a" if row["type"] == "LATENCY" else REFERENCE_FRAME
    return rows


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _tsv(table: pd.DataFrame, header: bool = True) -> str:
    return table.to_csv(sep="\t", index=False, header=header, na_rep="n/a", lineterminator="\n", float_format="%.7g")


WRITERS = 2
"""Motion files written at once: Arrow's CSV writer runs without the GIL, so two use both cores of a laptop."""


def _write_motion(path: Path, values: dict[str, np.ndarray], bar=None) -> None:
    """A ``*_motion.tsv``: no header, ``n/a`` where a value is unknown. The channels at the
    tracker's precision (single, as the Leap Motion delivers them: 0.01 um at 1 m), the latency to
    the microsecond. Written by Arrow's CSV writer, ten times faster than formatting each value in
    Python (the frames are most of an export), in ``WRITERS`` threads while the next run is read."""
    columns = {name: pa.array(np.round(column, 6) if name == "latency" else column.astype(np.float32),
                              from_pandas=True) for name, column in values.items()}
    pa_csv.write_csv(pa.table(columns), str(path), pa_csv.WriteOptions(
        include_header=False, delimiter="\t", quoting_style="none", null_string="n/a"))
    if bar is not None:
        bar.update()


README = """# {name}

Hand tracking and simulated-object data of a user study run with microg {version}: each task run
of each participant is one Motion-BIDS recording (task = the study phase, acq = the object).
Positions are metres in the hand tracker's frame, orientations unit quaternions; see each
recording's *_channels.tsv and *_motion.json. Simulated participants are marked in the sidecars
(TrackingSystemName). Events (*_events.tsv) are the task's stages, places, drops and respawns.

Protocol: {title}
"""


def _motion_sidecar(run: dict, channels: list[dict], *, samples: int, duration: float, rate, instructions: str,
                    about) -> dict:
    """A recording's ``*_motion.json``."""
    counts = pd.Series([c["type"] for c in channels]).value_counts()
    return {
        "TaskName": run["phase"],
        "TaskDescription": f"pick-and-place of the {run['object']} with the {run['interaction']} interaction model "
                           f"(run {run['run']}, {run['status']})",
        "SamplingFrequency": rate,
        "SamplingFrequencyEffective": (samples - 1) / duration if duration > 0 else "n/a",
        "TrackingSystemName": "simulated participant" if run["simulated"] else "hand tracker",
        "Manufacturer": "microg (simulated)" if run["simulated"] else "Ultraleap",
        "SoftwareVersions": f"microg {__version__}; input {run['input']}",
        "RecordingDuration": duration,
        "MotionChannelCount": len(channels),
        "POSChannelCount": int(counts.get("POS", 0)),
        "ORNTChannelCount": int(counts.get("ORNT", 0)),
        "LATENCYChannelCount": int(counts.get("LATENCY", 0)),
        "TrackedPointsCount": len({c["tracked_point"] for c in channels if c["type"] != "LATENCY"}),
        "SubjectArtefactDescription": "n/a",
        "MissingValues": "n/a",
        "Instructions": instructions,
        "ManufacturersModelName": "microg simulated participant" if run["simulated"] else "n/a",
        "DeviceSerialNumber": "n/a",
        "InstitutionName": about.institution or "n/a",
        "InstitutionAddress": about.institution_address or "n/a",
        "InstitutionalDepartmentName": about.department or "n/a",
    } | {f"{kind}ChannelCount": 0 for kind in ABSENT_CHANNELS}


def write_motion_bids(store: Store, out_dir: str | Path, bar=None, runs: list[dict] | None = None) -> list[Path]:
    """Write the study's task runs (``runs``, of ``run_list``; default: every run with frames) as a
    Motion-BIDS dataset into the new folder ``out_dir``; returns the files. ``bar`` (a tqdm bar)
    counts the runs written."""
    out_dir = Path(out_dir)
    protocol = store.protocol
    rate = protocol.tracking_rate
    about = protocol.dataset
    written = [
        _write(out_dir / "dataset_description.json", json.dumps({
            "Name": f"{store.name}: {protocol.title}" if protocol.title else store.name,
            "BIDSVersion": BIDS_VERSION, "DatasetType": "raw",
            "License": about.license or "See the study's data sharing agreement",
            "Authors": list(about.authors) or ["The study's researchers (microg export)"],
            "GeneratedBy": [{"Name": "microg", "Version": __version__}]}, indent=2)),
        _write(out_dir / "README.md", README.format(name=store.name, version=__version__,
                                                     title=protocol.title or protocol.name))]
    subjects: dict[str, str] = {}
    for p in store.participants():
        twin = subjects.setdefault(label(p.id).lower(), p.id)
        if twin != p.id:
            raise StoreError(f"participants {twin!r} and {p.id!r} would be one Motion-BIDS subject "
                             f"(sub-{label(p.id)}): the BIDS export keeps ASCII letters and digits, case aside; "
                             "export with --no-bids")
    people = pd.DataFrame([{"participant_id": f"sub-{label(p.id)}", "group": p.group, "gender": p.participant.gender,
                            "age": p.participant.age, "handedness": p.participant.handedness,
                            "mr_experience": "yes" if p.participant.mr_experience else "no",
                            "status": p.status} for p in store.participants()])
    written.append(_write(out_dir / "participants.tsv", _tsv(people)))
    written.append(_write(out_dir / "participants.json", json.dumps({
        "group": {"Description": "study group", "Levels": {g.code: g.name for g in protocol.groups}},
        "gender": {"Description": "gender as the participant stated it"},
        "age": {"Description": "age", "Units": "year"},
        "handedness": {"Description": "dominant hand", "Levels": {"left": "left", "right": "right",
                                                                   "ambidextrous": "ambidextrous"}},
        "mr_experience": {"Description": "has used mixed reality before"},
        "status": {"Description": "active, or withdrawn from the study"}}, indent=2)))

    instructions = " ".join(" ".join(p.text.split()) for p in protocol.timeline if p.name == "instructions") or "n/a"
    with ThreadPoolExecutor(max_workers=WRITERS) as background:
        writing: list[Future] = []
        numbers: dict[tuple, int] = {}
        for run in run_list(store) if runs is None else runs:
            frames = framelog.frame_columns(framelog.read(store.db, run["run_id"]))
            sides = [s for s in SIDES if not np.isnan(frames[f"{s}_palm_x"]).all()]
            channels = _channels(sides, run["object"])
            values = {c["name"]: frames[c["source"]] for c in channels}
            t0 = float(frames["t"][0])
            values["latency"] = frames["t"] - t0
            # the run entity counts a participant's recordings of one phase and object in a session (a task run
            # again after a cut, or a phase trained to a criterion that gives the object again)
            session = run["session"] if store.protocol.program else None
            key = (run["participant"], session, run["phase"], run["object"])
            numbers[key] = numbers.get(key, 0) + 1
            name = recording_name(run["participant"], run["phase"], run["object"], numbers[key], session)
            folder = out_dir / f"sub-{label(run['participant'])}" / ("" if session is None else
                                                                    f"ses-{label(session)}") / "motion"
            duration = float(values["latency"][-1])
            sidecar = _motion_sidecar(run, channels, samples=len(values["latency"]), duration=duration, rate=rate,
                                      instructions=instructions, about=about)
            events = [e for e in store.events(run["session_id"], run["run_id"]) if "frame_t" in e.data]
            event_table = pd.DataFrame([{
                "onset": round(e.data["frame_t"] - t0, 6), "duration": 0.0, "trial_type": e.kind,
                "stage": e.data.get("stage", "n/a"), "place": e.data.get("place", "n/a")} for e in events],
                columns=["onset", "duration", "trial_type", "stage", "place"])
            if len(writing) == WRITERS:
                writing.pop(0).result()
            folder.mkdir(parents=True, exist_ok=True)
            writing.append(background.submit(_write_motion, folder / f"{name}_motion.tsv", values, bar))
            written += [
                folder / f"{name}_motion.tsv",
                _write(folder / f"{name}_channels.tsv", _tsv(pd.DataFrame(channels).drop(columns="source"))),
                _write(folder / f"{name}_channels.json", json.dumps({"reference_frame": {
                    "Description": "reference frame of the channel",
                    "Levels": {REFERENCE_FRAME: {"Description": REFERENCE_DESCRIPTION, "RotationRule": "right-hand"}}}},
                    indent=2)),
                _write(folder / f"{name}_motion.json", json.dumps(sidecar, indent=2)),
                _write(folder / f"{name}_events.tsv", _tsv(event_table)),
                _write(folder / f"{name}_events.json", json.dumps(EVENTS_SIDECAR, indent=2)),
            ]
        for motion in writing:
            motion.result()
    if bar is not None:
        bar.close()
    return written
