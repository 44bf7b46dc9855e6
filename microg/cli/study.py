"""``microg study init``: create a study from a protocol; ``microg study status``: where it stands;
``microg study schedule``: who is due for which session of a training program in the coming days;
``microg study check``: the study database's full integrity check; ``microg study station`` (and
``--give-up``) and ``microg study merge``: several stations run one study (``microg.study.stations``)."""

from __future__ import annotations

import datetime
import secrets
from collections import Counter
from pathlib import Path

import click

from microg.paths import protocol_file

from microg.study import ledger
from microg.study.protocol import load_protocol
from microg.study.schedule import overdue_from, session_states
from microg.study.stations import give_up, given_up, make_station, merge_stations, stations
from microg.study.store import DATABASE, archived, check_study, create_study, describe_counts, open_study
from .common import SEED, clear_errors, study_dir_argument


@click.group("study")
def study() -> None:
    """Create a study, see where it stands, check its database, run it at several stations."""


@study.command("init")
@study_dir_argument
@click.option("--protocol", "protocol_name", default="paper", show_default=True,
              help="Protocol file, or the name of a shipped protocol (paper, paper-microgravity, mallet-microgravity).")
@click.option("--seed", type=SEED, default=None,
              help="Seed of every random choice in the study (default: the protocol's, else a fresh one).")
@clear_errors
def init(study_dir: str, protocol_name: str, seed: int | None) -> None:
    """Create a study in STUDY_DIR from a protocol: one SQLite database holding everything."""
    protocol = load_protocol(protocol_file(protocol_name))
    for problem in protocol.simulation_problems():
        click.echo(f"warning: {problem}; simulated sessions (--input simulated, microg demo) of this study "
                   "will refuse to start", err=True)
    seed = seed if seed is not None else protocol.seed if protocol.seed is not None else secrets.randbelow(2**31)
    with create_study(study_dir, protocol, seed) as store:
        click.echo(f"created study {store.name!r} in {study_dir} (seed {seed}, protocol sha256 {protocol.sha256[:12]})")
        click.echo(f"  {protocol.total_participants} participants in groups "
                   + ", ".join(f"{g.code} ({g.name}, {g.size})" for g in protocol.groups)
                   + f"; objects {', '.join(o.code for o in protocol.objects)} in {protocol.order} order")
        click.echo(f"next: microg participant add {study_dir} --id P01 --gender female --age 24 "
                   "--handedness right --mr-experience yes")


@study.command("status")
@study_dir_argument
@clear_errors
def status(study_dir: str) -> None:
    """Participants per group and gender, and how each session's tasks stand (read only)."""
    with open_study(study_dir, readonly=True, accept_damaged=True) as store:
        for problem in store.problems:
            click.echo(f"damaged: {problem}", err=True)
        people = store.participants()
        active = [p for p in people if p.status == "active"]
        click.echo(f"study {store.name!r}: {len(active)} active, {len(people) - len(active)} withdrawn")
        for group in store.protocol.groups:
            counts = Counter(p.participant.gender for p in active if p.group == group.code)
            click.echo(f"  {group.code} ({group.name}): {sum(counts.values())}/{group.size}  "
                       + ", ".join(f"{g} {n}" for g, n in sorted(counts.items())))
        today = datetime.date.today()
        for p in people:
            sessions = store.sessions_of(p.id)
            if store.protocol.program:
                states = session_states(store.protocol, p.group, [s.sitting for s in sessions], today)
                state = "; ".join(s.describe() for s in states if p.status == "active" or s.state != "due")
            elif not sessions:
                state = "no session"
            else:
                session = sessions[-1]
                state = f"session {session.id} {session.status}, {describe_counts(store.task_counts(session.id))} " \
                        f"({session.input})"
            click.echo(f"  {p.id:>6} {p.group} {p.participant.gender:<11} {p.status:<9} {state}")
        if store.station is not None:
            click.echo(f"station {store.station}'s study (made with microg study station): it runs the participants "
                       "above, enrolled centrally; bring its sessions into the central study with: microg study merge")
        else:
            for made in stations(store.db):
                merged = store.db.execute("SELECT COUNT(*) FROM sessions WHERE station = ?", (made.name,)).fetchone()[0]
                back = given_up(store.db, made.name)
                click.echo(f"  station {made.name} (made {made.made_at}): {', '.join(made.participants)}; "
                           f"{merged} session(s) merged" + (f"; taken back: {', '.join(back)}" if back else ""))
        if store.problems:
            click.echo(f"the study is damaged ({len(store.problems)} problem(s) above); see: microg study check "
                       f"{study_dir}", err=True)
        if archived(store.dir / DATABASE):
            click.echo("read only here (an archive): the commands that write into a study refuse it")


