"""Counterfactual replay: a logged session's real hand motion through the physics again, under another
interaction model or other scene parameters.

    microg session resimulate STUDY --participant P03 --interaction soft_hand [--set substeps=8]

Each task of the session replays the hand frames its last run logged (exactly as the physics
received them, ``framelog.hand_frames``) through the same tracking guard, window filter and task
rules, in a world where every task runs ``interaction`` (and whose scene takes the given settings).
The runs go into a study of their own, ``STUDY/resimulated/<label>/``: the original protocol with
the change (its name and title say so, and its stored SHA-256 differs), the same participants with
the same group and object order, sessions whose input is ``resimulated:<original session>``. The
original study is only read, so the two can never mix; ``microg report STUDY --compare
STUDY/resimulated/<label>`` puts them side by side.

What this answers: for a real person's motion, how much the interaction model alone changes the
outcome. What it cannot answer: a person adapts to the model they feel (they squeeze harder when an
object slips, slow down when it bounces); a replay keeps the motion made for the original model,
so it shows the model's effect on that motion, not what the person would have done with it. With
the same model and settings the replay reproduces the original runs exactly (the physics is
deterministic). A training program's sessions are replayed in order, each phase trained to a
criterion as its tasks ran: a replay cannot add the tasks a trainee would have needed, nor leave out
those they did.
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

from microg import __version__
from microg.hands import ReplaySource
from microg.sim import INTERACTION_MODELS

from . import framelog
from .assignment import Participant
from .protocol import SCENE_OPTIONS, ProtocolError, protocol_from_resolved
from .session import EventLog, SimulationClock, criterion_end, run_task, task_world
from .store import Event, Store, StoreError, create_study, derived_seed, open_study

FOLDER = "resimulated"
INPUT = "resimulated"


def resimulated_protocol(original: dict, settings: dict, label: str) -> dict:
    """The original protocol (``Protocol.resolved``) with the scene taking ``settings``, named for
    the re-simulation (its sessions' tasks take the interaction model: ``Store.create_session``)."""
    unknown = sorted(set(settings) - set(SCENE_OPTIONS))
    if unknown:
        raise ProtocolError(f"--set {unknown[0]}: not a scene setting (known: {', '.join(SCENE_OPTIONS)})")
    resolved = copy.deepcopy(original)
    resolved.setdefault("scene", {}).update(settings)
    resolved["name"] = f"{resolved['name']}-{label}"
    resolved["title"] = f"{resolved.get('title') or original['name']} (re-simulated: {label})"
    return resolved


def resimulate(study_dir: str | Path, participants: list[str], *, interaction: str | None = None,
               settings: dict | None = None, label: str | None = None, progress: bool = True) -> Path:
    """Re-simulate the sessions of ``participants`` (module docstring); returns the new study's folder."""
    from tqdm import tqdm

    if interaction is not None and interaction not in INTERACTION_MODELS:
        raise ProtocolError(f"--interaction {interaction!r}: must be one of {sorted(INTERACTION_MODELS)}")
    settings = dict(settings or {})
    label = label or "-".join([interaction or "same"] + [f"{k}{v}" for k, v in sorted(settings.items())])
    if not label.replace("-", "").replace("_", "").replace(".", "").isalnum():
        raise StoreError(f"--label {label!r}: letters, digits, '-', '_' and '.' only (it names a folder)")
    study_dir = Path(study_dir)
    target = study_dir / FOLDER / label
    with open_study(study_dir, readonly=True) as original:
        if original.damaged_batches:
            raise StoreError(f"{study_dir}: the study is damaged:\n" + "\n".join(
                f"  - {p}" for p in original.damaged_batches) + f"\nNothing was re-simulated. See: microg study check "
                f"{study_dir}")
        protocol = protocol_from_resolved(
            resimulated_protocol(original.protocol.resolved, settings, label), f"{target}")
        store = open_study(target) if (target / "study.db").exists() else create_study(target, protocol, original.seed)
        with store:
            if store.protocol.sha256 != protocol.sha256:
                raise StoreError(f"{target} holds a re-simulation with other settings; give another --label")
            for participant_id in participants:
                _resimulate_session(original, store, participant_id, interaction=interaction, progress=progress,
                                    tqdm=tqdm)
    return target


def _resimulate_session(original: Store, store: Store, participant_id: str, *, interaction: str | None,
                        progress: bool, tqdm) -> None:
    """Every session of the participant, in order: each task replayed as it ran (a phase trained to
    a criterion its tasks as the original ran them, each at its difficulty), the criterion's end
    logged as the replayed runs reached it."""
    record = original.participant(participant_id)
    sessions = original.sessions_of(participant_id)
    if not sessions:
        raise StoreError(f"participant {participant_id} has no session in {original.dir} to re-simulate")
    if store.session_of(participant_id) is not None:
        raise StoreError(f"{store.dir} already holds {participant_id}'s re-simulated session; a session is "
                         "never run twice (give another --label)")
    person = record.participant
    store.add_participant(Participant(person.id, person.gender, person.age, person.handedness,
                                      person.mr_experience), like=record)
    for session in sessions:
        _replay(original, store, participant_id, session, interaction=interaction, progress=progress, tqdm=tqdm)


def _replay(original: Store, store: Store, participant_id: str, session, *, interaction: str | None,
            progress: bool, tqdm) -> None:
    spec = f"{INPUT}:{original.dir.resolve()}#session={session.id}"
    new = store.create_session(participant_id, input_spec=spec, simulated=session.simulated, clock="simulation",
                               interaction=interaction, session=session.name, ignore_schedule=session.ignored_schedule,
                               today=session.date)
    planned = {t.index for t in store.tasks(new.id)}
    for task in original.tasks(session.id):  # a phase trained to a criterion: the tasks it ran
        if task.index not in planned:
            store.add_task(new.id, dataclasses.replace(task, interaction=interaction or task.interaction))
    store.lock_session(new.id)
    clock = SimulationClock()
    store.log(new.id, [Event(0.0, "session_start", {"input": spec, "microg_version": __version__,
                                                   "resimulated_from": session.id})])
    runs = {r.task_index: r for r in original.runs(session.id) if framelog.count(original.db, r.id)}
    tasks = store.tasks(new.id)
    protocol = store.protocol
    for task in tqdm(tasks, unit="task", desc=f"{participant_id} re-simulated", disable=not progress):
        if task.index not in runs:
            run_id = store.begin_run(new.id, task=task, source="nothing logged to replay",
                                     seed=derived_seed(new.seed, task.index), t=clock.now())
            store.end_run(run_id, "skipped", clock.now(), reason="the original run logged no frames")
            continue
        frames = framelog.hand_frames(framelog.read(original.db, runs[task.index].id))
        source = ReplaySource(frames, f"{INPUT}:run {runs[task.index].id}")
        run_id = store.begin_run(new.id, task=task, source=source.description, seed=derived_seed(new.seed, task.index),
                                 t=clock.now())
        rules = protocol.rules(task.phase, task.difficulty)
        run_task(log=EventLog(store, new.id, clock), run_id=run_id, world=task_world(protocol, task, rules),
                 source=source, protocol=protocol, rules=rules)
    for phase in dict.fromkeys(t.phase for t in tasks):
        if protocol.phase(phase) is not None and protocol.phase(phase).until is not None:
            ended = criterion_end(store, new.id, phase)
            if ended is not None:
                store.log(new.id, [Event(clock.now(), *ended)])
    store.finish_session(new.id, clock.now())
