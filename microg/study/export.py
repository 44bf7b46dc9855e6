"""Tidy tables from the log store: trials, questionnaire answers and frames (CSV, Parquet).

- ``trials``: one row per planned task of every session (its last run decides): study, participant,
  group, gender, age, handedness, mr_experience, stage, system, object (the paper's code: C, F,
  L), order_position, completed, time_s, attempts, started_at, ended_at, then status (completed,
  timeout, aborted, skipped, unfinished, not_run), simulated, object_name, runs, withdrawn,
  session, task_index. ``time_s`` is empty unless completed; ``attempts`` is the number of drops
  and is empty for a task that never ran; ``started_at``/``ended_at`` are session-clock seconds.
- ``questionnaire``: study, participant, group, system, item, rating, source, simulated, withdrawn.
- ``frames``: one row per logged frame, hand channels flattened (``hand_columns``).

``read_tables(study_dir)`` returns (trials, questionnaire) for the statistics: from a study's
database, or from a folder of exported ``trials``/``questionnaire`` files.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterator

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from microg.sim import BONES, DIGITS, Hand, HandFrame
from microg.sim.hand import SIDES

from .store import DATABASE, FINAL_RUN, HAND_VALUES, Store, hand_parts, hand_values, open_study

TRIAL_COLUMNS = ["study", "participant", "group", "gender", "age", "handedness", "mr_experience", "stage", "system",
                 "object", "order_position", "completed", "time_s", "attempts", "started_at", "ended_at", "status",
                 "simulated", "object_name", "runs", "withdrawn", "session", "task_index"]
QUESTIONNAIRE_COLUMNS = ["study", "participant", "group", "system", "item", "rating", "source", "simulated",
                         "withdrawn"]
JOINTS = ("metacarpal_base", "proximal_base", "intermediate_base", "distal_base", "tip")
"""Joint j of a digit is where bone j begins (j < 4) or the digit's tip."""
FRAME_STATE_COLUMNS = ["frame", "t", "stage", "place", "place_lit", "place_timer", "grasped", "held", "touching",
                       "px", "py", "pz", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz"]


def hand_columns(side: str) -> list[str]:
    """Column names of one side's hand values, in ``HAND_LAYOUT`` order."""
    names = [f"{side}_{d}_{j}_{axis}" for d in DIGITS for j in JOINTS for axis in "xyz"]
    names += [f"{side}_{d}_{b}_width" for d in DIGITS for b in BONES]
    names += [f"{side}_palm_{axis}" for axis in "xyz"] + [f"{side}_palm_q{c}" for c in "wxyz"]
    names += [f"rendered_{side}_{d}_{b}_{axis}" for d in DIGITS for b in BONES for axis in "xyz"]
    assert len(names) == HAND_VALUES
    return names


def _status(last_status: str | None) -> str:
    if last_status is None:
        return "not_run"
    return last_status if last_status in FINAL_RUN else "unfinished"


def trials_table(store: Store) -> pd.DataFrame:
    rows = store.db.execute("""
        SELECT p.id AS participant, p.group_code, p.gender, p.age, p.handedness, p.mr_experience,
               p.status AS participant_status, s.id AS session, s.simulated, t.task_index, t.phase, t.system,
               t.object, t.object_code, t.order_position,
               r.status, r.time_s, r.attempts, r.started_at, r.ended_at,
               (SELECT COUNT(*) FROM task_runs c WHERE c.session_id = t.session_id AND c.task_index = t.task_index) AS runs
        FROM tasks t
        JOIN sessions s ON s.id = t.session_id
        JOIN participants p ON p.id = s.participant_id
        LEFT JOIN task_runs r ON r.session_id = t.session_id AND r.task_index = t.task_index
             AND r.run = (SELECT MAX(run) FROM task_runs m WHERE m.session_id = t.session_id AND m.task_index = t.task_index)
        ORDER BY p.number, t.task_index""").fetchall()
    table = pd.DataFrame([{
        "study": store.name, "participant": r["participant"], "group": r["group_code"], "gender": r["gender"],
        "age": r["age"], "handedness": r["handedness"], "mr_experience": bool(r["mr_experience"]),
        "stage": r["phase"], "system": r["system"], "object": r["object_code"], "object_name": r["object"],
        "order_position": r["order_position"], "completed": r["status"] == "completed",
        "time_s": r["time_s"] if r["status"] == "completed" else None,
        "attempts": r["attempts"] if r["status"] in ("completed", "timeout", "aborted") else None,
        "started_at": r["started_at"] if r["status"] in FINAL_RUN else None,
        "ended_at": r["ended_at"] if r["status"] in FINAL_RUN else None,
        "status": _status(r["status"]), "runs": r["runs"], "simulated": bool(r["simulated"]),
        "withdrawn": r["participant_status"] == "withdrawn", "session": r["session"], "task_index": r["task_index"],
    } for r in rows], columns=TRIAL_COLUMNS)
    return table.astype({"age": "Int64", "order_position": "Int64", "attempts": "Int64", "runs": "Int64",
                         "session": "Int64", "task_index": "Int64", "time_s": "float64", "started_at": "float64",
                         "ended_at": "float64", "completed": "bool", "simulated": "bool", "withdrawn": "bool",
                         "mr_experience": "bool"})


def questionnaire_table(store: Store) -> pd.DataFrame:
    rows = store.db.execute("""
        SELECT p.id AS participant, p.group_code, p.status AS participant_status, s.simulated, a.system, a.item,
               a.rating, a.source
        FROM answers a JOIN sessions s ON s.id = a.session_id JOIN participants p ON p.id = s.participant_id
        ORDER BY p.number, a.system, a.item""").fetchall()
    table = pd.DataFrame([{
        "study": store.name, "participant": r["participant"], "group": r["group_code"], "system": r["system"],
        "item": r["item"], "rating": r["rating"], "source": r["source"],
        "simulated": bool(r["simulated"]) or r["source"] == "model",
        "withdrawn": r["participant_status"] == "withdrawn",
    } for r in rows], columns=QUESTIONNAIRE_COLUMNS)
    return table.astype({"rating": "Int64", "simulated": "bool", "withdrawn": "bool"})


def run_frames(store: Store, run_id: int) -> pd.DataFrame:
    """Every logged frame of one task run, hand channels flattened (NaN where not tracked)."""
    rows = store.db.execute("SELECT * FROM frames WHERE run_id = ? ORDER BY frame", (run_id,)).fetchall()
    state = pd.DataFrame([tuple(r[c] for c in FRAME_STATE_COLUMNS) for r in rows], columns=FRAME_STATE_COLUMNS)
    hands = [pd.DataFrame(np.array([hand_values(r[side]) for r in rows]).reshape(len(rows), HAND_VALUES),
                          columns=hand_columns(side)) for side in SIDES]
    return pd.concat([state] + hands, axis=1)


def hand_frames(store: Store, run_id: int) -> list[HandFrame]:
    """The hand frames of a task run exactly as its source delivered them: feed them to
    ``microg.sim.step`` on ``session.task_world`` to simulate the run again."""
    frames = []
    for row in store.db.execute("SELECT t, left, right FROM frames WHERE run_id = ? ORDER BY frame", (run_id,)):
        hands = []
        for side in SIDES:
            if row[side] is None:
                continue
            parts = hand_parts(hand_values(row[side]))
            hands.append(Hand(side, parts["joints"].reshape(5, 5, 3), parts["widths"].reshape(5, 4),
                              parts["palm_position"], parts["palm_orientation"]))
        frames.append(HandFrame(row["t"], tuple(hands)))
    return frames


def run_list(store: Store) -> list[dict]:
    """Every task run with frames, with what names it: participant, phase, object, run number."""
    rows = store.db.execute("""
        SELECT r.id AS run_id, r.run, r.status, r.source, s.participant_id AS participant, s.id AS session,
               s.simulated, s.input, t.task_index, t.phase, t.system, t.object
        FROM task_runs r JOIN tasks t ON t.session_id = r.session_id AND t.task_index = r.task_index
        JOIN sessions s ON s.id = r.session_id
        WHERE EXISTS (SELECT 1 FROM frames f WHERE f.run_id = r.id) ORDER BY r.id""").fetchall()
    return [dict(r) for r in rows]


def frames_tables(store: Store) -> Iterator[pd.DataFrame]:
    """The frames table, one task run at a time (a study's frames may not fit in memory at once)."""
    for run in run_list(store):
        table = run_frames(store, run["run_id"])
        keys = {"study": store.name, "participant": run["participant"], "session": run["session"],
                "run_id": run["run_id"], "task_index": run["task_index"], "run": run["run"],
                "run_status": run["status"], "phase": run["phase"], "system": run["system"], "object": run["object"]}
        yield pd.concat([pd.DataFrame({k: [v] * len(table) for k, v in keys.items()}), table], axis=1)


def read_tables(study_dir: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(trials, questionnaire) of a study folder (with ``study.db``) or of an export folder."""
    study_dir = Path(study_dir)
    if (study_dir / DATABASE).exists():
        with open_study(study_dir) as store:
            return trials_table(store), questionnaire_table(store)
    tables = []
    for name in ("trials", "questionnaire"):
        if (study_dir / f"{name}.parquet").exists():
            tables.append(pd.read_parquet(study_dir / f"{name}.parquet"))
        elif (study_dir / f"{name}.csv").exists():
            tables.append(pd.read_csv(study_dir / f"{name}.csv"))
        else:
            raise FileNotFoundError(f"{study_dir}: neither a study ({DATABASE}) nor an export ({name}.parquet "
                                    f"or {name}.csv)")
    return tables[0], tables[1]


def _claim(path: Path, overwrite: bool) -> Path:
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; export into another folder or pass --overwrite")
    return path


def export_study(study_dir: str | Path, out_dir: str | Path, formats: tuple[str, ...] = ("csv", "parquet"),
                 frames: bool = True, bids: bool = True, overwrite: bool = False, progress: bool = True) -> list[Path]:
    """Write the tables (and Motion-BIDS) into ``out_dir``; existing files are replaced only with
    ``overwrite``. Returns the files written."""
    from tqdm import tqdm

    from .bids import write_motion_bids

    out_dir = Path(out_dir)
    unknown = set(formats) - {"csv", "parquet"}
    if unknown or not formats:
        raise ValueError(f"formats = {list(formats)}: choose from csv, parquet")
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    with open_study(study_dir) as store:
        planned = [out_dir / f"{n}.{f}" for n in ("trials", "questionnaire") + (("frames",) if frames else ())
                   for f in formats] + [out_dir / "export.json"]
        for path in planned:
            _claim(path, overwrite)
        for name, table in (("trials", trials_table(store)), ("questionnaire", questionnaire_table(store))):
            for fmt in formats:
                path = out_dir / f"{name}.{fmt}"
                if fmt == "csv":
                    table.to_csv(path, index=False)
                else:
                    table.to_parquet(path, index=False)
                written.append(path)
        if frames:
            runs = run_list(store)
            writers: dict[str, object] = {}
            try:
                for i, table in enumerate(tqdm(frames_tables(store), total=len(runs), unit="run", desc="frames",
                                               disable=not progress)):
                    if "csv" in formats:
                        table.to_csv(out_dir / "frames.csv", index=False, mode="w" if i == 0 else "a", header=i == 0)
                    if "parquet" in formats:
                        arrow = pa.Table.from_pandas(table, preserve_index=False)
                        if "parquet" not in writers:
                            writers["parquet"] = pq.ParquetWriter(out_dir / "frames.parquet", arrow.schema)
                        writers["parquet"].write_table(arrow)
            finally:
                for writer in writers.values():
                    writer.close()
            written += [out_dir / f"frames.{f}" for f in formats if runs]
        if bids:
            written += write_motion_bids(store, out_dir / "bids", overwrite=overwrite)
    meta = out_dir / "export.json"
    meta.write_text(json.dumps({"study": str(Path(study_dir).resolve()), "files": [str(p.relative_to(out_dir))
                                                                                  for p in written]}, indent=2))
    return written + [meta]