@study.command("schedule")
@study_dir_argument
@click.option("--days", type=click.IntRange(min=1), default=7, show_default=True,
              help="How many days ahead to list, today included (a lab's week).")
@click.option("--out", "out_file", type=click.Path(dir_okay=False), default=None,
              help="Where to write the table as CSV; default: STUDY_DIR/schedule.csv (written anew each time).")
@clear_errors
def schedule(study_dir: str, days: int, out_file: str | None) -> None:
    """Who is due for which session of a training program in the coming --days, and who is overdue:
    a table (participant, group, session, due, overdue_from, state) printed and written as
    schedule.csv (read only on the study)."""
    import pandas as pd

    today = datetime.date.today()
    with open_study(study_dir, readonly=True, accept_damaged=True) as store:
        for problem in store.problems:
            click.echo(f"damaged: {problem}", err=True)
        rows = []
        for p in store.participants():
            if p.status != "active":
                continue
            states = session_states(store.protocol, p.group, [s.sitting for s in store.sessions_of(p.id)], today)
            for state in states:
                if state.state in ("due", "overdue", "running"):
                    plan = store.protocol.session(state.name)
                    due = state.due or state.date
                    late = None if state.due is None else overdue_from(plan, state.due)
                    rows.append({"participant": p.id, "group": p.group, "session": state.name,
                                 "due": due.isoformat(), "overdue_from": late.isoformat() if late else "",
                                 "state": state.state})
        table = pd.DataFrame(rows, columns=["participant", "group", "session", "due", "overdue_from", "state"])
        last = today + datetime.timedelta(days=days - 1)
        table = table[(table["state"] != "due") | (table["due"] <= last.isoformat())].sort_values(
            ["due", "participant"], kind="stable")
        target = Path(out_file) if out_file else Path(study_dir) / "schedule.csv"
    table.to_csv(target, index=False)
    click.echo(f"study {store.name!r} on {today.isoformat()}: {len(table)} session(s) due or running up to "
               f"{last.isoformat()}")
    if len(table):
        click.echo(table.to_string(index=False))
    click.echo(f"wrote {target}")


def _head(value: str) -> ledger.Head:
    try:
        return ledger.parse_head(value)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--head") from None


@study.command("check")
@study_dir_argument
@click.option("--head", "heads", multiple=True, metavar="ENTRY:LINK",
              help="A ledger head noted earlier (as this command prints it, or from an export's export.json): check "
                   "that the study's ledger still holds it, i.e. was not rewritten since (repeatable).")
@clear_errors
def check(study_dir: str, heads: tuple[str, ...]) -> None:
    """The full integrity check of STUDY_DIR's database (read only): every fact in the ledger's hash
    chain and against the chain's head beside the database (and any --head), every frame batch
    against its checksum, the append-only triggers, the stored protocol against its SHA-256, every
    finished task run's frames and events, participant ids, SQLite's own check. Prints the ledger's
    head to note elsewhere. Exit status 1 when something is wrong."""
    given = [(_head(value), f"--head {value}") for value in heads]
    with open_study(study_dir, readonly=True, accept_damaged=True) as store:
        problems = check_study(store, heads=given)
        runs, frames = store.db.execute("SELECT (SELECT COUNT(*) FROM task_runs), "
                                        "(SELECT COALESCE(SUM(count), 0) FROM frames)").fetchone()
        head = ledger.head_of(store.db)
        witnessed = (store.dir / ledger.HEAD_FILE).exists()
    if problems:
        for problem in problems:
            click.echo(f"damaged: {problem}")
        raise click.ClickException(f"{study_dir}: {len(problems)} problem(s); nothing was changed. Keep a copy of "
                                   "the study folder; microg export --accept-damaged exports it, marked as damaged")
    click.echo(f"{study_dir}: sound ({runs} task runs, {frames} frames; every fact and frame batch as committed, "
               "protocol and triggers as written)")
    click.echo(f"ledger head: {head}" + ("" if witnessed else f" (no {ledger.HEAD_FILE} beside the database: the "
                                                               "chain was checked within the database only)"))


@study.command("station")
@study_dir_argument
@click.option("--name", required=True, help="The station's name (letters, digits, '-', '_'), e.g. B; used once.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=str),
              help="A new folder for the station's study (copy it to the station's machine); to make a station.")
