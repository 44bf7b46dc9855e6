"""``microg participant add | add-sample | withdraw | list | calibrate``."""

from __future__ import annotations

import functools
from pathlib import Path

import click

from microg.study.assignment import GENDERS, HANDEDNESS, Participant, paper_sample
from microg.study.store import open_study
from .common import SEED, clear_errors, say_damage, study_dir_argument


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
def add(*, study_dir: str, participant_id: str, gender: str, age: int, handedness: str, mr_experience: str) -> None:
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
        say_damage(store)
        for record in store.participants():
            click.echo(f"{_describe(record)} [{record.status}]")


def _calibration_errors(command):
    """The calibration's own errors as ``Error: <message>`` (exit status 1), without a traceback."""
    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from microg.insilico.calibrate import CalibrationError, TargetError
        from microg.participant import PopulationError
        from microg.power import PowerInputError

        try:
            return command(*args, **kwargs)
        except (CalibrationError, TargetError, PopulationError, PowerInputError) as error:
            raise click.ClickException(str(error)) from None
    return wrapper


@participant.command("calibrate")
@click.argument("study_dir", metavar="STUDY", required=False, type=click.Path(file_okay=False, path_type=str))
@click.option("--trials", "trials_file", type=click.Path(dir_okay=False, path_type=Path),
              help="An exported trials table (CSV or Parquet) instead of a study.")
@click.option("--targets", "targets_file", type=click.Path(dir_okay=False, path_type=Path),
              help="A TOML file of published summary numbers (docs/simulated-participant.md, Calibration).")
@click.option("--out", "profile", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The fitted PROFILE.toml; the run's files (calibration.csv, calibration.png, posterior.csv, "
                   "calibration.json, calibration.db) go into its folder.")
@click.option("--protocol", default=None, help="--trials and --targets: the protocol whose study is simulated "
              "[default: the targets file's, else paper]; a study uses its own.")  # fmt: skip
@click.option("--fit", "fit", default=None, metavar="NAME[:sd],...",
              help="The free values: NAME fits a parameter's population mean, NAME:sd its spread between people "
                   "[default: hesitation_s, hesitation_s:sd, movement_slope, carry_slowdown, shape_caution, "
                   "learning_rate, aim_sd, grip_lapse].")
@click.option("--hold-out", "held_out", multiple=True, metavar="PATTERN",
              help="Numbers to report in the check but not fit (shell pattern on their names, e.g. 'attempts.*'); "
                   "repeatable.")  # fmt: skip
@click.option("--base", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The population whose values are kept where nothing is fitted [default: the shipped default].")
@click.option("--particles", type=click.IntRange(min=2), default=100, show_default=True,
              help="ABC-SMC particles per generation.")
@click.option("--generations", type=click.IntRange(min=1), default=5, show_default=True)
@click.option("--participants", type=click.IntRange(min=2), default=None,
              help="Participants per group of each simulated study [default: the data's smallest group].")
@click.option("--check", type=click.IntRange(min=2), default=20, show_default=True,
              help="Studies simulated from the posterior for the predictive check.")
@click.option("--seed", type=click.IntRange(min=0), default=1, show_default=True,
              help="Seed of the run: the same seed gives the same posterior whatever the workers.")
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT",
              help="An existing Dask scheduler; default: a local cluster on this machine's cores.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes of the local cluster [default: one per core].")
@click.option("--resume", is_flag=True, help="Continue the run beside --out where it stopped (same settings).")
@clear_errors
@_calibration_errors
def calibrate(*, study_dir: str | None, trials_file: Path | None, targets_file: Path | None, profile: Path,
              protocol: str | None, fit: str | None, held_out: tuple[str, ...], base: Path | None, particles: int,
              generations: int, participants: int | None, check: int, seed: int, scheduler: str | None,
              workers: int | None, resume: bool) -> None:
    """Fit a population of simulated participants to a pilot STUDY, a --trials table or published
    --targets, by simulation-based inference (pyabc's ABC-SMC, on Dask as microg power runs).

    Prints the posterior (mean and 90 % interval of each free value) and the predictive check
    (every number against studies simulated from the posterior), writes --out PROFILE.toml and,
    beside it, calibration.csv and calibration.png.
    """
    from microg.insilico.calibrate import DEFAULT_FIT, CalibrationRequest, calibrate as run, describe, hold_out, parse_fit
    from microg.insilico.targets import file_source, study_source, trials_source
    from microg.participant import read_population
    from microg.paths import protocol_file
    from microg.power.run import dask_client
    from microg.study.protocol import load_protocol

    given = [name for name, value in (("STUDY", study_dir), ("--trials", trials_file), ("--targets", targets_file))
             if value]  # fmt: skip
    if len(given) != 1:
        raise click.UsageError("give exactly one of STUDY, --trials FILE, --targets FILE"
                               + (f" (not {' and '.join(given)})" if given else ""))
    if study_dir is not None and protocol is not None:
        raise click.UsageError("--protocol: a study is simulated with its own protocol")
    rules = load_protocol(protocol_file(protocol)) if protocol else None
    if study_dir is not None:
        source = study_source(study_dir, seed)
    elif trials_file is not None:
        source = trials_source(trials_file, rules or load_protocol(protocol_file("paper")), seed)
    else:
        source = file_source(targets_file, rules)
    request = CalibrationRequest(source.protocol, hold_out(source.targets, held_out), source.source, source.digest,
                                 parse_fit(",".join(DEFAULT_FIT) if fit is None else fit), read_population(base) if base else None,
                                 particles, generations, participants or source.participants, check, seed,
                                 source.unused)  # fmt: skip
    click.echo(f"calibrating to {request.source}: {sum(not t.held_out for t in request.targets)} numbers fitted, "
               f"{sum(t.held_out for t in request.targets)} held out; {particles} particles x {generations} "
               f"generations, {request.participants} simulated participants per group")
    with dask_client(scheduler, workers) as client:
        result = run(request, profile, client, resume=resume)
    click.echo(describe(result))
    click.echo(f"{result.summary['studies']} simulated studies in {result.summary['seconds']:.1f} s on "
               f"{result.summary['workers']} workers")
    folder = profile.parent
    click.echo(f"-> {profile}, {folder / 'calibration.csv'}, {folder / 'calibration.png'}, {folder / 'posterior.csv'}")
    click.echo(f"next: a study of these people, microg demo --profile {profile}; how many of them a study needs, "
               f"microg power --simulated --profile {profile}")


COMMANDS = [participant]
