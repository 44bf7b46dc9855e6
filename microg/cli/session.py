"""``microg session run | resume``: run a participant's session from live, replayed or simulated hands."""

from __future__ import annotations

import click
from tqdm import tqdm

from microg.study.inputs import open_inputs, parse_input
from microg.study.protocol import Phase
from microg.study.questionnaire import TerminalRater
from microg.study.session import make_clock, resume_session, run_session
from microg.study.store import Event, PlannedTask, Store, open_study
from .common import clear_errors, study_dir_argument

QUESTIONNAIRE_DEFAULT = {"leap": "ask", "replay": "skip", "simulated": "model"}


class TerminalOperator:
    """The researcher at the keyboard of a live session."""

    def show(self, phase: Phase) -> None:
        click.echo(f"\n== {phase.name} ({phase.minutes:g} min) ==")
        if phase.text.strip():
            click.echo(phase.text.strip())
        click.prompt("Press Enter when done", default="", show_default=False)

    def ready(self, task: PlannedTask) -> bool:
        answer = click.prompt(f"\nNext: {task.phase}, {task.object} ({task.object_code}), position "
                              f"{task.order_position}. Enter to start, s to skip", default="", show_default=False)
        return answer.strip().lower() != "s"


@click.group("session")
def session() -> None:
    """Run and resume participants' sessions."""


def _rater(kind: str, store: Store, session_id: int, seed: int, clock):
    if kind == "skip":
        return None
    if kind == "ask":
        def rejected(item, stage, text, message):
            store.log(session_id, [Event(clock.now(), "answer_rejected", {"system": stage.system, "item": item.name,
                                                                  "answer": text, "message": message})])
        return TerminalRater(on_rejected=rejected)

    from microg.study.questionnaire import ModelRater
    return ModelRater(store, session_id, seed)


def _run_one(store: Store, participant_id: str, input_spec: str | None, questionnaire: str | None, lsl: bool,
             progress: bool, resume: bool) -> str:
    record = store.participant(participant_id)
    existing = store.session_of(participant_id)
    if resume and existing is None:
        raise click.ClickException(f"participant {participant_id} has no session to resume; start one with: "
                                   f"microg session run {store.dir} --participant {participant_id} --input ...")
    spec = input_spec or (existing.input if existing else None)
    if spec is None:
        raise click.ClickException("give --input leap, replay:FILE or simulated[:PROFILE]")
    inputs = open_inputs(spec, store.protocol.group(record.group).simulated_profile)
    kind = spec.partition(":")[0]
    rating = questionnaire or QUESTIONNAIRE_DEFAULT.get(kind, "skip")
    if resume:
        session_record = existing
        if session_record.status != "running":
            raise click.ClickException(f"session {existing.id} of {participant_id} is {existing.status}; "
                                       "there is nothing to resume")
    else:
        session_record = store.create_session(participant_id, inputs.spec, inputs.simulated, inputs.clock)
    store.lock_session(session_record.id)
    clock = make_clock(inputs.clock, store.last_time(session_record.id))
    rater = _rater(rating, store, session_record.id, session_record.seed, clock)
    markers = None
    if lsl:
        from microg.study.lsl import MarkerOutlet
        markers = MarkerOutlet()
    options = dict(clock=clock, operator=TerminalOperator() if kind == "leap" else None, rater=rater,
                   markers=markers, progress=progress)
    try:
        if resume:
            return resume_session(store, session_record.id, inputs, **options)
        return run_session(store, session_record.id, inputs, **options)
    except (KeyboardInterrupt, click.Abort):
        raise click.ClickException(f"session {session_record.id} of {participant_id} paused; the task in progress "
                                   f"will run again from its start on: microg session resume {store.dir} "
                                   f"--participant {participant_id}") from None
    finally:
        inputs.close()


INPUT_HELP = ("leap (live tracking), replay:FILE (a recording, replayed for each task) or simulated[:PROFILE] "
              "(a simulated participant; PROFILE practice (skill grows with each task done), veteran or beginner; "
              "default: the group's simulated_profile).")
QUESTIONNAIRE_HELP = ("ask (in the terminal), model (the rating model of microg.participant.ratings, answers marked "
                      "simulated) or skip; default: ask "
                      "for leap, model for simulated, skip for replay.")


@session.command("run")
@study_dir_argument
@click.option("--participant", "participant_id", help="The participant whose session to run.")
@click.option("--all", "run_all", is_flag=True,
              help="Run every active participant without a finished session (resuming unfinished ones).")
@click.option("--input", "input_spec", required=True, help=INPUT_HELP)
@click.option("--questionnaire", type=click.Choice(["ask", "model", "skip"]), default=None, help=QUESTIONNAIRE_HELP)
@click.option("--lsl", is_flag=True, help="Send task and stage events as an LSL marker stream (needs microg[lsl]).")
@click.option("--quiet", is_flag=True, help="No progress bars.")
@clear_errors
def run(study_dir: str, participant_id: str | None, run_all: bool, input_spec: str, questionnaire: str | None,
        lsl: bool, quiet: bool) -> None:
    """Run a participant's session: timeline, tasks, questionnaire; everything is logged as it happens."""
    if bool(participant_id) == run_all:
        raise click.UsageError("give either --participant ID or --all")
    parse_input(input_spec)
    with open_study(study_dir) as store:
        if participant_id:
            status = _run_one(store, participant_id, input_spec, questionnaire, lsl, not quiet, resume=False)
            click.echo(f"session of {participant_id}: {status}")
            return
        todo = [p.id for p in store.participants() if p.status == "active"
                and (store.session_of(p.id) is None or store.session_of(p.id).status == "running")]
        for pid in tqdm(todo, unit="participant", desc="participants", disable=quiet):
            resume = store.session_of(pid) is not None
            _run_one(store, pid, None if resume else input_spec, questionnaire, lsl, not quiet, resume=resume)
        click.echo(f"ran {len(todo)} session(s)")


@session.command("resume")
@study_dir_argument
@click.option("--participant", "participant_id", required=True, help="The participant whose session to resume.")
@click.option("--input", "input_spec", default=None, help=INPUT_HELP + " Default: the session's own input.")
@click.option("--questionnaire", type=click.Choice(["ask", "model", "skip"]), default=None, help=QUESTIONNAIRE_HELP)
@click.option("--lsl", is_flag=True, help="Send task and stage events as an LSL marker stream (needs microg[lsl]).")
@click.option("--quiet", is_flag=True, help="No progress bars.")
@clear_errors
def resume(study_dir: str, participant_id: str, input_spec: str | None, questionnaire: str | None, lsl: bool,
           quiet: bool) -> None:
    """Carry on a session that was cut off: at its first unfinished task (a task cut off midway runs
    again from its start; its partial frames stay, marked interrupted)."""
    with open_study(study_dir) as store:
        status = _run_one(store, participant_id, input_spec, questionnaire, lsl, not quiet, resume=True)
        click.echo(f"session of {participant_id}: {status}")


COMMANDS = [session]
