"""``microg demo``: the whole product at work, a simulated study from protocol to report."""

from __future__ import annotations

import click

from .common import SEED, clear_errors


@click.command()
@click.option("--out", type=click.Path(file_okay=False), default="microg-demo", show_default=True,
              help="Folder for the study, its tables and its report (in the current folder by default).")
@click.option("--participants", type=click.IntRange(2), default=30, show_default=True,
              help="Simulated participants to enrol (the paper had 30; at least 2, one per group, for the "
                   "report's between-group test).")
@click.option("--seed", type=SEED, default=1, show_default=True,
              help="Seed of the study: who is enrolled with which demographics, and every session.")
@click.option("--protocol", default="paper", show_default=True,
              help="A shipped protocol name (paper, paper-microgravity, mallet-microgravity) or a protocol file.")
@click.option("--profile", type=click.Path(dir_okay=False, exists=True), default=None,
              help="A population file (PROFILE.toml, microg participant calibrate writes one) that every group's "
                   "simulated participants are drawn from; default: each group's simulated_profile.")
@click.option("--jobs", type=click.IntRange(1), default=None, help="Worker processes (default: one per core).")
@click.option("--overwrite", is_flag=True, help="Replace what is in --out.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@clear_errors
def demo(*, out: str, participants: int, seed: int, protocol: str, profile: str | None, jobs: int | None,
         overwrite: bool, quiet: bool) -> None:
    """Run a complete simulated study: enrol participants with the paper's demographics, run every
    session (simulated hands, real session runner and physics, logged to SQLite), answer the
    questionnaires with the rating model (marked simulated), export the tables, write the report."""
    from microg.study.demo import run_demo

    result = run_demo(out, participants, seed, protocol, profile=profile, jobs=jobs, overwrite=overwrite,
                      progress=not quiet)
    click.echo(f"{result.participants} simulated participants, {result.tasks} tasks in "
               f"{result.seconds / 60:.1f} min")
    click.echo(f"study (SQLite log store): {result.study}")
    click.echo(f"tables: {result.tables}")
    click.echo(f"report: {result.report}")
    if result.trainee is not None:
        click.echo(f"a trainee's page: {result.trainee}")


COMMANDS = [demo]
