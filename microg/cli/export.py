"""``microg export``: tidy tables (CSV, Parquet), frames and Motion-BIDS from a study."""

from __future__ import annotations

from pathlib import Path

import click

from microg.study.export import export_study, refuse_links
from microg.study.store import open_study
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
@click.option("--xdf", "xdf_file", type=click.Path(dir_okay=False), default=None,
              help="Instead, line up an XDF recording of sessions run with --lsl (LabRecorder) with the study's log "
                   "by the markers: writes xdf_tasks (each task run's start and end on the LSL clock), xdf_markers "
                   "and xdf_mocap (the MoCap samples with the session's time), into --out (default: "
                   "STUDY_DIR/export-xdf).")
@clear_errors
def export(*, study_dir: str, out_dir: str | None, formats: tuple[str, ...], frames: bool, bids: bool, overwrite: bool,
           accept_damaged: bool, quiet: bool, xdf_file: str | None) -> None:
    """Export STUDY_DIR: trials, questionnaire, answers and scores tables (with the study's instrument
    files), frames, Motion-BIDS; or line up an XDF file."""
    if xdf_file is not None:
        _export_xdf(study_dir, Path(xdf_file), out=Path(out_dir) if out_dir else Path(study_dir) / "export-xdf",
                    formats=formats, overwrite=overwrite)
        return
    out = Path(out_dir) if out_dir else Path(study_dir) / "export"
    written = export_study(study_dir, out, formats=formats, frames=frames, bids=bids, overwrite=overwrite,
                           accept_damaged=accept_damaged, progress=not quiet, say=click.echo)
    click.echo(f"wrote {len(written)} files into {out}")


def _export_xdf(study_dir: str, xdf_file: Path, *, out: Path, formats: tuple[str, ...], overwrite: bool) -> None:
    from microg.study.xdf import line_up, write_lineups

    refuse_links(out)
    with open_study(study_dir, readonly=True) as store:
        lineups = line_up(store, xdf_file)
    for lineup in lineups:
        fit = lineup.fit
        click.echo(f"participant {lineup.participant}, session {lineup.session}: {len(fit.residuals)} of "
                   f"{len(lineup.markers)} markers matched; {fit.describe()}; max residual {fit.max_residual_ms:.3f} ms")
        if lineup.clock != "wall":
            click.echo(f"  note: this session ran on the {lineup.clock} clock, whose times are simulated seconds; "
                       "the task runs' LSL times come from their markers, but the fit and the MoCap samples' "
                       "study_t are only approximate")
        if lineup.mocap is None:
            click.echo(f"  note: {xdf_file} holds no MoCap stream of this session; no xdf_mocap rows for it")
    written = write_lineups(lineups, out, formats, overwrite)
    click.echo(f"wrote {len(written)} files into {out}")


COMMANDS = [export]
