"""The main job end to end: a whole simulated study, from protocol to report.

``run_demo`` creates a study from a protocol (the paper's by default), enrols simulated
participants with the paper's demographics, runs every session (each session of a training program in turn, on the simulated calendar)
through the real session runner
and physics with simulated hands (``--input simulated``: the protocol's ``practice`` profile, so
the veterans differ from the beginners only by the practice their training gave), answers the
questionnaires with the rating model (``microg.participant.ratings``; marked simulated), exports the
tables (trials, questionnaire, answers and scores; the frames stay in the store, ``microg export``
writes them and Motion-BIDS) and writes the statistics report. Sessions run in parallel worker processes, each writing
its own session to the study's SQLite store; every session is seeded from the study's seed, so the
same seed gives the same tables whatever the number of workers.
"""

from __future__ import annotations

import datetime
import os
import shutil
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing.util import Finalize
from pathlib import Path

from tqdm import tqdm

from microg.paths import protocol_file

from .assignment import paper_sample
from .export import export_study, kind_infos, read_answers, read_tables
from .inputs import InputError, open_inputs
from .protocol import Protocol, ProtocolError, load_protocol
from .simulated_rater import SimulatedRater
from .session import SimulationClock, run_session
from .schedule import next_session, trainee_outlook
from .store import FINAL_RUN, Store, StoreError, create_study, open_study, plan_tasks


@dataclass(frozen=True)
class DemoStudy:
    study: Path
    report: Path
    tables: Path
    participants: int
    tasks: int
    seconds: float
    trainee: Path | None = None
    """A training program's first trainee's page (``microg report --participant``), beside the report."""


def _inputs(store, participant_id: str, spec: str = "simulated"):
    """The simulated participant's inputs: the group's profile, unless ``spec`` names another."""
    return open_inputs(spec, store.protocol.group(store.participant(participant_id).group))


_worker_store: Store | None = None
"""The study as a worker process opened it, once: the integrity check on opening reads the whole
log, which grows with every session."""


def _open_in_worker(study_dir: str) -> None:
    global _worker_store
    _worker_store = open_study(study_dir)
    Finalize(_worker_store, _worker_store.close, exitpriority=1)  # closed when the worker ends


def _run_sessions(session_id: int) -> str:
    """One simulated participant's session and, in a training program, each of their sessions after it
    in turn, on the simulated calendar (in a worker process); the last one's status."""
    store = _worker_store
    session = store.session(session_id)
    group = store.participant(session.participant_id).group
    while True:
        store.lock_session(session.id)
        try:
            status = run_session(store, session.id, _inputs(store, session.participant_id, session.input),
                                 clock=SimulationClock(), rater=SimulatedRater(store, session.id, session.seed))
        finally:
            store.unlock_session(session.id)
        sittings = [s.sitting for s in store.sessions_of(session.participant_id)]
        if next_session(store.protocol, group, sittings) is None:
            return status
        session = store.create_session(session.participant_id, input_spec=session.input, simulated=True,
                                       clock=session.clock)


def _most_tasks(store: Store, participant_id: str) -> int:
    """The most tasks a participant's sessions run (each phase trained to a criterion counted at its bound)."""
    record = store.participant(participant_id)
    fixed = sum(len(plan_tasks(store.protocol, record.group, record.object_order, plan.name))
                for plan in store.protocol.sessions_for(record.group))
    bounds = sum(store.protocol.phase(name).max_tasks for plan in store.protocol.sessions_for(record.group)
                 for name in plan.phases if store.protocol.phase(name) and store.protocol.phase(name).until)
    return fixed + bounds


def _tasks_finished(store: Store) -> int:
    return store.db.execute("SELECT COUNT(*) FROM task_runs WHERE status IN (%s)" % ",".join("?" * len(FINAL_RUN)),
                            FINAL_RUN).fetchone()[0]


