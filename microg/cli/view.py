"""``microg view``: a study's sessions in the browser (live or replayed), or pictures of a task."""

from __future__ import annotations

from pathlib import Path

import click

from microg.view import HAND_MODES

from .common import clear_errors, picture_size, renamed, study_dir_argument


@click.command("view")
@study_dir_argument
@click.option("--session", "session", default=None,
              help="A participant id (P01) or session number; default: the running session, else the latest.")
@click.option("--task", "task_index", type=int, default=None, help="The task (index in the session's plan).")
@click.option("--run", "run", type=int, default=None, help="Which run of the task (default: its last).")
@click.option("--hands", type=click.Choice(HAND_MODES), default="rendered", show_default=True,
              help="Draw the rendered (god-object) hand, the tracked hand, or both (tracked faint).")
@click.option("--at", "seconds", type=float, multiple=True,
              help="Seconds into the task: the browser opens paused there; a strip shows these moments "
                   "(repeat; default: the key moments: start, pick-up, each place, release).")
@click.option("--port", default=8080, show_default=True, help="Port on 127.0.0.1 (the next free one if taken).")
@click.option("--out", "out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write pictures instead of serving: an image strip (.png, .pdf, .svg) or an animation "
                   "(.gif, .webp) of the task (needs --session and --task).")
@click.option("--size", default="480x360", show_default=True, help="Pixels of one panel or animation frame.")
@click.option("--fps", default=15.0, show_default=True, help="Animation frames per second.")
@click.option("--speed", default=1.0, show_default=True, help="Animation speed (2: twice real time).")
@click.option("--title/--no-title", default=True, show_default=True, help="A title line over the strip.")
@click.option("--overwrite", is_flag=True, help="Replace OUT if it exists.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@renamed("--study", "the argument STUDY_DIR (microg view STUDY_DIR)")
@clear_errors
def view(*, study_dir: str, session: str | None, task_index: int | None, run: int | None, hands: str,
         seconds: tuple[float, ...], port: int, out: Path | None, size: str, fps: float, speed: float, title: bool,
         overwrite: bool, quiet: bool) -> None:
    """Watch a running session of STUDY_DIR, or replay a logged one, in the browser (the operator's
    view); with --out, write pictures of one task for a report or paper instead (like the paper's
    Figs. 7 and 9).

    Served on this machine only (127.0.0.1), and only to pages it served itself: the tracked and
    rendered hands, the contact highlight, the object, the places lighting up, and the stage, task
    timer and attempts. A live view follows the newest frame; play, pause, speed and the time
    slider replay. (The participant sees their own view, served by the session: see
    ``microg session run --display``.)
    """
    if out is not None:
        from microg.view import export_task

        if session is None or task_index is None:
            raise click.UsageError("--out writes pictures of one task: give --session and --task too")
        try:
            written = export_task(study_dir, session, task_index, out, run=run, hands=hands, seconds=seconds,
                                  size=picture_size(size), fps=fps, speed=speed, title=title, overwrite=overwrite,
                                  progress=not quiet, say=lambda text: click.echo(text, err=True))
        except ValueError as error:
            raise click.ClickException(str(error)) from None
        click.echo(f"wrote {written}")
        return
    from microg.view.server import serve

    try:
        serve(study_dir, spec=session, port=port, hands=hands, task_index=task_index,
              seconds=seconds[0] if seconds else None, announce=click.echo)
    except KeyboardInterrupt:  # a second Ctrl-C, or one before the view was up
        pass
    click.echo("view stopped")


COMMANDS = [view]
