"""``microg view``: the 3D view of a study's sessions in the browser (live or replayed), and
``microg view export``: pictures of a task for reports and papers."""

from __future__ import annotations

from pathlib import Path

import click

from microg.view import HAND_MODES
from .common import clear_errors

study_option = click.option("--study", "study_dir", required=True, type=click.Path(file_okay=False, path_type=str),
                            help="The study folder (holding study.db).")
hands_option = click.option("--hands", type=click.Choice(HAND_MODES), default="rendered", show_default=True,
                            help="Draw the rendered (god-object) hand, the tracked hand, or both (tracked faint).")


@click.group("view", invoke_without_command=True)
@click.option("--study", "study_dir", type=click.Path(file_okay=False, path_type=str),
              help="The study folder (holding study.db).")
@click.option("--session", "session", default=None,
              help="A participant id (P01) or session number; default: the running session, else the latest.")
@click.option("--port", default=8080, show_default=True, help="Port on 127.0.0.1 (the next free one if taken).")
@hands_option
@click.option("--task", "task_index", type=int, default=None, help="Open on this task (index in the session's plan).")
@click.option("--at", "seconds", type=float, default=None, help="Open paused this many seconds into the task.")
@click.pass_context
@clear_errors
def view(ctx: click.Context, study_dir: str | None, session: str | None, port: int, hands: str,
         task_index: int | None, seconds: float | None) -> None:
    """Watch a running session, or replay a logged one, in the browser.

    Served on this machine only (127.0.0.1): the tracked and rendered hands, the contact
    highlight, the object, the places lighting up, and the stage, task timer and attempts.
    A live view follows the newest frame; play, pause, speed and the time slider replay.
    """
    if ctx.invoked_subcommand is not None:
        return
    if study_dir is None:
        raise click.UsageError("give --study DIR (and optionally --session ID)")
    from microg.view.server import serve

    try:
        serve(study_dir, session, port, hands, task_index, seconds, announce=click.echo)
    except KeyboardInterrupt:
        click.echo("view stopped")


def _size(text: str) -> tuple[int, int]:
    width, _, height = text.partition("x")
    if not (width.isdigit() and height.isdigit() and int(width) >= 16 and int(height) >= 16):
        raise click.BadParameter(f"{text!r}: give WIDTHxHEIGHT in pixels, e.g. 480x360", param_hint="--size")
    return int(width), int(height)


@view.command("export")
@study_option
@click.option("--session", "session", required=True, help="A participant id (P01) or session number.")
@click.option("--task", "task_index", type=int, required=True, help="The task (index in the session's plan).")
@click.option("--run", "run", type=int, default=None, help="Which run of the task (default: its last).")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="An image strip (.png, .pdf, .svg) or an animation (.gif, .webp).")
@hands_option
@click.option("--at", "seconds", type=float, multiple=True,
              help="Strip panels at these seconds into the task (repeat); default: the key moments "
                   "(start, pick-up, each place, release).")
@click.option("--size", default="480x360", show_default=True, help="Pixels of one panel or animation frame.")
@click.option("--fps", default=15.0, show_default=True, help="Animation frames per second.")
@click.option("--speed", default=1.0, show_default=True, help="Animation speed (2: twice real time).")
@click.option("--title/--no-title", default=True, show_default=True, help="A title line over the strip.")
@click.option("--overwrite", is_flag=True, help="Replace OUT if it exists.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@clear_errors
def export(study_dir: str, session: str, task_index: int, run: int | None, out: Path, hands: str,
           seconds: tuple[float, ...], size: str, fps: float, speed: float, title: bool, overwrite: bool,
           quiet: bool) -> None:
    """Pictures of one task for a report or paper: an image strip of its key moments (like the
    paper's Figs. 7 and 9) or an animation."""
    from microg.view import export_task

    try:
        written = export_task(study_dir, session, task_index, out, run=run, hands=hands, seconds=seconds,
                              size=_size(size), fps=fps, speed=speed, title=title, overwrite=overwrite,
                              progress=not quiet)
    except ValueError as error:
        raise click.ClickException(str(error)) from None
    click.echo(f"wrote {written}")


COMMANDS = [view]
