"""Whole simulated studies, kept as their trials table (``simulate_trials``).

A simulated study is a real study in a temporary folder: its participants enrolled, assigned to
groups and object orders, each given a session with its seed, by the study engine itself. Its
tasks are then played by ``engine.play_tasks`` (batched, in compiled code, no frames logged) and
each task's run is written to the study as a session would write it: the run's start and end on
the session's clock (rebuilt from the frames' times, as a session advances it), its status,
completion time and attempts. The trials table is read back by the export's own function, so it
is the table a logged session of the same seeds gives.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from microg.participant import Population
from microg.study.protocol import Protocol, protocol_from_resolved
from microg.task.rules import timeout_reason

from .engine import TaskUnit, play_tasks


def sized_protocol(protocol: Protocol, n_per_group: int) -> Protocol:
    """The protocol with every group of ``n_per_group`` participants."""
    resolved = dict(protocol.resolved)
    resolved["groups"] = [dict(group, size=n_per_group) for group in resolved["groups"]]
    resolved["participants"] = dict(resolved["participants"], total=n_per_group * len(resolved["groups"]))
    return protocol_from_resolved(resolved, f"{protocol.where} (resized to {n_per_group} per group)")


def protocol_through(protocol: Protocol, statistics) -> Protocol:
    """The protocol cut after the last of its ``[[phases]]`` (in the timeline's order) whose tasks one
    of ``statistics`` (``summaries.Statistic``) can select: a simulated participant does not know what comes later,
    so the phases before are played exactly as in the whole protocol, and a study that is only
    asked about the paper's model need not play the baseline's phase. Questionnaires are dropped
    (an in-silico study asks none)."""
    selections = [s.where for s in statistics] + [s.versus for s in statistics if s.versus]
    needed = {phase.name for phase in protocol.phases
              if any(all((column != "phase" or value == phase.name)
                         and (column != "interaction" or value == phase.interaction) for column, value in where)
                     for where in selections)}
    played = [entry.name for entry in protocol.timeline if any(p.name == entry.name for p in protocol.phases)]
    last = max((i for i, name in enumerate(played) if name in needed), default=0)  # in the order sessions play them
    dropped = set(played[last + 1:])
    if not dropped:
        return protocol
    resolved = dict(protocol.resolved)
    resolved["phases"] = [phase for phase in resolved["phases"] if phase["name"] not in dropped]
    resolved["timeline"] = [entry for entry in resolved["timeline"]
                            if entry.get("phase") not in dropped and "instruments" not in entry]
    return protocol_from_resolved(resolved, f"{protocol.where} (through phase {played[last]})")


def simulate_trials(protocol: Protocol, n_per_group: int, seed: int, *, population: Population | None = None,
                    workers: int = 1) -> pd.DataFrame:
    """The trials table of one whole simulated study with ``n_per_group`` participants per group;
    every group's participants are drawn from ``population`` when given, else from each group's
    ``simulated_profile``. The same seed gives the same table, with any number of ``workers``
    (processes sharing the tasks out, ``engine.play_tasks``)."""
    from microg.study import Participant, create_study, open_inputs, trials_table
    from microg.study.inputs import SimulatedInputs

    sized = sized_protocol(protocol, n_per_group)
    rng = np.random.default_rng(seed)
    youngest, oldest = sized.age_range or (18, 60)
    players = {group.code: (open_inputs("simulated", group) if population is None
                            else SimulatedInputs(f"simulated:{population.where}", population)) for group in sized.groups}
    with tempfile.TemporaryDirectory(prefix="microg-insilico-") as folder, \
            create_study(Path(folder) / "study", sized, seed) as store:
        store.commit_for(True)
        for number in range(sized.total_participants):
            store.add_participant(Participant(f"S{number + 1:03d}", ("female", "male")[number % 2],
                                              int(rng.integers(youngest, oldest + 1)), "right", True))
        for record in store.participants():
            inputs = players[record.group]
            store.create_session(record.participant.id, input_spec=inputs.spec, simulated=inputs.simulated,
                                 clock=inputs.clock)
        play_sessions(store, lambda session: players[store.participant(session.participant_id).group], workers=workers)
        return trials_table(store)


def play_sessions(store, inputs_of, workers: int = 1) -> None:
    """Play every running session of ``store`` (simulated participants, ``inputs_of(session)``
    their ``SimulatedInputs``) with ``engine.play_tasks`` and write each task's run as the session
    runner would, in the order it would run them; then end the sessions."""
    from microg.study.session import SimulationClock, planned_runs
    from microg.study.store import Event

    protocol = store.protocol
    trained = [p.name for p in protocol.phases if p.until is not None]
    if trained:
        raise ValueError(f"protocol {protocol.name!r}: phase(s) {', '.join(trained)} train to a criterion, which an "
                         "in-silico study does not play yet; run its simulated participants as logged sessions "
                         "(microg session run --input simulated, or microg demo)")
    sessions, units = [], []
    for record in store.participants():
        session = store.session_of(record.participant.id)
        if session is None or session.status != "running":
            continue
        inputs, tasks = inputs_of(session), store.tasks(session.id)
        played = []
        for task, plan, seed in [run for phase in protocol.phases_for(record.group, session.name)
                                 if protocol.runs_tasks(phase)
                                 for run in planned_runs(protocol, session, participant=record, tasks=tasks,
                                                         phase=phase)]:
            skill = inputs.skill(plan)
            units.append(TaskUnit(plan, skill, seed, inputs.time_limit_s(plan), task.interaction, task.object))
            played.append((task, seed, f"simulated:{skill.name}:seed={seed}"))
        sessions.append((session, played))
    results = iter(play_tasks(protocol, units, workers=workers))
    for session, played in sessions:
        clock = SimulationClock()
        for task, seed, source in played:
            result = next(results)
            run_id = store.begin_run(session.id, task=task, source=source, seed=seed, t=clock.now())
            times = result.frame_times
            clock.elapse_each(np.diff(times))
            reason = {"completed": None, "timeout": timeout_reason(protocol.rules(task.phase)),
                      "aborted": f"the hand source ({source}) ended before the task did"}[result.status]
            measured = [Event(clock.now(), "measures", {"kind": task_kind, **result.measures})
                        for task_kind in [protocol.kind(task.phase)] if result.measures]
            store.end_run(run_id, result.status, clock.now(), time_s=result.time_s, attempts=result.attempts,
                          reason=reason, events=measured + [Event(clock.now(), "in_silico", {"frames": len(times)})])
        store.finish_session(session.id, clock.now())
