"""``microg plan training``: a training program planned in silico before anyone is recruited."""

from __future__ import annotations

from pathlib import Path

import click

from microg.cli.common import SEED, ExistingPath, clear_errors
from microg.cli.power import power_errors, profile_population


@click.group("plan")
def plan() -> None:
    """Plan a study before recruiting: what a training program gives its trainees."""


@plan.command("training")
@click.option("--protocol", required=True, help="The training program: a protocol name or file with [[sessions]].")
@click.option("--n", "n_per_group", type=int, default=20, show_default=True, help="Trainees per group in a cohort.")
@click.option("--sims", type=int, default=200, show_default=True, help="Cohorts played through the program.")
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for plan.csv, plan.png (and cohorts.csv, run.json, to resume).")
@click.option("--compare", default=None, metavar="NAME|FILE",
              help="A second program (a protocol name or file) played by the same simulated people, drawn beside the first "
                   "(massed against spaced, one interaction model against another).")
@click.option("--profile", type=ExistingPath(dir_okay=False, path_type=Path), default=None,
              help="A population file (PROFILE.toml, microg participant calibrate writes one) that every group's "
                   "trainees are drawn from; default: each group's simulated_profile.")
@click.option("--target", type=float, default=0.8, show_default=True, help="The share of trainees proficient to reach.")
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT",
              help="An existing Dask scheduler; default: a local cluster on this machine's cores.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes of the local cluster [default: one per core].")
@click.option("--seed", type=SEED, default=1, show_default=True,
              help="Seed of the run; each cohort's seed derives from it and the cohort's index.")
@click.option("--resume", is_flag=True, help="Continue the run in --out where it stopped (same settings).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@clear_errors
@power_errors
def training(*, protocol: str, n_per_group: int, sims: int, out: Path, compare: str | None, profile: Path | None,
             target: float, scheduler: str | None, workers: int | None, seed: int, resume: bool, quiet: bool) -> None:
    """How many sessions of a training program until --target of its trainees are proficient, and
    what is left at its retention test: --sims cohorts of --n trainees per group played through
    every session in silico (learning and forgetting across days, criteria and staircases as a
    session runs them), one Dask task per cohort.

    Writes OUT/plan.csv (per program, group and session: the share proficient with its 90 % band,
    tasks to criterion, completion time, retention loss) and OUT/plan.png, and prints the answer.
    The same seed gives the same plan with any number of workers; --resume finishes a stopped run.
    """
    from microg.paths import protocol_file
    from microg.power.program import ProgramRequest, plan_training
    from microg.study.protocol import load_protocol

    population = profile_population(profile)
    programs = [load_protocol(protocol_file(name)) for name in [protocol] + ([compare] if compare else [])]
    problems = [p for program in programs for p in program.player_problems()] if population is None else []
    if problems:
        raise click.ClickException("\n".join(problems))
    request = ProgramRequest(programs[0], n_per_group, sims, seed, target, programs[1] if compare else None,
                             population)
    result = plan_training(request, out, scheduler, workers, resume, progress=not quiet)
    shown = result.table[["program", "group", "session", "day", "proficient", "proficient_low", "proficient_high",
                          "tasks_to_criterion", "time_s", "retention_loss_s"]]
    click.echo(shown.to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    for line in result.words:
        click.echo(line)
    click.echo(f"-> {out / 'plan.csv'}, {out / 'plan.png'}")


COMMANDS = [plan]
