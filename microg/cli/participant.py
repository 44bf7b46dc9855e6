"""``microg participant add | add-sample | withdraw | list``."""

from __future__ import annotations

import click

from microg.study.assignment import GENDERS, HANDEDNESS, Participant, paper_sample
from microg.study.store import open_study
from .common import SEED, clear_errors, study_dir_argument


@click.group("participant")
def participant() -> None:
    """Enrol, list and withdraw participants."""


def _describe(record) -> str:
    p = record.participant
    row = "" if record.order_row is None else f", Latin-square row {record.order_row}"
    return (f"{p.id}: group {record.group}, object order {' '.join(record.object_order)}{row} "
            f"({p.gender}, {p.age}, {p.handedness}-handed, MR experience {'yes' if p.mr_experience else 'no'})")


@participant.command("add")
@study_dir_argument
@click.option("--id", "participant_id", required=True, help="Letters and digits, e.g. P01; never reused.")
@click.option("--gender", type=click.Choice(GENDERS), required=True)
@click.option("--age", type=int, required=True, help="Age in whole years.")
@click.option("--handedness", type=click.Choice(HANDEDNESS), required=True)
@click.option("--mr-experience", type=click.Choice(["yes", "no"]), required=True,
              help="Has the participant used mixed reality before?")
@clear_errors
def add(study_dir: str, participant_id: str, gender: str, age: int, handedness: str, mr_experience: str) -> None:
    """Enrol a participant: assigns a group (gender-balanced) and an object order."""
    with open_study(study_dir) as store:
        record = store.add_participant(Participant(participant_id, gender, age, handedness, mr_experience == "yes"))
        click.echo(_describe(record))


@participant.command("add-sample")
@study_dir_argument
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Who gets which demographic value.")
@clear_errors
def add_sample(study_dir: str, seed: int) -> None:
    """Enrol P01-P30 with the paper's demographics (20 male, 10 female, aged 18-30, mean 23.63,
    SD 3.44, 3 left-handed, 8 without MR experience): for simulated studies."""
    with open_study(study_dir) as store:
        people = paper_sample(seed)
        taken = {p.id for p in store.participants()} & {p.id for p in people}
        if taken:
            raise click.ClickException(f"participants {sorted(taken)} are already in study {store.name!r}; "
                                       "add the sample to a study without them")
        for person in people:
            click.echo(_describe(store.add_participant(person)))


@participant.command("withdraw")
@study_dir_argument
@click.option("--participant", "participant_id", required=True, help="The participant to withdraw.")
@click.option("--reason", required=True, help="Why, for the record.")
@clear_errors
def withdraw(study_dir: str, participant_id: str, reason: str) -> None:
    """Withdraw a participant: their data stays (marked), their slot is free for someone new."""
    with open_study(study_dir) as store:
        store.withdraw(participant_id, reason)
        click.echo(f"withdrew {participant_id}: {reason}")


@participant.command("list")
@study_dir_argument
@clear_errors
def list_participants(study_dir: str) -> None:
    """Every participant with group, object order and status."""
    with open_study(study_dir, readonly=True) as store:
        for record in store.participants():
            click.echo(f"{_describe(record)} [{record.status}]")


COMMANDS = [participant]
