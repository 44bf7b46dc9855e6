"""``microg report``: the statistics report of a study (HTML, CSV tables, figures)."""

from __future__ import annotations

from pathlib import Path

import click

from .common import ExistingPath, renamed, say_damage

FILE = ExistingPath(dir_okay=False, path_type=Path)


@click.command("report")
@click.argument("study", required=False, type=ExistingPath(file_okay=False, path_type=Path))
@click.option("--trials", type=FILE, help="Exported trials table (CSV or Parquet), instead of a STUDY folder.")
@click.option("--likert", type=FILE, help="Exported questionnaire table (CSV or Parquet), with --trials.")
@click.option("--answers", "answers_file", type=FILE,
              help="Answers table of the questionnaires' instruments (CSV or Parquet: participant, instrument, "
                   "item, value, and administration, interaction), with --trials.")
@click.option("--instrument", "instrument_files", multiple=True, type=FILE,
              help="An instrument file of your own that --answers names (repeatable); the shipped ones are known.")
@click.option("--compare", type=ExistingPath(file_okay=False, path_type=Path), default=None,
              help="Another run set of the same tasks (a re-simulation: STUDY/resimulated/LABEL, or its export): "
                   "also writes OUT/comparison.md and its CSVs, the two side by side.")
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output directory.")
@click.option("--participant", default=None,
              help="Instead of the study's report, one trainee's page of a training program (OUT/trainee-ID.html): "
                   "their learning curve against the criterion and their group's band, their sessions and tasks "
                   "to criterion, and what is due next. Needs a STUDY folder.")
@click.option("--interaction", default=None,
              help="Interaction model under test (default: impulse_penetration, else the first listed).")
@click.option("--baseline", default=None, help="Baseline interaction model (default: soft_hand, else the next listed).")
@click.option("--ss-type", type=click.Choice(["2", "3"]), default="3", show_default=True, help="Sums-of-squares type.")
@click.option(
    "--exclude-phase",
    "excluded_phases",
    multiple=True,
    default=("training",),
    show_default=True,
    help="Leave out trials of this phase (repeatable).",
)
@click.option("--subject", default=None, help="Column of the participant id [participant].")
@click.option("--group", default=None, help="Column of the between-participant factor [group].")
@click.option("--within", default=None, help="Column of the within-participant factor [object].")
@click.option("--interaction-column", default=None, help="Column of the interaction model [interaction].")
@click.option("--dv", multiple=True, help="Column of a measure (repeatable) [time_s, attempts].")
@click.option("--count", "counts", multiple=True,
              help="A --dv that counts events, analysed also with a count model (repeatable) [attempts].")
@click.option("--drop-duplicates", is_flag=True,
              help="Drop rows that repeat an earlier row of their table in every column (the report says which) "
                   "instead of refusing the table.")
@click.option("--practice-column", "practice", default=None,
              help="Column of a task's place in the participant's session: the trial model's practice term and "
                   "random slope [task_index].")
@click.option("--pretest", default=None,
              help="A training program's pre-test session by name [the first session without a criterion].")
@click.option("--posttest", default=None,
              help="A training program's post-test session by name [the second-to-last session without a criterion].")
@click.option("--retention", default=None,
              help="A training program's retention test session by name [the last session without a criterion].")
@click.option("--columns", "columns_file", type=FILE,
              help="TOML file of column names (subject, group, within, interaction_column, dv, counts, completed, "
                   "phase, label, item, rating, practice); the options above win.")  # fmt: skip
