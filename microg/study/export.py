"""Tidy tables from the log store: trials, questionnaire answers, scores and frames (CSV, Parquet).

- ``trials``: one row per planned task of every session (its last run decides), with its task
  kind and the kind's own measures (``measure_declarations``; empty for the other kinds);
- ``questionnaire``: one row per answer to the paper's kind of 0-10 items (the Likert analysis's);
- ``answers``: one row per answer to every instrument, in the order they were given;
  the three name the station that ran the session (``station``; empty for one run in the study itself);
  their columns, types and meanings are ``microg.schema`` (what the analysis reads);
- ``scores``: the answers scored by the instruments' keys (``microg.analysis.scoring``, the same
  function as ``microg questionnaire score``), with ``instruments/`` beside them: the instrument
  files the study keeps, so that the export scores and reports the same way anywhere;
- ``frames``: one row per logged frame, hand channels flattened (``framelog.frame_table``);
- ``codebook.csv`` and ``dataset_description.json`` (Psych-DS's form): every column of every table
  written, from the declarations that make the tables (``table_declarations``; ``microg.study.codebook``).

``read_tables(study_dir)`` returns (trials, questionnaire) for the statistics and ``read_answers``
(answers, instruments): from a study's database, or from a folder of exported files.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterator

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from microg.instruments import Instrument, load_instrument
from microg.schema import ANSWER_COLUMNS, ANSWER_DTYPES, ANSWERS, ENROLMENT, PROGRESSION, PROTOCOL, QUESTIONNAIRE, \
    QUESTIONNAIRE_COLUMNS, QUESTIONNAIRE_DTYPES, SCORES, SESSION_LOG, STUDY, TASK_RULES, TRIALS, Column, KindInfo, \
    KindMeasure
from microg.skeleton import HandFrame
from microg.task import KINDS

from . import framelog, ledger
from .codebook import write_codebook
from .store import DATABASE, FINAL_RUN, RUN_STATUSES, Store, StoreError, nearest_folder, open_study, writable


def _status(last_status: str | None) -> str:
    if last_status is None:
        return "not_run"
    return last_status if last_status in FINAL_RUN else "unfinished"


def interaction_labels(store: Store) -> dict[str, str]:
    """How the protocol names each interaction model to the reader (its phases' labels)."""
    return {phase.interaction: phase.label for phase in store.protocol.phases}


def trials_table(store: Store) -> pd.DataFrame:
    """One row per planned task of every session (the module docstring lists the columns)."""
    labels = interaction_labels(store)
    rows = store.db.execute("""
        SELECT p.id AS participant, p.group_code, p.gender, p.age, p.handedness, p.mr_experience,
               p.status AS participant_status, s.id AS session_id, s.name AS session, s.session_index, s.date,
               s.simulated, s.station, t.task_index, t.phase, t.interaction,
               t.object, t.object_code, t.order_position, t.task_in_phase, t.difficulty,
               r.id AS run_id, r.status, r.time_s, r.attempts, r.started_at, r.ended_at,
               (SELECT COUNT(*) FROM task_runs c WHERE c.session_id = t.session_id AND c.task_index = t.task_index) AS runs
        FROM tasks t
        JOIN sessions s ON s.id = t.session_id
        JOIN participants p ON p.id = s.participant_id
        LEFT JOIN task_runs r ON r.session_id = t.session_id AND r.task_index = t.task_index
             AND r.run = (SELECT MAX(run) FROM task_runs m WHERE m.session_id = t.session_id AND m.task_index = t.task_index)
        ORDER BY p.number, s.session_index, t.task_index""").fetchall()
    measured, met = _measures(store), _criterion_met(store)
    trained = {p.name for p in store.protocol.phases if p.until is not None}
    table = pd.DataFrame([{
        "study": store.name, "participant": r["participant"], "group": r["group_code"], "gender": r["gender"],
        "age": r["age"], "handedness": r["handedness"], "mr_experience": bool(r["mr_experience"]),
        "phase": r["phase"], "interaction": r["interaction"],
        "interaction_label": labels.get(r["interaction"], r["interaction"]),
        "added_latency_ms": store.protocol.added_latency_ms(r["phase"]),
        "object": r["object_code"], "object_name": r["object"],
        "order_position": r["order_position"], "completed": r["status"] == "completed",
        "time_s": r["time_s"] if r["status"] == "completed" else None,
        "attempts": r["attempts"] if r["status"] in ("completed", "timeout", "aborted") else None,
        "started_at": r["started_at"] if r["status"] in FINAL_RUN else None,
        "ended_at": r["ended_at"] if r["status"] in FINAL_RUN else None,
        "status": _status(r["status"]), "runs": r["runs"], "simulated": bool(r["simulated"]),
        "withdrawn": r["participant_status"] == "withdrawn", "session": r["session"], "task_index": r["task_index"],
        "station": r["station"], "task_kind": store.protocol.kind(r["phase"]), "session_id": r["session_id"],
        "session_index": r["session_index"], "session_date": r["date"], "task_in_phase": r["task_in_phase"],
        "criterion_met": met.get((r["session_id"], r["phase"])) == r["task_in_phase"] if r["phase"] in trained
        else None, "difficulty": r["difficulty"],
        **{column.name: measured.get(r["run_id"], {}).get(column.name) for column in measure_declarations()},
    } for r in rows], columns=[column.name for column in trial_declarations()])
    return table.astype({column.name: column.dtype for column in trial_declarations()})


def measure_declarations() -> tuple[Column, ...]:
    """Every task kind's own measures (``microg.task.Kind.measures``) as columns of the trials table,
    in the registry's order (``microg.task.KINDS``)."""
    return tuple(Column(m.name, m.dtype, m.meaning, optional=True, unit=m.unit,
                        minimum=None if m.signed or m.dtype == "boolean" else 0,
                        source=f"{TASK_RULES}: the {kind.title.lower()}'s")
                 for kind in KINDS.values() for m in kind.measures)


def trial_declarations() -> tuple[Column, ...]:
    """The trials table's columns: every study's (``microg.schema.TRIALS``), then every kind's measures."""
    return TRIALS + measure_declarations()


def kind_infos() -> dict[str, KindInfo]:
    """Every task kind as the report reads it (``microg.schema.KindInfo``), from the registry."""
    return {kind.name: KindInfo(kind.name, kind.title, kind.attempts,
                                tuple(KindMeasure(m.name, f"{m.label} ({m.unit})" if m.unit else m.label,
                                                  m.proportion, m.signed) for m in kind.measures))
            for kind in KINDS.values()}


def progression_table(store: Store, trials: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per participant, session and phase of tasks: the tasks it ran, whether and at which
    task it met its criterion, its minutes and its staircase's last value (``microg.schema.PROGRESSION``)."""
    trials = trials_table(store) if trials is None else trials
    spans = {}
    for r in store.db.execute("SELECT session_id, t, kind, data FROM events WHERE kind IN ('phase_start', 'phase_end') "
                              "ORDER BY id"):
        spans.setdefault((r["session_id"], json.loads(r["data"])["phase"]), {})[r["kind"]] = r["t"]
    rows = []
    keys = ["participant", "group", "session", "session_index", "phase", "session_id"]
    for key, tasks in trials.groupby(keys, sort=False):
        span = spans.get((key[-1], key[-2]), {})
        trained = tasks["criterion_met"].notna().any()
        met = tasks.loc[tasks["criterion_met"].fillna(False).astype(bool), "task_in_phase"]
        ran = tasks[tasks["status"].isin(FINAL_RUN)]
        rows.append(dict(zip(PROGRESSION_KEYS, key[:-1])) | {
            "tasks": len(ran), "criterion_met": bool(len(met)) if trained else None,
            "tasks_to_criterion": int(met.iloc[0]) if len(met) else None,
            "minutes": (span["phase_end"] - span["phase_start"]) / 60.0 if len(span) == 2 else None,
            "final_difficulty": ran["difficulty"].iloc[-1] if len(ran) else None})
    columns = [c.name for c in PROGRESSION]
    return pd.DataFrame(rows, columns=columns).astype({c.name: c.dtype for c in PROGRESSION})


PROGRESSION_KEYS = ("participant", "group", "session", "session_index", "phase")


def _criterion_met(store: Store) -> dict[tuple[int, str], int]:
    """The task (its place in the phase) at which each session's phase met its criterion, by (session id, phase)."""
    rows = store.db.execute("SELECT session_id, data FROM events WHERE kind = 'criterion_met'")
    return {(r["session_id"], data["phase"]): data["task_in_phase"] for r in rows for data in [json.loads(r["data"])]}


def _measures(store: Store) -> dict[int, dict]:
    """Each finished run's measures of its task kind, by run id (its ``measures`` event)."""
    rows = store.db.execute("SELECT run_id, data FROM events WHERE kind = 'measures' AND run_id IS NOT NULL")
    return {r["run_id"]: json.loads(r["data"]) for r in rows}


def answers_table(store: Store) -> pd.DataFrame:
    """One row per answer to every instrument, per participant in the order given (``microg.schema.ANSWERS``)."""
    labels = interaction_labels(store)
    rows = store.db.execute("""
        SELECT p.id AS participant, p.group_code, p.status AS participant_status, s.simulated, s.station,
               a.instrument, a.administration, a.interaction, a.item, a.value, a.source, a.response_time_s, a.t
        FROM answers a JOIN sessions s ON s.id = a.session_id JOIN participants p ON p.id = s.participant_id
        ORDER BY p.number, a.rowid""").fetchall()
    table = pd.DataFrame([{
        "study": store.name, "participant": r["participant"], "group": r["group_code"], "instrument": r["instrument"],
        "administration": r["administration"], "interaction": r["interaction"],
        "interaction_label": labels.get(r["interaction"], r["interaction"]), "item": r["item"],
        "value": str(r["value"]), "source": r["source"], "response_time_s": r["response_time_s"], "t": r["t"],
        "simulated": bool(r["simulated"]) or r["source"] == "model",
        "withdrawn": r["participant_status"] == "withdrawn", "station": r["station"],
    } for r in rows], columns=ANSWER_COLUMNS)
    return table.astype(ANSWER_DTYPES)


def questionnaire_table(store: Store) -> pd.DataFrame:
    """One row per answer to the paper's kind of 0-10 items about an interaction model (the Likert
    analysis's table; ``microg.instruments.Instrument.likert``)."""
    labels = interaction_labels(store)
    likert = [name for name, instrument in store.protocol.instruments.items() if instrument.likert]
    rows = store.db.execute(f"""
        SELECT p.id AS participant, p.group_code, p.status AS participant_status, s.simulated, s.station,
               a.interaction, a.item, a.value, a.source
        FROM answers a JOIN sessions s ON s.id = a.session_id JOIN participants p ON p.id = s.participant_id
        WHERE a.instrument IN ({",".join("?" * len(likert))}) AND a.interaction != ''
        ORDER BY p.number, a.interaction, a.item""", likert).fetchall()
    table = pd.DataFrame([{
        "study": store.name, "participant": r["participant"], "group": r["group_code"], "interaction": r["interaction"],
        "interaction_label": labels.get(r["interaction"], r["interaction"]), "item": r["item"], "rating": r["value"],
        "source": r["source"],
        "simulated": bool(r["simulated"]) or r["source"] == "model",
        "withdrawn": r["participant_status"] == "withdrawn", "station": r["station"],
    } for r in rows], columns=QUESTIONNAIRE_COLUMNS)
    return table.astype(QUESTIONNAIRE_DTYPES)


def scores_table(store: Store, answers: pd.DataFrame | None = None) -> pd.DataFrame:
    """Every answer (``answers``: the study's, when already read) scored by its instrument's key
    (``microg.analysis.scoring.score_answers``)."""
    from microg.analysis.scoring import score_answers  # the statistics' imports take seconds: only when scoring

    answers = answers_table(store) if answers is None else answers
    return score_answers(answers, store.protocol.instruments, source=str(store.dir))


def run_frames(store: Store, run_id: int) -> pd.DataFrame:
    """Every logged frame of one task run as a flat table (``framelog.frame_table``)."""
    return framelog.frame_table(framelog.read(store.db, run_id))


def run_hand_frames(store: Store, run_id: int) -> list[HandFrame]:
    """The hand frames of a task run as hand tracking admitted them, before the window filter
    (``framelog.hand_frames``): filtered again, they step the physics as the run did."""
    return framelog.hand_frames(framelog.read(store.db, run_id))


def run_list(store: Store) -> list[dict]:
    """Every task run with frames, with what names it: participant, phase, object, run number."""
    rows = store.db.execute("""
        SELECT r.id AS run_id, r.run, r.status, r.source, s.participant_id AS participant, s.name AS session,
               s.id AS session_id,
               s.simulated, s.input, t.task_index, t.phase, t.interaction, t.object
        FROM task_runs r JOIN tasks t ON t.session_id = r.session_id AND t.task_index = r.task_index
        JOIN sessions s ON s.id = r.session_id
        WHERE EXISTS (SELECT 1 FROM frames f WHERE f.run_id = r.id) ORDER BY r.id""").fetchall()
    return [dict(r) for r in rows]


FRAME_KEYS = (
    Column("study", "string", "the study's name", source=STUDY),
    Column("participant", "string", "participant id, e.g. P01", source=ENROLMENT),
    Column("session", "string", "the session (as in trials)", levels="sessions", source=PROTOCOL),
    Column("session_id", "int64", "id of the session in the study's log (as in trials)", minimum=1,
           source=SESSION_LOG),
    Column("run_id", "int64", "id of the task run in the study's log", minimum=1, source=SESSION_LOG),
    Column("task_index", "int64", "index of the task within its session, from 0 (as in trials)", minimum=0,
           source=SESSION_LOG),
    Column("run", "int64", "the run's number among its task's runs, from 1 (a task cut off midway runs again)",
           minimum=1, source=SESSION_LOG),
    Column("run_status", "string", "how the run ended (running: not ended when exported; interrupted: cut off)",
           values=RUN_STATUSES, source=SESSION_LOG),
    Column("phase", "string", "the protocol phase the task belongs to", levels="phases", source=PROTOCOL),
    Column("interaction", "string", "code of the interaction model the run used", levels="interactions",
           source=PROTOCOL),
    Column("object", "string", "the object's name, e.g. cube (the trials table's object_name)",
           levels="object_names", source=PROTOCOL),
)
"""The frames table's first columns: which task run a frame belongs to."""
def table_declarations() -> dict[str, tuple[Column, ...]]:
    """Every table an export may write, by name, with its columns: the codebook describes those written."""
    return {"trials": trial_declarations(), "progression": PROGRESSION, "questionnaire": QUESTIONNAIRE, "answers": ANSWERS, "scores": SCORES,
            "frames": FRAME_KEYS + framelog.FRAME_COLUMNS}


def frames_columns(store: Store, runs: list[dict] | None = None) -> Iterator[dict[str, pa.Array | np.ndarray]]:
    """The frames table's columns, one task run at a time (a study's frames may not fit in memory
    at once): the run's keys, then ``framelog.frame_columns``."""
    for run in run_list(store) if runs is None else runs:
        columns = framelog.frame_columns(framelog.read(store.db, run["run_id"]))
        keys = {"study": store.name, "participant": run["participant"], "session": run["session"],
                "session_id": run["session_id"],
                "run_id": run["run_id"], "task_index": run["task_index"], "run": run["run"],
                "run_status": run["status"], "phase": run["phase"], "interaction": run["interaction"],
                "object": run["object"]}
        yield {**{k: pa.repeat(v, len(columns["t"])) for k, v in keys.items()}, **columns}


def read_answers(study_dir: str | Path) -> tuple[pd.DataFrame | None, dict[str, Instrument]]:
    """(answers, instruments) of a study folder or of an export folder (its ``answers`` table and
    ``instruments/``); answers None for an export written before there were instruments."""
    study_dir = Path(study_dir)
    if (study_dir / DATABASE).exists():
        with open_study(study_dir, readonly=True) as store:
            return answers_table(store), dict(store.protocol.instruments)
    instruments = {path.stem: load_instrument(path) for path in sorted((study_dir / "instruments").glob("*.toml"))}
    for name in ("answers.parquet", "answers.csv"):
        if (study_dir / name).exists():
            from microg.analysis.tables import read_table

            return read_table(study_dir / name), instruments
    return None, instruments


def read_tables(study_dir: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(trials, questionnaire) of a study folder (with ``study.db``) or of an export folder."""
    study_dir = Path(study_dir)
    if (study_dir / DATABASE).exists():
        with open_study(study_dir, readonly=True) as store:
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


PARTIAL = ".partial"
"""An export is written into ``<out>.partial`` and renamed to ``<out>`` when complete."""
MANIFEST = "export.json"


def refuse_links(*paths: Path) -> None:
    """Refuse to write through a symbolic link (dangling or not): the files would land wherever it
    points, and replacing it would replace what it points to."""
    for path in paths:
        if path.is_symlink():
            raise FileExistsError(f"{path} is a symbolic link (to {os.readlink(path)}); microg writes an export into "
                                  "a real folder, never through a link: give the folder itself, or another")


def check_output(out_dir: Path, overwrite: bool) -> None:
    """Refuse an export folder that the export would write through, replace by mistake or cannot
    write: a symbolic link (``refuse_links``), an existing folder without ``overwrite``, one that is
    not an earlier export (no ``export.json``; ``overwrite`` replaces exports only, never a folder
    of other files, nor the study), a read-only place."""
    refuse_links(out_dir, out_dir.with_name(out_dir.name + PARTIAL))
    if out_dir.exists():
        if not overwrite:
            raise FileExistsError(f"{out_dir} exists; export into another folder or pass --overwrite")
        if not out_dir.is_dir() or (any(out_dir.iterdir()) and not (out_dir / MANIFEST).is_file()):
            raise FileExistsError(f"{out_dir} exists and is not an export (it has no {MANIFEST}); --overwrite "
                                  "replaces an earlier export only: export into another folder")
    parent = nearest_folder(out_dir)
    if not writable(parent):
        raise StoreError(f"{out_dir}: cannot write into {parent}: the folder is read-only (an archived study "
                         "is exported elsewhere: give --out a writable folder)")


def export_study(study_dir: str | Path, out_dir: str | Path, *, formats: tuple[str, ...] = ("csv", "parquet"),
                 frames: bool = True, frames_csv: bool = False, bids: bool = True, overwrite: bool = False,
                 accept_damaged: bool = False, progress: bool = True, say=print) -> list[Path]:
    """Write the trials, questionnaire, answers and scores tables (``formats``) with the study's
    instrument files (``instruments/``), the frames (Parquet; also CSV with ``frames_csv``),
    Motion-BIDS, and the codebook of the tables written (``codebook.csv``, ``dataset_description.json``)
    into the folder ``out_dir``; returns the files written. Items a scale needs that were
    not answered are reported through ``say`` (their scales are left unscored).

    The export is atomic: it is written into ``<out_dir>.partial`` and renamed at the end, so a
    folder named ``out_dir`` always holds a complete export. An existing ``out_dir`` is replaced
    only with ``overwrite`` and only if it is an earlier export (``check_output``: never through a
    symbolic link); a ``.partial`` folder left by an earlier export that was cut off is reported
    through ``say`` and replaced. A study that fails its integrity check is exported only with
    ``accept_damaged``, and its ``export.json`` lists the problems. Every frame batch is verified
    against its checksum as it is read: a damaged one stops the export, or with ``accept_damaged``
    (every batch verified first) its run is left out of the frames and Motion-BIDS and listed. A
    write that fails (a full disk) removes the partial folder and leaves ``out_dir`` as it was.
    ``export.json`` also records the ledger's head, for checking the study against it later.
    """
    out_dir = Path(out_dir)
    unknown = set(formats) - {"csv", "parquet"}
    if unknown or not formats:
        raise ValueError(f"formats = {list(formats)}: choose from csv, parquet")
    check_output(out_dir, overwrite)
    partial = out_dir.with_name(out_dir.name + PARTIAL)
    with open_study(study_dir, readonly=True, accept_damaged=accept_damaged) as store:
        if store.damaged_batches and (frames or bids) and not accept_damaged:
            raise StoreError(_refusal(store, store.damaged_batches[0], out_dir))
        damage = list(framelog.damaged(store.db)) if accept_damaged and (frames or bids) else []
        for problem in store.problems:
            if problem not in [p for _, p in damage]:
                say(f"warning: exporting a damaged study: {problem}")
        for _, problem in damage:
            say(f"warning: left out of the frames and Motion-BIDS: {problem}")
        if partial.exists():
            say(f"note: {partial} holds an earlier export that was cut off before it finished; it is replaced now")
            shutil.rmtree(partial)
        try:
            written = _write_export(store, partial, formats=formats, frames=frames, frames_csv=frames_csv, bids=bids,
                                    progress=progress, damage=damage, say=say)
        except OSError as error:
            shutil.rmtree(partial, ignore_errors=True)
            full = error.errno == errno.ENOSPC
            raise StoreError(f"{partial}: {'the disk is full' if full else 'cannot write the export'} "
                             f"({error.strerror or error}); the export stopped and was removed, {out_dir} is as it "
                             f"was. {'Free space on that disk' if full else 'Fix that'}, then export again") from None
        except framelog.DamagedFramesError as error:
            shutil.rmtree(partial, ignore_errors=True)
            raise StoreError(_refusal(store, error, out_dir)) from None
    if out_dir.exists():
        shutil.rmtree(out_dir)
    partial.rename(out_dir)
    return [out_dir / p for p in written]


def _refusal(store: Store, damage, out_dir: Path) -> str:
    """Why an export of frames stopped at a damaged batch, and what to do."""
    return (f"{store.dir}: {damage}. Nothing was exported ({out_dir} is as it was). See every damaged batch with: "
            f"microg study check {store.dir}; microg export --accept-damaged exports the study without the damaged "
            f"runs' frames, listed in {MANIFEST}")


def _write_export(store: Store, folder: Path, *, formats: tuple[str, ...], frames: bool, frames_csv: bool, bids: bool,
                  progress: bool, damage: list[tuple[int, str]], say) -> list[Path]:
    """Every file of an export into the new ``folder``, ``export.json`` last; their paths in it.
    The runs with a damaged frame batch (``damage``: run id, what is wrong) have no frames in it;
    items a scale needs that were not answered are reported through ``say``."""
    from tqdm import tqdm

    from microg.analysis.scoring import missing_items

    from .bids import write_motion_bids

    head = ledger.head_of(store.db)
    left_out = {run_id for run_id, _ in damage}
    folder.mkdir(parents=True)
    answers, trials = answers_table(store), trials_table(store)
    tables = (("trials", trials), ("progression", progression_table(store, trials)),
              ("questionnaire", questionnaire_table(store)), ("answers", answers), ("scores", scores_table(store, answers)))
    for name, table in tables:
        for fmt in formats:
            if fmt == "csv":
                table.to_csv(folder / f"{name}.csv", index=False)
            else:
                table.to_parquet(folder / f"{name}.parquet", index=False)
    (folder / "instruments").mkdir()
    for name, instrument in store.protocol.instruments.items():
        (folder / "instruments" / f"{name}.toml").write_text(instrument.text, encoding="utf-8")
    for row in missing_items(answers, store.protocol.instruments).itertuples(index=False):
        say(f"note: participant {row.participant}, {row.instrument} ({row.administration}"
            f"{', ' + row.interaction if row.interaction else ''}): item {row.item} was not answered; {row.scales} "
            "not scored")
    runs = [run for run in run_list(store) if run["run_id"] not in left_out]
    if frames and runs:
        _write_frames(store, runs, folder=folder, csv=frames_csv, bar=tqdm(total=len(runs), unit="run", desc="frames",
                                                            disable=not progress))
    if bids:
        write_motion_bids(store, folder / "bids", tqdm(total=len(runs), unit="run", desc="Motion-BIDS",
                                                      disable=not progress), runs)
    written_tables = [name for name, _ in tables] + (["frames"] if frames and runs else [])
    declared = table_declarations()
    write_codebook(folder, {name: declared[name] for name in written_tables}, study=store.name, protocol=store.protocol,
                   interactions=[r[0] for r in store.db.execute("SELECT DISTINCT interaction FROM tasks")])
    written = sorted(p.relative_to(folder) for p in folder.rglob("*") if p.is_file())
    head = ledger.head_of(store.db)
    (folder / MANIFEST).write_text(json.dumps({"study": str(store.dir.resolve()),
                                               "files": [str(p) for p in written],
                                               "damaged": list(dict.fromkeys(store.problems + [problem for _, problem in damage])),
                                               "frames_left_out": sorted(left_out),
                                               "ledger_head": None if head is None else str(head)}, indent=2))
    return written + [Path(MANIFEST)]


def _write_frames(store: Store, runs: list[dict], *, folder: Path, csv: bool, bar) -> None:
    """frames.parquet (and frames.csv), one task run at a time: a study's frames may not fit in
    memory. A run is written in a second thread (Arrow works without the GIL) while the next is read.
    Floats are stored byte-stream split and only names dictionary-encoded: half the time of Parquet's
    defaults, and a third smaller."""
    writer = None

    def write(table: pa.Table, first: bool) -> None:
        nonlocal writer
        writer = writer or pq.ParquetWriter(
            folder / "frames.parquet", table.schema, compression="zstd",
            use_dictionary=[f.name for f in table.schema if pa.types.is_string(f.type)],
            use_byte_stream_split=[f.name for f in table.schema if pa.types.is_floating(f.type)])
        writer.write_table(table)
        if csv:
            with open(folder / "frames.csv", "wb" if first else "ab") as out:
                pa_csv.write_csv(table, out, pa_csv.WriteOptions(include_header=first))
        bar.update()

    try:
        with ThreadPoolExecutor(max_workers=1) as background:
            writing = None
            for i, columns in enumerate(frames_columns(store, runs)):
                table = pa.table(columns)
                if writing is not None:
                    writing.result()
                writing = background.submit(write, table, i == 0)
            if writing is not None:
                writing.result()
    finally:
        bar.close()
        if writer is not None:
            writer.close()