def run_demo(out: str | Path, participants: int = 30, seed: int = 1, protocol: str | Path = "paper", *,
             profile: str | Path | None = None, jobs: int | None = None, overwrite: bool = False,
             progress: bool = True) -> DemoStudy:
    """Run a whole simulated study into ``out`` (see the module docstring) and return where things are.
    ``profile``: a population file every group's simulated participants are drawn from (default:
    each group's ``simulated_profile``)."""
    started = time.monotonic()
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        if not overwrite:
            raise StoreError(f"{out} exists and is not empty; choose another --out or allow --overwrite")
        shutil.rmtree(out)
    rules: Protocol = load_protocol(protocol_file(protocol))
    profiled = None  # every participant's inputs, when --profile names them: checked before anything is written
    if profile is not None:
        try:
            profiled = open_inputs(f"simulated:{Path(profile).resolve()}")
        except InputError as error:
            raise InputError(f"--profile {profile}: {str(error).split(': ', 1)[-1]}") from None
    problems = rules.simulation_problems()
    if problems:
        raise ProtocolError("a simulated study cannot run this protocol:\n  " + "\n  ".join(problems))
    if not 1 <= participants <= rules.total_participants:
        raise StoreError(f"--participants {participants}: the protocol {rules.name!r} has room for "
                         f"1 to {rules.total_participants}")
    study_dir = out / "study"
    with create_study(study_dir, rules, seed) as store:
        for person in paper_sample(seed)[:participants]:
            store.add_participant(person)
        ids = [p.id for p in store.participants()]
        sessions = []
        for participant_id in ids:
            inputs = profiled or _inputs(store, participant_id)
            sessions.append(store.create_session(participant_id, input_spec=inputs.spec, simulated=inputs.simulated,
                                                 clock=inputs.clock).id)
        planned = {session_id: _most_tasks(store, store.session(session_id).participant_id) for session_id in sessions}
        total_tasks = sum(planned.values())
        # Longest first: the last session to start is a short one, so the workers finish close together.
        sessions.sort(key=lambda session_id: -planned[session_id])

    jobs = max(1, min(jobs or os.cpu_count() or 1, participants))
    bar = tqdm(total=total_tasks, unit="task", desc=f"{participants} simulated participants", disable=not progress,
               bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} tasks [{elapsed}<{remaining}, {rate_fmt}] {postfix}")
    with ProcessPoolExecutor(max_workers=jobs, initializer=_open_in_worker, initargs=(str(study_dir),)) as pool:
        pending = {pool.submit(_run_sessions, session_id) for session_id in sessions}
        from microg.analysis import write_report  # a few seconds, while the workers run the sessions
        with open_study(study_dir, readonly=True) as watcher:  # opened after the workers start
            done_participants = 0
            while pending:
                finished, pending = wait(pending, timeout=1.0, return_when=FIRST_COMPLETED)
                for future in finished:
                    future.result()
                    done_participants += 1
                bar.n = _tasks_finished(watcher)
                bar.set_postfix_str(f"participants {done_participants}/{participants}")
                bar.refresh()
    bar.total = bar.n  # a phase trained to a criterion may end before its bound
    bar.close()

    tables = out / "tables"
    export_study(study_dir, tables, frames=False, bids=False, progress=False)
    answers, instruments = read_answers(tables)
    report = write_report(tables / "trials.csv", tables / "questionnaire.csv", out / "report",
                          title=f"Simulated study: {participants} participants, protocol {rules.name}, seed {seed}",
                          answers=answers, instruments=instruments, kinds=kind_infos())
    with open_study(study_dir, readonly=True) as done:
        ran, trainee = _tasks_finished(done), None
        if rules.program:  # the cohort's report, and the first trainee's own page beside it
            from microg.analysis.trainee import write_trainee_page

            next_session, criterion_s = trainee_outlook(done, ids[0], datetime.date.today())
            trainee = write_trainee_page(read_tables(tables)[0], ids[0], out / "report",
                                         next_session=next_session, criterion_s=criterion_s)
    return DemoStudy(study_dir, report, tables, participants, ran, time.monotonic() - started, trainee)