@renamed("--system", "--interaction")
@renamed("--system-column", "--interaction-column")
def report(
    *, study: Path | None,
    trials: Path | None,
    participant: str | None,
    likert: Path | None,
    answers_file: Path | None,
    instrument_files: tuple[Path, ...],
    compare: Path | None,
    out: Path,
    interaction: str | None,
    baseline: str | None,
    ss_type: str,
    excluded_phases: tuple[str, ...],
    subject: str | None,
    group: str | None,
    within: str | None,
    interaction_column: str | None,
    dv: tuple[str, ...],
    counts: tuple[str, ...],
    drop_duplicates: bool,
    practice: str | None,
    pretest: str | None,
    posttest: str | None,
    retention: str | None,
    columns_file: Path | None,
) -> None:
    """Mixed ANOVA, post hoc tests, the trial model of every task, interaction model vs baseline, Likert
    analysis with the aligned rank transform, the questionnaires' scores and their comparisons, and
    figures of a study; for a training program (several sessions per participant, or phases trained to a
    criterion) also its learning curves, tasks to criterion and the pre-test, post-test and retention test.

    Give a STUDY folder (a study, or an export of one) or --trials (and optionally --likert, --answers). Writes
    OUT/report.html (self-contained),
    OUT/report.md (Results and tables as Markdown) and the tables as CSV next to them. Any tidy table
    works: name its columns with --subject, --group, --within, --interaction-column, --dv and --count, or
    in a --columns file.
    """
    from microg.analysis import AnalysisInputError, write_report
    from microg.study.export import kind_infos
    from microg.analysis.tables import read_columns

    try:
        columns = read_columns(columns_file) if columns_file is not None else {}
    except AnalysisInputError as error:
        raise click.ClickException(str(error)) from error
    given = {"subject": subject, "group": group, "within": within, "interaction_column": interaction_column,
             "dv": list(dv) or None, "counts": list(counts) or None, "practice": practice}  # fmt: skip
    columns.update({key: value for key, value in given.items() if value is not None})
    if "dv" in columns:
        columns.setdefault("counts", [])

    if study is not None and (trials is not None or likert is not None or answers_file is not None):
        raise click.UsageError("give either STUDY or --trials/--likert/--answers, not both")
    if study is None and trials is None:
        raise click.UsageError("give a STUDY folder, or --trials FILE (and optionally --likert FILE)")
    from microg.study.store import StoreError

    from microg.instruments import InstrumentError, load_instrument

    try:
        if study is not None:
            from microg.study.export import read_answers, read_tables
            from microg.study.store import DATABASE, open_study

            if (study / DATABASE).exists():
                with open_study(study, readonly=True) as store:  # a damaged log is refused, damaged frames named
                    say_damage(store)
            trials_table, questionnaire = read_tables(study)
            answers, instruments = read_answers(study)
            if questionnaire is not None and questionnaire.empty:
                questionnaire = None
        else:
            from microg.analysis.tables import read_table

            trials_table, questionnaire = trials, likert
            answers = read_table(answers_file) if answers_file is not None else None
            instruments = {i.id: i for i in map(load_instrument, instrument_files)}
    except (FileNotFoundError, StoreError, InstrumentError, AnalysisInputError) as error:
        raise click.ClickException(str(error)) from error
    if participant is not None:
        if study is None:
            raise click.UsageError("--participant writes a trainee's page from a STUDY folder")
        _trainee_page(study, trials_table, participant, out)
        return
    try:
        path = write_report(trials_table, questionnaire, out, interaction, baseline, int(ss_type), excluded_phases,
                            drop_duplicates=drop_duplicates, answers=answers, instruments=instruments,
                            training={key: value for key, value in (("pretest", pretest), ("posttest", posttest),
                                                                    ("retention", retention)) if value is not None},
                            kinds=kind_infos(), **columns)
    except AnalysisInputError as error:
        where = f"study {study}: " if study is not None else ""
        raise click.ClickException(f"{where}{error}") from error
    click.echo(f"report: {path}")
    click.echo(f"tables: {', '.join(sorted(p.name for p in out.glob('*.csv')))}")
    if compare is not None:
        from microg.analysis.compare import write_comparison
        from microg.study.export import read_tables

        try:
            other = read_tables(compare)[0]
        except (FileNotFoundError, StoreError) as error:
            raise click.ClickException(str(error)) from error
        click.echo(f"comparison: {write_comparison(trials_table, other, out, ('original', compare.name))}")


def _trainee_page(study: Path, trials_table, participant: str, out: Path) -> None:
    """One trainee's page; what is next and the criterion's limit come from the study's store."""
    import datetime

    from microg.analysis import AnalysisInputError
    from microg.analysis.trainee import write_trainee_page
    from microg.study.assignment import ParticipantError
    from microg.study.schedule import trainee_outlook
    from microg.study.store import DATABASE, open_study

    next_session, criterion_s = "", None
    if (study / DATABASE).exists():
        with open_study(study, readonly=True) as store:
            try:
                next_session, criterion_s = trainee_outlook(store, participant, datetime.date.today())
            except ParticipantError as error:
                raise click.ClickException(f"--participant {participant!r}: {error}") from None
    try:
        page = write_trainee_page(trials_table, participant, out, next_session=next_session, criterion_s=criterion_s)
    except AnalysisInputError as error:
        raise click.ClickException(f"study {study}: {error}") from error
    click.echo(f"trainee's page: {page}")


COMMANDS = [report]
