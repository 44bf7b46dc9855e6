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

from .engine import Stream, TaskUnit, advance, play_streams, play_tasks


def sized_protocol(protocol: Protocol, n_per_group: int) -> Protocol:
    """The protocol with every group of ``n_per_group`` participants."""
    resolved = dict(protocol.resolved)
    resolved["groups"] = [dict(group, size=n_per_group) for group in resolved["groups"]]
    resolved["participants"] = dict(resolved["participants"], total=n_per_group * len(resolved["groups"]))
    return protocol_from_resolved(resolved, f"{protocol.where} (resized to {n_per_group} per group)")


def protocol_through(protocol: Protocol, statistics) -> Protocol:
    """The protocol cut after the last of its ``[[phases]]`` (in the timeline's order) whose tasks one
    of ``statistics`` (``summaries.Statistic``) can select (a training program is played whole): a simulated
    participant does not know what comes later,
    so the phases before are played exactly as in the whole protocol, and a study that is only
    asked about the paper's model need not play the baseline's phase. Questionnaires are dropped
    (an in-silico study asks none)."""
    if protocol.program:  # a trainee's later sessions follow from the earlier ones: all are played
        return protocol
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
        inputs_of = lambda session: players[store.participant(session.participant_id).group]  # noqa: E731
        play_sessions(store, inputs_of, workers=workers)
        while following := _following_sessions(store):  # a training program's next sessions, in turn
            for record in following:
                inputs = players[record.group]
                store.create_session(record.participant.id, input_spec=inputs.spec, simulated=inputs.simulated,
                                     clock=inputs.clock)
            play_sessions(store, inputs_of, workers=workers)
        return trials_table(store)


def _following_sessions(store) -> list:
    """The participants with a session of the program still to run (on the simulated calendar, each
    the day it becomes due)."""
    from microg.study.schedule import next_session

    return [record for record in store.participants()
            if next_session(store.protocol, record.group, [s.sitting for s in store.sessions_of(record.participant.id)])
            is not None]


def play_sessions(store, inputs_of, workers: int = 1) -> None:
    """Play every running session of ``store`` (simulated participants, ``inputs_of(session)``
    their ``SimulatedInputs``) with the engine and write each task's run as the session runner
    would, in the order it would run them; then end the sessions. A phase trained to a criterion
    plans each task after the one before ended, as a session does. With ``workers`` > 1 (a study
    without such phases) the tasks are planned first and shared out to worker processes."""
    protocol = store.protocol
    sessions = [(record, session) for record in store.participants()
                for session in [store.session_of(record.participant.id)]
                if session is not None and session.status == "running"]
    streams = [_session_stream(store, record, session, inputs_of(session)) for record, session in sessions]
    if workers > 1 and not any(phase.until for phase in protocol.phases):
        units = [unit for record, session in sessions for unit in _fixed_units(store, record, session, inputs_of(session))]
        results = iter(play_tasks(protocol, units, workers=workers))
        for stream in streams:  # each session's runs written in its order
            unit = next(stream, None)
            while unit is not None:
                unit = advance(stream, next(results))
        return
    play_streams(protocol, streams)


def _fixed_units(store, record, session, inputs) -> list[TaskUnit]:
    """Every task of a session without a phase trained to a criterion, in its order."""
    return [unit for phase in store.protocol.phases_for(record.group, session.name) if store.protocol.runs_tasks(phase)
            for unit, _ in _phase_units(store, record, session, inputs, phase)]


def _phase_units(store, record, session, inputs, phase):
    """The planned tasks of a phase of fixed tasks: (its ``TaskUnit``, its task and seed)."""
    from microg.study.session import earlier_sessions, planned_runs

    protocol, earlier = store.protocol, earlier_sessions(store, session)
    for task, plan, seed in planned_runs(protocol, session, participant=record, tasks=store.tasks(session.id),
                                         phase=phase, earlier=earlier):
        yield _unit(task, plan, seed, inputs), (task, seed)


def _unit(task, plan, seed: int, inputs) -> TaskUnit:
    return TaskUnit(plan, inputs.skill(plan), seed, inputs.time_limit_s(plan), task.interaction, task.object)


def _session_stream(store, record, session, inputs) -> Stream:
    """A session's tasks as the engine plays them, each run written as it ends, as the session
    runner writes it (its start and end on the session's clock, rebuilt from its frames' times);
    a phase trained to a criterion plans its next task from the runs so far and logs its end."""
    from microg.study.session import (SimulationClock, criterion_end, earlier_sessions, next_criterion_task,
                                      planned_run)
    from microg.study.store import Event

    protocol, clock = store.protocol, SimulationClock()
    earlier = earlier_sessions(store, session)
    for phase in protocol.phases_for(record.group, session.name):
        if not protocol.runs_tasks(phase):
            continue
        if protocol.phase(phase.name) is None or protocol.phase(phase.name).until is None:
            for unit, (task, seed) in list(_phase_units(store, record, session, inputs, phase)):
                _write_run(store, session, clock, task, seed, unit, (yield unit))
            continue
        while (task := next_criterion_task(store, session, record, phase.name)) is not None:
            _, plan, seed = planned_run(protocol, session, participant=record, tasks=store.tasks(session.id), task=task,
                                        earlier=earlier)
            unit = _unit(task, plan, seed, inputs)
            _write_run(store, session, clock, task, seed, unit, (yield unit))
        ended = criterion_end(store, session.id, phase.name)
        if ended is not None:
            store.log(session.id, [Event(clock.now(), *ended)])
    store.finish_session(session.id, clock.now())


def _write_run(store, session, clock, task, seed: int, unit: TaskUnit, result) -> None:
    """A task's run as the session runner writes it."""
    from microg.study.store import Event

    protocol = store.protocol
    source = f"simulated:{unit.skill.name}:seed={seed}"
    run_id = store.begin_run(session.id, task=task, source=source, seed=seed, t=clock.now())
    times = result.frame_times
    clock.elapse_each(np.diff(times))
    reason = {"completed": None, "timeout": timeout_reason(protocol.rules(task.phase)),
              "aborted": f"the hand source ({source}) ended before the task did"}[result.status]
    measured = [Event(clock.now(), "measures", {"kind": kind, **result.measures})
                for kind in [protocol.kind(task.phase)] if result.measures]
    store.end_run(run_id, result.status, clock.now(), time_s=result.time_s, attempts=result.attempts,
                  reason=reason, events=measured + [Event(clock.now(), "in_silico", {"frames": len(times)})])
