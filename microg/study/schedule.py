"""A training program's calendar: which session a participant runs next, from which day, and how
each of their sessions stands (done, running, due on a date, overdue).

A session of the protocol's ``[[sessions]]`` may run ``after_days`` days after the participant's
previous session at the earliest (its due date; the first session is due the day the participant
starts); with ``within_days`` it is overdue that many days after its due date (still runnable).
Simulated participants live on a simulated calendar: the first session's date is the day the study
was made and each next one runs on its due date, so a demo runs a whole program at once.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass

from .protocol import Protocol, SessionPlan


@dataclass(frozen=True)
class Sitting:
    """A session a participant has in the store: its name, when it ran and how it ended."""

    name: str
    date: datetime.date
    status: str


@dataclass(frozen=True)
class SessionState:
    """How one of a participant's sessions stands on a day: ``done`` (with its status), ``running``,
    ``due`` (from ``due``), ``overdue`` (past its window), ``later`` (an earlier session has not run)."""

    name: str
    state: str
    due: datetime.date | None
    date: datetime.date | None = None
    status: str | None = None

    def describe(self) -> str:
        if self.state == "done":
            return f"{self.name}: {self.status} on {self.date}"
        if self.state == "running":
            return f"{self.name}: running since {self.date}"
        if self.state in ("due", "overdue"):
            return f"{self.name}: {'overdue, was ' if self.state == 'overdue' else ''}due on {self.due}"
        return f"{self.name}: after {self.due}" if self.due else f"{self.name}: later"


class ScheduleError(ValueError):
    """A session asked for out of order, twice, or before its day."""


def next_session(protocol: Protocol, group: str, sittings: list[Sitting]) -> SessionPlan | None:
    """The session a participant of ``group`` runs next (None: every session has run)."""
    done = {s.name for s in sittings}
    return next((plan for plan in protocol.sessions_for(group) if plan.name not in done), None)


def due_date(plan: SessionPlan, sittings: list[Sitting], first_day: datetime.date) -> datetime.date:
    """The earliest day ``plan`` may run: ``after_days`` after the previous session's date, or
    ``first_day`` for a participant's first session."""
    return first_day if not sittings else sittings[-1].date + datetime.timedelta(days=plan.after_days)


def overdue_from(plan: SessionPlan, due: datetime.date) -> datetime.date | None:
    """The first day ``plan`` due on ``due`` is overdue (None: it has no window)."""
    return None if plan.within_days is None else due + datetime.timedelta(days=plan.within_days + 1)


def choose_session(protocol: Protocol, participant: str, group: str, sittings: list[Sitting],
                   asked: str | None) -> SessionPlan:
    """The session to start for ``participant``: ``asked`` (a session's name) or their next one;
    refused when one is running, when ``asked`` ran already or comes out of order, or when every
    session has run, naming what to run instead."""
    plans = protocol.sessions_for(group)
    running = [s for s in sittings if s.status == "running"]
    if running:
        raise ScheduleError(f"participant {participant}'s session {running[0].name!r} is running (not ended); "
                            "continue it with: microg session resume")
    upcoming = next_session(protocol, group, sittings)
    instead = f"their next session is {upcoming.name!r}" if upcoming else "they have run every session of the program"
    if asked is not None:
        names = [p.name for p in plans]
        if asked not in names:
            raise ScheduleError(f"--session {asked!r}: participant {participant} (group {group}) has no such session "
                                f"(theirs: {', '.join(names)})")
        ran = next((s for s in sittings if s.name == asked), None)
        if ran is not None:
            raise ScheduleError(f"participant {participant}'s session {asked!r} ran already ({ran.status} on "
                                f"{ran.date}): a session is never run twice; {instead}")
        if upcoming.name != asked:
            raise ScheduleError(f"--session {asked!r} is out of order for participant {participant}: {instead}")
    if upcoming is None:
        raise ScheduleError(f"participant {participant} has run every session of the program "
                            f"({', '.join(p.name for p in plans)}): a session is never run twice")
    return upcoming


def session_states(protocol: Protocol, group: str, sittings: list[Sitting], today: datetime.date,
                   first_day: datetime.date | None = None) -> list[SessionState]:
    """Every session of a participant of ``group`` as it stands on ``today``: the ones they ran,
    then the next (due on its date, or overdue past its window; from ``first_day`` or ``today``
    for a first session), then the later ones (after the next's due date at the earliest)."""
    by_name = {s.name: s for s in sittings}
    states, earliest = [], None
    for plan in protocol.sessions_for(group):
        sat = by_name.get(plan.name)
        if sat is not None:
            states.append(SessionState(plan.name, "running" if sat.status == "running" else "done", None,
                                       sat.date, sat.status))
        elif earliest is None and not any(s.state == "running" for s in states):
            due = due_date(plan, sittings, first_day or today)
            late = overdue_from(plan, due)
            states.append(SessionState(plan.name, "overdue" if late is not None and today >= late else "due", due))
            earliest = due
        else:
            earliest = None if earliest is None else earliest + datetime.timedelta(days=plan.after_days)
            states.append(SessionState(plan.name, "later", earliest))
    return states


def what_is_next(protocol: Protocol, group: str, sittings: list[Sitting], today: datetime.date) -> str:
    """What a trainee hears is next: their running session, the next one due (or overdue) on its
    date, or that the program is done."""
    for state in session_states(protocol, group, sittings, today):
        if state.state == "running":
            return f"session {state.name!r}, under way since {state.date.isoformat()}"
        if state.state in ("due", "overdue"):
            return f"session {state.name!r}, " + ("overdue: it was " if state.state == "overdue" else "") + \
                f"due on {state.due.isoformat()}"
    return "nothing: every session of the program is done"


def trainee_outlook(store, participant: str, today: datetime.date) -> tuple[str, float | None]:
    """What a trainee's page says is next (``what_is_next``) and the time limit of the first
    criterion their group trains to (None: none)."""
    protocol, record = store.protocol, store.participant(participant)
    sittings = [s.sitting for s in store.sessions_of(participant)]
    trained = [protocol.phase(entry.name) for entry in protocol.timeline
               if entry.groups is None or record.group in entry.groups]
    limits = [phase.until.time_s for phase in trained if phase is not None and phase.until is not None]
    return what_is_next(protocol, record.group, sittings, today), limits[0] if limits else None
