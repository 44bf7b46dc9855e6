"""``microg questionnaire score``: questionnaire scores by the instruments' published keys, from a tidy
answers table (a study's export, or any survey tool's)."""

from __future__ import annotations

from pathlib import Path

import click


@click.group("questionnaire")
def questionnaire() -> None:
    """Score questionnaire answers (SSQ, IPQ, NASA-TLX, SUS, the paper's items, your own instruments)."""


@questionnaire.command("score")
@click.argument("answers_file", metavar="ANSWERS", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for scores.csv and missing.csv.")
@click.option("--instrument", "instrument_files", multiple=True,
              type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="An instrument file of your own (repeatable); its file name is its id in the answers' "
                   "instrument column. Shipped instruments: ssq, ipq, tlx, sus, paper.")
def score(answers_file: Path, out_dir: Path, instrument_files: tuple[Path, ...]) -> None:
    """Score ANSWERS (CSV or Parquet; columns participant, instrument, item, value and optionally
    administration, interaction) into OUT/scores.csv (participant, instrument, administration,
    interaction, scale, score). Items a scale needs but that were not answered are listed in
    OUT/missing.csv and here; their scales are left empty, never counted as zero."""
    from microg.analysis.scoring import missing_items, score_answers
    from microg.analysis.tables import AnalysisInputError, read_table
    from microg.instruments import InstrumentError, load_instrument

    try:
        instruments = {i.id: i for i in map(load_instrument, instrument_files)}
        answers = read_table(answers_file, text=("participant", "instrument", "item", "value", "administration",
                                                 "interaction"))
        scores = score_answers(answers, instruments, source=str(answers_file))
        missing = missing_items(answers, instruments, source=str(answers_file))
    except (AnalysisInputError, InstrumentError) as error:
        raise click.ClickException(str(error)) from None
    out_dir.mkdir(parents=True, exist_ok=True)
    scores.to_csv(out_dir / "scores.csv", index=False)
    missing.to_csv(out_dir / "missing.csv", index=False)
    for row in missing.itertuples(index=False):
        when = ", ".join(part for part in (row.administration, row.interaction) if part)
        click.echo(f"missing: participant {row.participant}, {row.instrument}{f' ({when})' if when else ''}: item "
                   f"{row.item} was not answered; {row.scales} not scored", err=True)
    click.echo(f"scored {scores['score'].notna().sum()} of {len(scores)} scales of "
               f"{scores.groupby(['participant', 'instrument', 'administration', 'interaction']).ngroups} "
               f"filled-in instruments into {out_dir / 'scores.csv'}")


COMMANDS = [questionnaire]
