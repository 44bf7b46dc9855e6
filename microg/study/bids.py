"""Motion-BIDS export of the hand-tracking data: one recording per task run.

Layout (the run's stage is the BIDS task, its object the acquisition, its run number the run)::

    bids/dataset_description.json, participants.tsv, participants.json
    bids/sub-P01/motion/sub-P01_task-stage1_tracksys-hand_acq-cube_run-1_motion.tsv
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
from pathlib import Path

import pandas as pd

from microg import __version__
from microg.sim import BONES, DIGITS
from microg.sim.hand import SIDES

from .export import JOINTS, run_frames, run_list
from .store import Store

BIDS_VERSION = "1.10.0"
TRACKSYS = "hand"
REFERENCE_FRAME = "tracker"
REFERENCE_DESCRIPTION = ("The hand tracker's frame (Leap Motion): origin at the device, x to the right, y up, "
                         "z toward the participant; right-handed; metres. Simulated objects live in the same frame.")


def label(text: str) -> str:
    """A BIDS label: letters and digits only."""
    return re.sub(r"[^A-Za-z0-9]", "", text)


def recording_name(participant: str, phase: str, obj: str, run: int) -> str:
    return f"sub-{label(participant)}_task-{label(phase)}_tracksys-{TRACKSYS}_acq-{label(obj)}_run-{run}"


def _channels(sides: list[str], obj: str) -> list[dict]:
    rows = [dict(name="latency", component="n/a", type="LATENCY", tracked_point="n/a", units="s", source="t")]

    def add(prefix_point, columns, kind, components, units):
        for column, component in zip(columns, components):
            rows.append(dict(name=column, component=component, type=kind, tracked_point=prefix_point,
                             units=units, source=column))

    for side in sides:
        for d in DIGITS:
            for j in JOINTS:
                add(f"{side}_{d}_{j}", [f"{side}_{d}_{j}_{a}" for a in "xyz"], "POS", "xyz", "m")
        add(f"{side}_palm", [f"{side}_palm_{a}" for a in "xyz"], "POS", "xyz", "m")
        add(f"{side}_palm", [f"{side}_palm_q{c}" for c in "xyzw"], "ORNT",
            ["quat_x", "quat_y", "quat_z", "quat_w"], "n/a")
    add(obj, ["px", "py", "pz"], "POS", "xyz", "m")
    add(obj, ["qx", "qy", "qz", "qw"], "ORNT", ["quat_x", "quat_y", "quat_z", "quat_w"], "n/a")
    for side in sides:
        for d in DIGITS:
            for b in BONES:
                add(f"rendered_{side}_{d}_{b}", [f"rendered_{side}_{d}_{b}_{a}" for a in "xyz"], "POS", "xyz", "m")
    for row in rows:
        row["reference_frame"] = "n/a" if row["type"] == "LATENCY" else REFERENCE_FRAME
    return rows


def _write(path: Path, text: str, overwrite: bool) -> Path:
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; export into another folder or pass --overwrite")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _tsv(table: pd.DataFrame, header: bool = True) -> str:
    return table.to_csv(sep="\t", index=False, header=header, na_rep="n/a", lineterminator="\n")


def write_motion_bids(store: Store, out_dir: str | Path, overwrite: bool = False) -> list[Path]:
    """Write the study's task runs as a Motion-BIDS dataset in ``out_dir``; returns the files."""
    out_dir = Path(out_dir)
    protocol = store.protocol
    rate = protocol.tracking_rate
    written = [
        _write(out_dir / "dataset_description.json", json.dumps({
            "Name": f"{store.name}: {protocol.title}" if protocol.title else store.name,
            "BIDSVersion": BIDS_VERSION, "DatasetType": "raw",
            "GeneratedBy": [{"Name": "microg", "Version": __version__}]}, indent=2), overwrite)]
    people = pd.DataFrame([{"participant_id": f"sub-{label(p.id)}", "group": p.group, "gender": p.participant.gender,
                            "age": p.participant.age, "handedness": p.participant.handedness,
                            "mr_experience": "yes" if p.participant.mr_experience else "no",
                            "status": p.status} for p in store.participants()])
    written.append(_write(out_dir / "participants.tsv", _tsv(people), overwrite))
    written.append(_write(out_dir / "participants.json", json.dumps({
        "group": {"Description": "study group", "Levels": {g.code: g.name for g in protocol.groups}},
        "gender": {"Description": "gender as the participant stated it"},
        "age": {"Description": "age", "Units": "year"},
        "handedness": {"Description": "dominant hand", "Levels": {"left": "left", "right": "right",
                                                                   "ambidextrous": "ambidextrous"}},
        "mr_experience": {"Description": "has used mixed reality before"},
        "status": {"Description": "active, or withdrawn from the study"}}, indent=2), overwrite))

    for run in run_list(store):
        frames = run_frames(store, run["run_id"])
        sides = [s for s in SIDES if frames[f"{s}_palm_x"].notna().any()]
        channels = _channels(sides, run["object"])
        values = pd.DataFrame({c["name"]: frames[c["source"]] for c in channels})
        values["latency"] = frames["t"] - frames["t"].iloc[0]
        name = recording_name(run["participant"], run["phase"], run["object"], run["run"])
        folder = out_dir / f"sub-{label(run['participant'])}" / "motion"
        duration = float(values["latency"].iloc[-1])
        counts = pd.Series([c["type"] for c in channels]).value_counts()
        sidecar = {
            "TaskName": run["phase"],
            "TaskDescription": f"pick-and-place of the {run['object']} with the {run['system']} interaction model "
                               f"(run {run['run']}, {run['status']})",
            "SamplingFrequency": rate,
            "SamplingFrequencyEffective": (len(values) - 1) / duration if duration > 0 else "n/a",
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
        }
        events = [e for e in store.events(run["session"], run["run_id"]) if "frame_t" in e.data]
        t0 = float(frames["t"].iloc[0])
        event_table = pd.DataFrame([{
            "onset": round(e.data["frame_t"] - t0, 6), "duration": 0.0, "trial_type": e.kind,
            "stage": e.data.get("stage", "n/a"), "place": e.data.get("place", "n/a")} for e in events],
            columns=["onset", "duration", "trial_type", "stage", "place"])
        written += [
            _write(folder / f"{name}_motion.tsv", _tsv(values, header=False), overwrite),
            _write(folder / f"{name}_channels.tsv",
                   _tsv(pd.DataFrame(channels).drop(columns="source")), overwrite),
            _write(folder / f"{name}_channels.json", json.dumps({"reference_frame": {
                "Description": "reference frame of the channel",
                "Levels": {REFERENCE_FRAME: {"Description": REFERENCE_DESCRIPTION, "RotationRule": "right-hand"}}}},
                indent=2), overwrite),
            _write(folder / f"{name}_motion.json", json.dumps(sidecar, indent=2), overwrite),
            _write(folder / f"{name}_events.tsv", _tsv(event_table), overwrite),
        ]
    return written