@click.option("--participant", "participants", multiple=True,
              help="A participant the station may run (repeat); default: every active participant with no session "
                   "here and given to no station yet (a trainee who ran sessions is named: they go with them). With "
                   "--give-up: a participant to take back (default: every one of the station's with a session left "
                   "to run).")
@click.option("--give-up", "give", is_flag=True,
              help="Instead, give up the station NAME made before: take its participants back (or those named with "
                   "--participant) so that they can run here or at another station; a merge of the station leaves "
                   "their sessions there out. Merge the station first if it ran any of them.")
@click.option("--reason", default=None, help="With --give-up: why, for the record.")
@clear_errors
def station(study_dir: str, name: str, out_dir: str | None, participants: tuple[str, ...], give: bool,
            reason: str | None) -> None:
    """Make a station's study from the central study STUDY_DIR: the same protocol and seed, and the
    participants it may run with the groups and object orders assigned here (so the balance holds
    across stations). Run its sessions there as usual; bring them back with microg study merge.
    With --give-up, take a station's participants back instead."""
    if give:
        if out_dir is not None:
            raise click.UsageError("--give-up takes participants back from a station made before: no --out")
        with open_study(study_dir) as central:
            back = give_up(central, name, participants, reason)
        click.echo(f"took {', '.join(back)} back from station {name}: run them here (microg session run "
                   f"{study_dir} --participant {back[0]} ...) or make another station for them")
        click.echo(f"  a merge of station {name} leaves its new sessions of {', '.join(back)} out (they stay in "
                   "its folder)")
        return
    if out_dir is None:
        raise click.UsageError("give --out FOLDER for the station's study (or --give-up to give a station up)")
    if reason is not None:
        raise click.UsageError("--reason goes with --give-up")
    with open_study(study_dir) as central:
        with make_station(central, name, out_dir=out_dir, participants=participants,
                          say=lambda text: click.echo(text, err=True)) as made:
            people = [p.id for p in made.participants()]
            carried = {pid: [s.name for s in made.sessions_of(pid)] for pid in people}
    click.echo(f"made station {name} in {out_dir}: it may run {', '.join(people)}")
    for pid, names in carried.items():
        if names:
            click.echo(f"  {pid}'s sessions run so far went with them: {', '.join(names)}")
    click.echo(f"next, on the station: microg session run {out_dir} --participant {people[0]} --input ...; then "
               f"here: microg study merge {study_dir} {out_dir}")


@study.command("merge")
@study_dir_argument
@click.argument("station_dirs", nargs=-1, required=True, type=click.Path(file_okay=False, path_type=str))
@clear_errors
def merge(study_dir: str, station_dirs: tuple[str, ...]) -> None:
    """Bring the ended sessions of the stations' studies STATION_DIRS into the central study
    STUDY_DIR: append-only, in one transaction, idempotent (a session merged before adds nothing),
    each session keeping its station and when it was merged; withdrawals at a station carry over.
    A trainee's sessions carried to a station with them are recognised as this study's own. Both
    sides' integrity is checked; any conflict (another protocol, one session run at two stations, a
    session that differs from the one merged before) is listed and nothing is merged."""
    with open_study(study_dir) as central:
        outcomes = merge_stations(central, station_dirs)
        head = ledger.head_of(central.db)
    for outcome in outcomes:
        parts = [f"merged {len(outcome.merged)} session(s)" + (f" ({', '.join(outcome.merged)})" if outcome.merged
                                                               else "")]
        if outcome.already:
            parts.append(f"{len(outcome.already)} merged before, unchanged ({', '.join(outcome.already)})")
        if outcome.carried:
            parts.append(f"{len(outcome.carried)} given to the station from here, unchanged "
                         f"({', '.join(outcome.carried)})")
        if outcome.withdrawn:
            parts.append(f"withdrew {', '.join(outcome.withdrawn)} as at the station")
        click.echo(f"station {outcome.station} ({outcome.folder}): " + "; ".join(parts))
        if outcome.running:
            click.echo(f"  still running at the station, not merged: {', '.join(outcome.running)} (finish or resume "
                       "them there, then merge again)")
        if outcome.given_up:
            click.echo(f"  taken back from the station (study station --give-up), not merged: "
                       f"{', '.join(outcome.given_up)} (their records stay in {outcome.folder})")
    click.echo(f"ledger head: {head}")


COMMANDS = [study]
