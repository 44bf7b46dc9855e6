"""``microg export``: tidy tables (CSV, Parquet), frames and Motion-BIDS from a study."""

from __future__ import annotations

from pathlib import Path

import click

from microg.study.export import export_study
from .common import clear_errors, study_dir_argument


@click.command("export")
@study_dir_argument
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Folder to write into (default: STUDY_DIR/export).")
@click.option("--format", "formats", type=click.Choice(["csv", "parquet"]), multiple=True,
              default=("csv", "parquet"), show_default=True, help="Table formats; repeat for several.")
@click.option("--frames/--no-frames", default=True, show_default=True, help="Write the frame-level table.")
@click.option("--bids/--no-bids", default=True, show_default=True, help="Write the Motion-BIDS dataset.")
@click.option("--overwrite", is_flag=True, help="Replace files of an earlier export.")
@click.option("--accept-damaged", is_flag=True,
              help="Export a study that fails its integrity check (microg study check) anyway; export.json lists "
                   "what is wrong with it.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@clear_errors
def export(study_dir: str, out_dir: str | None, formats: tuple[str, ...], frames: bool, bids: bool, overwrite: bool,
           accept_damaged: bool, quiet: bool) -> None:
    """Export STUDY_DIR: trials and questionnaire tables, frames, Motion-BIDS."""
    out = Path(out_dir) if out_dir else Path(study_dir) / "export"
    written = export_study(study_dir, out, formats=formats, frames=frames, bids=bids, overwrite=overwrite,
                           accept_damaged=accept_damaged, progress=not quiet, say=click.echo)
    click.echo(f"wrote {len(written)} files into {out}")


COMMANDS = [export]
