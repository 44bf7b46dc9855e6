"""``microg report``: the statistics report of a study (HTML, CSV tables, figures)."""

from __future__ import annotations

from pathlib import Path

import click

FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


@click.command("report")
@click.option("--trials", type=FILE, help="Exported trials table (CSV or Parquet).")
@click.option("--likert", type=FILE, help="Exported questionnaire table (CSV or Parquet).")
@click.option(
    "--study",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="A study directory; its tables are read with microg.study.export.read_tables.",
)
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output directory.")
@click.option("--system", default=None, help="System under test (default: impulse_penetration, else the first listed).")
@click.option("--baseline", default=None, help="Baseline system (default: soft_hand, else the next listed).")
@click.option("--ss-type", type=click.Choice(["2", "3"]), default="3", show_default=True, help="Sums-of-squares type.")
@click.option(
    "--exclude-stage",
    "excluded_stages",
    multiple=True,
    default=("training",),
    show_default=True,
    help="Leave out trials of this stage (repeatable).",
)
def report(
    trials: Path | None,
    likert: Path | None,
    study: Path | None,
    out: Path,
    system: str | None,
    baseline: str | None,
    ss_type: str,
    excluded_stages: tuple[str, ...],
) -> None:
    """Mixed ANOVA, post hoc tests, system vs baseline, Likert analysis and figures of a study.

    Give either --trials (and optionally --likert) or --study. Writes OUT/report.html (self-contained)
    and the tables as CSV next to it.
    """
    from microg.analysis import AnalysisInputError, write_report

    if study is not None and (trials is not None or likert is not None):
        raise click.UsageError("give either --study or --trials/--likert, not both")
    if study is None and trials is None:
        raise click.UsageError("give --trials FILE (and optionally --likert FILE) or --study DIR")
    if study is not None:
        from microg.study.export import read_tables

        try:
            trials_table, questionnaire = read_tables(study)
        except FileNotFoundError as error:
            raise click.ClickException(str(error)) from error
        if questionnaire is not None and questionnaire.empty:
            questionnaire = None
    else:
        trials_table, questionnaire = trials, likert
    try:
        path = write_report(trials_table, questionnaire, out, system, baseline, int(ss_type), excluded_stages)
    except AnalysisInputError as error:
        where = f"study {study}: " if study is not None else ""
        raise click.ClickException(f"{where}{error}") from error
    click.echo(f"report: {path}")
    click.echo(f"tables: {', '.join(sorted(p.name for p in out.glob('*.csv')))}")


COMMANDS = [report]
