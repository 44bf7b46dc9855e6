"""The study report: one self-contained HTML page (figures embedded), the same Results and tables as
Markdown to paste into a manuscript, the tables as CSV at full precision, and the figures as PNG
and SVG."""

from __future__ import annotations

import base64
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path

import jinja2
import pandas as pd
from markupsafe import Markup

from microg import __version__
from microg.analysis import results as r
from microg.analysis.analyse import EXCLUDED_PHASES, PICK_AND_PLACE, StudyAnalysis, analyse_study, kinds_present
from microg.analysis.anova import ANOVA_COLUMNS, SPHERICITY_ALPHA
from microg.analysis.assumptions import BOX_M_ALPHA
from microg.analysis.figures import (
    plot_bars,
    plot_criterion,
    plot_learning_curves,
    plot_practice_means,
    plot_ratings,
    plot_scores,
    save_figure,
)
from microg.analysis.posthoc import POSTHOC_COLUMNS
from microg.analysis.questionnaires import ORDINAL_POINTS, QuestionnaireAnalysis, analyse_questionnaires
from microg.analysis.report_template import TEMPLATE
from microg.analysis.tables import read_table
from microg.schema import REPORT_FILE, KindInfo
from microg.analysis.training import (
    POWER_LAW_UPPER_C,
    PRACTICE,
    TrainingAnalysis,
    analyse_training,
    is_training,
)

MEASURE_FILES = {"time_s": "time"}
INTERACTION_DESCRIPTIONS = {
    "impulse_penetration": "impulse + penetration contact model, the paper's method",
    "soft_hand": "compliant soft-hand coupling, standing in for the paper's comparison interaction model",
    "penetration_only": "penetration phase only, the prior method the paper improves on",
}
MARKDOWN_FILE = "report.md"
TIDY_TABLES = {"sample": "sample", "cell_means": "cell_means", "corrections": "corrections",
               "simple_effects": "simple_effects", "simple_pairs": "simple_pairs", "assumptions": "assumptions",
               "count_model": "count_model", "trial_models": "trial_models", "trial_anova": "trial_model_anova",
               "trial_coefficients": "trial_model_coefficients", "trial_random": "trial_model_random"}
"""The tidy tables written as they are: StudyAnalysis field -> CSV file name."""
SIMULATED_TRIALS = "Simulated data: some or all trials come from simulated participants (a motor model), not people."
SIMULATED_RATINGS = "Simulated ratings: some or all questionnaire answers come from a rating model, not people."
NO_QUESTIONNAIRE = ("The study asks no questionnaire (its questionnaire table has no rows): the questionnaire's "
                    "sections are left out.")
"""How a reader sees a task kind other than the pick-and-place (whose sections read as they always did)."""
QUESTIONNAIRE_TABLES = {"scores": "scores", "summary": "score_summary", "consistency": "consistency"}
"""The questionnaire section's CSV files (the comparisons and changes go together into score_tests.csv)."""
TRAINING_FOLDER = "training"
TRAINING_TABLES = {"sessions": "sessions", "learning_curve": "learning_curve", "power_law": "power_law",
                   "group_curves": "group_curves", "criterion": "criterion", "kaplan_meier": "kaplan_meier",
                   "medians": "medians", "logrank": "logrank", "test_cells": "session_cells",
                   "test_cell_means": "session_cell_means", "test_anova": "session_anova",
                   "test_corrections": "session_corrections", "test_posthoc": "session_posthoc",
                   "retention": "retention"}
"""The training section's tidy tables (TrainingAnalysis field -> CSV file name in training/); its two
mixed models go to practice_model_*.csv and session_model_*.csv."""
TRAINING_COLUMNS = {"subject": "subject", "group": "group", "phase": "phase", "interaction_column": "interaction",
                    "completed": "completed", "alpha": "alpha"}
"""The report's column options (:func:`microg.analysis.analyse_study`'s) that the training section shares:
option -> :func:`microg.analysis.training.analyse_training`'s parameter."""


def write_report(
    trials: pd.DataFrame | str | Path,
    questionnaire: pd.DataFrame | str | Path | None,
    out_dir: str | Path,
    interaction: str | None = None,
    baseline: str | None = None,
    ss_type: int = 3,
    excluded_phases: Sequence[str] = EXCLUDED_PHASES,
    title: str = "Study report",
    answers: pd.DataFrame | None = None,
    instruments: dict | None = None,
    training: dict | None = None,
    kinds: Mapping[str, KindInfo] | None = None,
    **columns,
) -> Path:
    """Analyse a study's tables and write the report into ``out_dir``.

    Parameters
    ----------
    trials, questionnaire, interaction, baseline, ss_type, excluded_phases, kinds
        As for :func:`microg.analysis.analyse_study`.
    answers : pandas.DataFrame, optional
        The questionnaires' answers, one row per answer (:func:`microg.analysis.check_answers`): each
        instrument other than the paper's kind of 0-10 items (which ``questionnaire`` holds) gets its
        section (:func:`microg.analysis.questionnaires.analyse_questionnaires`).
    instruments : dict, optional
        The instruments of ``answers`` by id (a study's own); the shipped ones serve the rest.
    training : dict, optional
        Options of the training section (:func:`microg.analysis.training.analyse_training`: e.g.
        ``{"posttest": "post", "retention": "week"}``, or its session columns' names).
    out_dir : str or Path
        Folder for report.html, report.md, the CSV tables and figures/.
    title : str
        The report's title.
    **columns
        Column names and options passed to :func:`microg.analysis.analyse_study` (subject, group,
        within, interaction_column, dv, counts, completed, phase, label, item, rating, alpha).

    Returns
    -------
    Path
        The HTML file. Beside it: report.md (Results and tables as Markdown), the CSV tables
        (:func:`write_tables`) and figures/ (PNG and SVG).

    Notes
    -----
    A training program's trials table (a participant with several sessions, or a phase with a
    proficiency criterion: :func:`microg.analysis.training.is_training`) adds the training section:
    learning curves, tasks to criterion, and the pre-test, post-test and retention test
    (:func:`microg.analysis.training.analyse_training`), its CSV tables in training/. Any other table's
    report has no such section.

    A trials table whose analysed tasks are all pick-and-place (or that has no ``task_kind``) is
    analysed as one study. Otherwise each task kind is analysed apart
    (:func:`microg.analysis.analyse_study`'s ``kind``; pick-and-place first), its sections titled by
    the kind and its CSV tables in a folder named after it (the pick-and-place's where they always
    are); the questionnaire goes with the first kind. A questionnaire table without rows (a protocol
    that asks none) is no questionnaire, and the report says so.

    Examples
    --------
    >>> import tempfile
    >>> import pingouin as pg
    >>> from microg.analysis import write_report
    >>> data = pg.read_dataset("mixed_anova").assign(tool="s")
    >>> path = write_report(data, None, tempfile.mkdtemp(), subject="Subject", group="Group", within="Time",
    ...                     interaction_column="tool", dv=["Scores"], counts=[])
    >>> path.name, (path.parent / "report.md").exists()
    ('report.html', True)
    """
    no_questionnaire = ""
    if questionnaire is not None and not len(_table(questionnaire)):
        questionnaire, no_questionnaire = None, NO_QUESTIONNAIRE
    table = _table(trials)
    present = kinds_present(table, excluded_phases, columns.get("phase", "phase"))
    if set(present) <= {PICK_AND_PLACE}:
        analyses = [analyse_study(trials, questionnaire, interaction, baseline, ss_type, excluded_phases, **columns)]
    else:
        analyses = [analyse_study(trials, questionnaire if kind == present[0] else None, interaction, baseline,
                                  ss_type, excluded_phases, kind=kind, kinds=kinds, **columns)
                    for kind in present]  # fmt: skip
    analysis = analyses[0]
    program = None
    if is_training(table, columns.get("subject", "participant")):
        shared = {parameter: columns[option] for option, parameter in TRAINING_COLUMNS.items() if option in columns}
        source = "trials table" if isinstance(trials, pd.DataFrame) else str(trials)
        program = analyse_training(table, excluded_phases=excluded_phases, source=source,
                                   **{**shared, **(training or {})})  # fmt: skip
    found = None
    if answers is not None and len(answers):
        found = analyse_questionnaires(answers, instruments, analysis.interaction, analysis.baseline, analysis.alpha)
        found = found if found.instruments else None
    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    figures = []
    for each in analyses:
        folder = out if _plain(each) else out / each.kind
        folder.mkdir(exist_ok=True)
        write_tables(each, folder, found if each is analysis else None)
        figures += write_figures(each, out / "figures", found if each is analysis else None)
    if program is not None:
        write_training_tables(program, out / TRAINING_FOLDER)
        figures += write_training_figures(program, out / "figures")
    sections = merged_sections(analyses, found)
    sections["no_questionnaire"] = no_questionnaire
    sections["training"] = training_section(program) if program is not None else None
    if program is not None:
        sections["methods"] = sections["methods"] + training_methods(program)
    (out / MARKDOWN_FILE).write_text(render_markdown(analysis, title, sections), encoding="utf-8")
    path = out / REPORT_FILE
    path.write_text(render_html(analysis, figures, title, sections), encoding="utf-8")
    return path


def write_tables(analysis: StudyAnalysis, out: Path, found: QuestionnaireAnalysis | None = None) -> list[Path]:
    """The CSV tables at full precision; returns the files written.

    Per interaction model and measure (suffix ``_<interaction>`` for models other than the one under test):
    anova_<measure>.csv and posthoc_<measure>.csv. An ANOVA the data cannot support is written with
    its sources and empty statistics; the report says why. One tidy table each, with the columns
    interaction and measure: sample.csv (N per group in the data and in each analysis), cell_means.csv,
    corrections.csv, simple_effects.csv, simple_pairs.csv, assumptions.csv, count_model.csv, and the
    trial models (interaction "": every interaction model) trial_models.csv, trial_model_anova.csv,
    trial_model_coefficients.csv, trial_model_random.csv. Also interactions.csv (interaction model under
    test vs baseline), likert.csv, art_anova.csv and art_contrasts.csv (the questionnaire's aligned rank
    transform, per item), dropped.csv and conditions.csv (labels).
    With ``found`` (the questionnaires' analysis): scores.csv, score_summary.csv, score_tests.csv (the
    comparisons between interaction models and between administrations) and consistency.csv. For a
    task kind other than the pick-and-place: description.csv (the cell means of every measure, with
    or without an ANOVA).
    """
    a = analysis
    written = []
    sources = [a.group, a.within, f"{a.group}:{a.within}"]
    not_estimable = pd.DataFrame({"source": sources}).reindex(columns=ANOVA_COLUMNS)
    analysed = set(a.analysed())
    for name, dv in ((name, dv) for name in a.interactions for dv in a.measures):
        suffix = "" if name == a.interaction else f"_{name}"
        anova = a.table("anova", name, dv) if (name, dv) in analysed else not_estimable
        post = a.table("posthoc", name, dv) if (name, dv) in analysed else pd.DataFrame(columns=POSTHOC_COLUMNS)
        for kind, frame in (("anova", anova), ("posthoc", post)):
            written.append(_csv(frame, out / f"{kind}_{MEASURE_FILES.get(dv, dv)}{suffix}.csv"))
    for name, file in TIDY_TABLES.items():
        written.append(_csv(getattr(a, name), out / f"{file}.csv"))
    if not a.comparison.empty:
        written.append(_csv(a.comparison, out / "interactions.csv"))
    if not a.likert_summary.empty:
        written.append(_csv(likert_table(a), out / "likert.csv"))
    if not a.likert_art.empty:
        written.append(_csv(a.likert_art, out / "art_anova.csv"))
        written.append(_csv(a.likert_art_contrasts, out / "art_contrasts.csv"))
    written.append(_csv(a.conditions, out / "conditions.csv"))
    written.append(_csv(a.dropped, out / "dropped.csv"))
    if not _plain(a):
        written.append(_csv(a.description, out / "description.csv"))
    if found is not None:
        written += [_csv(getattr(found, name), out / f"{file}.csv") for name, file in QUESTIONNAIRE_TABLES.items()]
        tests = pd.concat([found.comparisons, found.changes], ignore_index=True)
        written.append(_csv(tests, out / "score_tests.csv"))
    return written


def likert_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Distribution per item and interaction model, with the item's test against the baseline on each row."""
    if analysis.likert_tests.empty:
        return analysis.likert_summary
    tests = analysis.likert_tests.drop(columns=["median_interaction", "median_baseline"]).rename(
        columns={"interaction": "test_interaction", "baseline": "test_baseline", "n": "n_pairs"}
    )
    item = analysis.likert_summary.columns[0]
    return analysis.likert_summary.merge(tests.rename(columns={"item": item}), on=item, how="left")


def write_figures(analysis: StudyAnalysis, folder: Path, found: QuestionnaireAnalysis | None = None) -> list[dict]:
    """Bars with each participant's point per interaction model and measure, the rating distribution, and
    each instrument's scores; a task kind's named after it."""
    a = analysis
    kind = "" if _plain(a) else f"{a.kind}_"
    figures = []
    for name, dv in a.analysed():
        cells, label = a.table("cells", name, dv), r.measure_label(dv, a.kind_info)
        fig = plot_bars(cells, "value", a.table("posthoc", name, dv), a.within, a.group, ylabel=label,
                        title=a.label(name))  # fmt: skip
        caption = (
            ("" if _plain(a) else f"{a.kind_info.title}: ")
            + f"{label.capitalize()} with {a.label(name)} per {a.within} and {a.group}: bars mean "
            "\u00b1 SE, dots individual participants (n per group in the legend); brackets mark "
            "Bonferroni-significant post hoc comparisons (* p < .05, ** p < .01, *** p < .001)"
        )
        figures.append(_figure(fig, folder / f"bars_{kind}{MEASURE_FILES.get(dv, dv)}_{name}", caption))
    if not a.likert_summary.empty:
        summary = a.likert_summary.copy()
        summary.iloc[:, 1] = summary.iloc[:, 1].map(a.label)
        fig = plot_ratings(summary, title="Ratings (simulated)" if a.simulated_ratings else None,
                           item=summary.columns[0], interaction=summary.columns[1])  # fmt: skip
        caption = "Distribution of the 0-10 ratings per item and interaction model (diverging at the neutral 5)"
        figures.append(_figure(fig, folder / "ratings", caption))
    for instrument in found.instruments if found is not None else ():
        fig = plot_scores(found.rows("scores", instrument.id), instrument.title,
                          dict(zip(a.conditions["interaction"], a.conditions["label"])))
        caption = (f"{instrument.title}: each scale per administration and interaction model, boxes median and "
                   "quartiles (whiskers to 1.5 IQR), dots individual participants")
        figures.append(_figure(fig, folder / f"scores_{instrument.id}", caption))
    return figures


def report_sections(analysis: StudyAnalysis, found: QuestionnaireAnalysis | None = None) -> dict:
    """Everything the HTML page and the Markdown file show, as text and display tables."""
    a = analysis
    blocks = []
    for name, dv in a.analysed():
        post = a.table("posthoc", name, dv)
        block = {
            "title": f"{r.measure_label(dv, a.kind_info).capitalize()}, {a.label(name)}",
            "results": r.anova_paragraph(a, name, dv),
            "assumptions": r.assumptions_paragraph(a, name, dv),
            "tables": [
                ("Cell means", r.cell_means_table(a, name, dv)),
                ("Mixed ANOVA", r.anova_table(a, name, dv)),
                ("Sphericity (GG: Greenhouse-Geisser, HF: Huynh-Feldt)", r.sphericity_table(a, name, dv)),
                ("Post hoc comparisons (Bonferroni within each family)", r.contrasts_table(a, post)),
                ("Assumption checks", r.assumptions_table(a, name, dv)),
            ],
        }  # fmt: skip
        if r.crossed_effect_significant(a, name, dv):
            block["tables"][4:4] = [
                (f"Simple effects of {a.within} in each {a.group}", r.simple_effects_table(a, name, dv)),
                (f"Pairs of {a.within} in each {a.group} (Bonferroni over all of them)",
                 r.contrasts_table(a, a.table("simple_pairs", name, dv))),
            ]  # fmt: skip
        if dv in a.counts and not a.table("count_model", name, dv).empty:
            block["tables"].append(
                ("Count model (an addition to the paper's analysis)", r.count_model_table(a, name, dv))
            )
        blocks.append(block)
    models = [
        {
            "title": f"{r.measure_label(dv, a.kind_info).capitalize()}, every finished task: linear mixed model",
            "results": r.trial_model_paragraph(a, dv),
            "tables": [
                ("Type 3 F tests (Satterthwaite df)", r.trial_anova_table(a, dv)),
                ("Coefficients (sum-to-zero coding)", r.trial_coefficients_table(a, dv)),
                ("Random effects", r.trial_random_table(a, dv)),
            ],
        }
        for dv in a.trial_models["measure"]
    ]
    comparison = []
    if not a.comparison.empty:
        comparison = [r.comparison_paragraph(a, dv) for dv in a.comparison["measure"]]
    art_cells = [
        (f"ART-C contrasts of {item}: {a.group} \u00d7 interaction model cells (Bonferroni over the pairs, in ranks)",
         r.art_cells(a, item))
        for item, tests in a.likert_art.groupby("item", sort=True)
        if tests["p_unc"].iloc[2] < a.alpha
    ]
    return {
        "objects": a.objects,
        "warnings": list(a.warnings),
        "kinds": [],
        "no_questionnaire": "",
        "training": None,
        "interactions": [
            f"{label} ({role})"
            + (f": {name}" if label != name else "")
            + (f", {INTERACTION_DESCRIPTIONS[name]}" if name in INTERACTION_DESCRIPTIONS else "")
            for name, label, role in a.conditions[["interaction", "label", "role"]].itertuples(index=False)
        ],
        "sample": r.sample_table(a),
        "dropped": r.dropped_table(a) if len(a.dropped) else None,
        "blocks": blocks,
        "models": models,
        "comparison": comparison,
        "table1": r.table1(a) if comparison else None,
        "ttests": r.ttest_table(a) if comparison else None,
        "wilcoxon": r.wilcoxon_table(a) if comparison else None,
        "likert": r.likert_paragraph(a) if not a.likert_tests.empty else "",
        "likert_distribution": r.likert_distribution_table(a) if not a.likert_summary.empty else None,
        "likert_tests": r.likert_analyse_batch(a) if not a.likert_tests.empty else None,
        "art": r.art_paragraph(a) if not a.likert_art.empty else "",
        "art_table": r.art_table(a) if not a.likert_art.empty else None,
        "art_cells": art_cells,
        "instruments": instrument_blocks(a, found),
        "simulated_answers": SIMULATED_RATINGS if found is not None and found.simulated else "",
        "methods": methods(a) + ([QUESTIONNAIRE_METHODS] if found is not None else []),
    }


def merged_sections(analyses: Sequence[StudyAnalysis], found: QuestionnaireAnalysis | None = None) -> dict:
    """The sections of each task kind's analysis (:func:`report_sections`) as one report: the first
    analysis's (with the questionnaire), then each other kind's blocks, models, comparisons, sample,
    exclusions and warnings after them; a kind other than the pick-and-place has its titles and rows
    prefixed by the kind and a description in ``kinds``."""
    merged = _kind_sections(analyses[0], report_sections(analyses[0], found))
    for analysis in analyses[1:]:
        more = _kind_sections(analysis, report_sections(analysis))
        for key in ("blocks", "models", "comparison", "warnings", "kinds"):
            merged[key] = merged[key] + more[key]
        merged["sample"] = pd.concat([merged["sample"], more["sample"]], ignore_index=True)
        listed = [table for table in (merged["dropped"], more["dropped"]) if table is not None]
        merged["dropped"] = pd.concat(listed, ignore_index=True) if listed else None
        merged["objects"] = tuple(sorted(set(merged["objects"]) | set(more["objects"])))
        merged["interactions"] = list(dict.fromkeys(merged["interactions"] + more["interactions"]))
        merged["methods"] = list(dict.fromkeys(merged["methods"] + more["methods"]))
    return merged


def _kind_sections(analysis: StudyAnalysis, sections: dict) -> dict:
    """``sections`` with a task kind's titles, table rows and warnings prefixed by the kind, and its
    description; the pick-and-place's as they are."""
    a = analysis
    if _plain(a):
        return sections
    title = a.kind_info.title
    prefixed = dict(sections)
    prefixed["blocks"] = [{**block, "title": f"{title}: {block['title']}"} for block in sections["blocks"]]
    prefixed["models"] = [{**block, "title": f"{title}: {block['title']}"} for block in sections["models"]]
    prefixed["comparison"] = [f"{title}: {text}" for text in sections["comparison"]]
    prefixed["warnings"] = [f"{title}: {text}" for text in sections["warnings"]]
    prefixed["interactions"] = [f"{title}: {text}" for text in sections["interactions"]]
    for key in ("sample", "dropped"):
        if sections[key] is not None:
            prefixed[key] = sections[key].assign(Analysis=f"{title}: " + sections[key]["Analysis"])
    analysed = sorted({r.measure_label(dv, a.kind_info) for _, dv in a.analysed()})
    not_tested = [text for text in a.warnings if text.startswith("No ") and " ANOVA for " in text]
    prefixed["kinds"] = [{
        "title": title,
        "text": (f"Measures: {', '.join(r.measure_label(dv, a.kind_info) for dv in a.measures)}. "
                 + (f"Mixed ANOVA of {', '.join(analysed)}." if analysed else
                    "No mixed ANOVA: the design does not allow one (below); the cell means describe the tasks.")),
        "notes": not_tested,
        "description": r.description_table(a),
    }]  # fmt: skip
    prefixed["methods"] = sections["methods"] + [KIND_METHODS]
    return prefixed


KIND_METHODS = (
    "Task kinds: the tasks of each kind (column task_kind) are analysed apart, by the same methods, with the kind's "
    "own measures besides completion time and attempts (catch: time to catch, to the grasp that caught the object; "
    "stop of a spin: time to rest, and flipped, whether the object turned over its spin axis; send: send error, "
    "the closest approach of the drift's line to the target's centre, and release speed error, the release speed "
    "minus the speed that reaches the target in the protocol's arrival time, which may be negative; handover: "
    "transfer time, from the second hand's hold to the first hand letting go, and the time both hands held the "
    "object). Flipped is a "
    "yes or no per task: a participant's cell is the proportion of its tasks that flipped, of every task with a value "
    "(completed or not), and it has no trial model. The cell means of every measure per group and object describe "
    "each kind, also where a mixed ANOVA cannot be made (one group or one object); the report then says so."
)


def _plain(analysis: StudyAnalysis) -> bool:
    """Whether an analysis reads as a pick-and-place study's always did (every task, or the pick-and-place's)."""
    return analysis.kind in (None, PICK_AND_PLACE)


def _table(table: pd.DataFrame | str | Path) -> pd.DataFrame:
    return table if isinstance(table, pd.DataFrame) else read_table(table)


QUESTIONNAIRE_METHODS = (
    "Questionnaires: each instrument scored by its published key (microg.analysis.scoring, the same function as "
    "microg questionnaire score and the export's scores.csv); a scale with an unanswered item is not scored. Per "
    "scale, administration and interaction model: n, mean, SD, median and quartiles (linear interpolation). Paired "
    "comparisons between the interaction model under test and the baseline in each administration, and of each "
    "later administration with the first (as SSQ post vs pre), on participants scored in both, by the test that "
    f"fits the scale: a single item of at most {ORDINAL_POINTS} points is ordinal (Wilcoxon signed-rank test, "
    "r_rb with its 95 % CI); a score of several items is compared by the paired t-test (d_z with its 95 % CI) unless "
    "the Shapiro-Wilk test rejects normal differences, then by the Wilcoxon test; p Bonferroni-corrected over the "
    "instrument's scales compared together. Internal consistency: Cronbach's alpha of each scale of two or more items "
    "(reversed items reversed) with its 95 % CI (Feldt's, pingouin), on participants who answered all its items."
)


def instrument_blocks(analysis: StudyAnalysis, found: QuestionnaireAnalysis | None) -> list[dict]:
    """One block per instrument: its title and source, the Results paragraphs and the tables."""
    if found is None:
        return []
    label = analysis.label
    blocks = []
    for instrument in found.instruments:
        tables = [("Scores per administration and interaction model", r.instrument_summary_table(found, instrument.id,
                                                                                                  label))]
        tests = r.instrument_tests_table(found, instrument.id, label)
        if len(tests):
            tables.append(("Paired comparisons (the test that fits the scale; differences first \u2212 second)", tests))
        consistency = r.consistency_table(found, instrument.id, label)
        if len(consistency):
            tables.append(("Internal consistency", consistency))
        blocks.append({"title": instrument.title, "source": instrument.source,
                       "results": r.instrument_paragraphs(found, instrument.id, label), "tables": tables})
    return blocks


def render_html(analysis: StudyAnalysis, figures: list[dict], title: str, sections: dict | None = None) -> str:
    """The report page (jinja2), readable from the top: summary, Results, methods, tables, figures.
    ``sections``: :func:`report_sections` of the analysis, when already made."""
    a = analysis
    environment = jinja2.Environment(
        autoescape=jinja2.select_autoescape(default=True), undefined=jinja2.StrictUndefined
    )
    environment.filters["html"] = _html
    banners = ((a.simulated_trials, SIMULATED_TRIALS), (a.simulated_ratings, SIMULATED_RATINGS))
    return environment.from_string(TEMPLATE).render(
        title=title,
        version=__version__,
        generated=datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
        simulated=[text for flag, text in banners if flag],
        simulated_ratings=SIMULATED_RATINGS if a.simulated_ratings else "",
        interaction=a.label(a.interaction),
        baseline=a.label(a.baseline) if a.baseline else "",
        within=a.within,
        excluded_phases=a.excluded_phases,
        figures=figures,
        **(sections or report_sections(a)),
    )


def render_markdown(analysis: StudyAnalysis, title: str, sections: dict | None = None) -> str:
    """The Results paragraphs and every table as Markdown, to paste into a manuscript."""
    a = analysis
    sections = sections or report_sections(a)
    lines = [f"# {title}", ""]
    if a.simulated_trials or a.simulated_ratings:
        lines += [f"> {text}" for flag, text in ((a.simulated_trials, SIMULATED_TRIALS),
                                                  (a.simulated_ratings, SIMULATED_RATINGS)) if flag] + [""]  # fmt: skip
    lines += [
        "## Participants",
        "",
        *[f"- {line}" for line in sections["interactions"]],
        "",
        markdown_table(sections["sample"]),
        "",
    ]
    if sections["dropped"] is not None:
        lines += ["Excluded participants:", "", markdown_table(sections["dropped"]), ""]
    if sections["kinds"]:
        lines += ["## Task kinds", ""]
    for kind in sections["kinds"]:
        lines += [f"### {kind['title']}", "", kind["text"], "", *[f"- {note}" for note in kind["notes"]], "",
                  "**Cell means per group and object**", "", markdown_table(kind["description"]), ""]
    lines += ["## Results", ""]
    for block in sections["blocks"]:
        lines += [f"### {block['title']}", "", block["results"], "", block["assumptions"], ""]
        for caption, table in block["tables"]:
            lines += [f"**{caption}**", "", markdown_table(table), ""]
    for block in sections["models"]:
        lines += [f"### {block['title']}", "", block["results"], ""]
        for caption, table in block["tables"]:
            lines += [f"**{caption}**", "", markdown_table(table), ""]
    if sections["comparison"]:
        lines += ["### Interaction model vs baseline (Table 1)", "", *[p + "\n" for p in sections["comparison"]]]
        for caption in ("table1", "ttests", "wilcoxon"):
            lines += [markdown_table(sections[caption]), ""]
    if sections["likert"]:
        lines += ["### Questionnaire", "", sections["likert"], "", markdown_table(sections["likert_tests"]), ""]
    if sections["art"]:
        lines += [sections["art"], "", markdown_table(sections["art_table"]), ""]
        for caption, table in sections["art_cells"]:
            lines += [f"**{caption}**", "", markdown_table(table), ""]
    if sections["likert_distribution"] is not None:
        lines += [markdown_table(sections["likert_distribution"]), ""]
    if sections["no_questionnaire"]:
        lines += ["### Questionnaire", "", sections["no_questionnaire"], ""]
    for block in sections["instruments"]:
        lines += [f"### {block['title']}", "", f"Source: {block['source']}", "", *[p + "\n" for p in block["results"]]]
        for caption, table in block["tables"]:
            lines += [f"**{caption}**", "", markdown_table(table), ""]
    if sections["training"] is not None:
        lines += ["## Training program", "", *[p + "\n" for p in sections["training"]["results"]]]
        for caption, table in sections["training"]["tables"]:
            lines += [f"**{caption}**", "", markdown_table(table), ""]
    lines += ["## Methods", "", *[f"- {line}" for line in sections["methods"]], ""]
    return "\n".join(lines)


def write_training_tables(training: TrainingAnalysis, out: Path) -> list[Path]:
    """The training section's CSV tables at full precision in ``out`` (training/); returns the files.

    sessions.csv (each session's order and role), learning_curve.csv (per group and practice),
    power_law.csv (per trainee), group_curves.csv and practice_model_{anova,coefficients,random}.csv
    (the learning curves' mixed model), criterion.csv (per trainee, session and phase: tasks to
    criterion), kaplan_meier.csv, medians.csv, logrank.csv, session_cells.csv, session_cell_means.csv,
    session_anova.csv, session_corrections.csv, session_posthoc.csv,
    session_model_{anova,coefficients,random}.csv and retention.csv; a table whose analysis did not
    apply has its header only.
    """
    out.mkdir(parents=True, exist_ok=True)
    written = [_csv(getattr(training, name), out / f"{file}.csv") for name, file in TRAINING_TABLES.items()]
    for prefix, model in (("practice_model", training.practice_model), ("session_model", training.session_model)):
        if model is not None:
            written += [_csv(getattr(model, part), out / f"{prefix}_{part}.csv")
                        for part in ("anova", "coefficients", "random")]  # fmt: skip
    return written


def write_training_figures(training: TrainingAnalysis, folder: Path) -> list[dict]:
    """The learning curves (time with the fits; attempts), the curves of reaching the criterion and the
    test sessions' bars."""
    t = training
    label = r.measure_label(t.dv)
    figures = []
    fig = plot_learning_curves(t.curve_tasks, t.power_law, t.group_curves, t.dv, PRACTICE, t.subject, t.group, label)
    figures.append(_figure(fig, folder / "training_learning_time",
                           f"Learning curves: {label} of every completed task against practice (tasks done), per "
                           f"{t.group}; thin lines each trainee's power law a + b \u00d7 practice^\u2212c, the thick "
                           "line the group's curve from the mixed model of log time on log practice"))
    fig = plot_practice_means(t.learning_curve, t.attempts, t.group, ylabel=r.measure_label(t.attempts))
    figures.append(_figure(fig, folder / "training_learning_attempts",
                           f"Learning curves: mean {r.measure_label(t.attempts)} per {t.group} at each amount of "
                           "practice, band \u00b1 SE (fewer trainees at more practice: those who met the criteria "
                           "sooner did fewer tasks)"))
    if len(t.criterion):
        fig = plot_criterion(t.kaplan_meier, t.criterion, (t.session, t.phase), t.group)
        figures.append(_figure(fig, folder / "training_criterion",
                               "Reaching the criterion: the share of each group that had met it against the tasks in "
                               "the phase (1 \u2212 the Kaplan-Meier curve), 95 % band shaded (R's log band); ticks "
                               "mark trainees who reached the phase's bound without it (censored)"))
    if len(t.test_posthoc):
        fig = plot_bars(t.test_cells, t.dv, t.test_posthoc, t.session, t.group, ylabel=label,
                        order=t.test_order())  # fmt: skip
        figures.append(_figure(fig, folder / "training_tests",
                               f"{label.capitalize()} in the test sessions per {t.group}: bars mean \u00b1 SE, dots "
                               "each trainee's mean; brackets mark Bonferroni-significant comparisons"))
    return figures


def training_section(training: TrainingAnalysis) -> dict:
    """The training section as the page and report.md show it: Results paragraphs and tables."""
    t = training
    tables = [("Sessions", r.training_sessions_table(t))]
    if t.practice_model is not None:
        tables += [("Learning curves: each group's curve (mixed model of log time on log practice)",
                    r.group_curves_table(t)),
                   ("Learning curves: type 3 F tests (Satterthwaite df)", r.model_tests_table(t.practice_model))]
    tables.append(("Learning curves: each trainee's power law, time = a + b \u00d7 practice^\u2212c",
                   r.power_law_table(t)))
    if len(t.medians):
        tables += [("Tasks to criterion (Kaplan-Meier; censored: the bound reached without the criterion)",
                    r.criterion_table(t)), ("Log-rank tests", r.logrank_table(t))]
    if len(t.test_anova):
        tables += [("Test sessions: means of the trainees' means", r.test_means_table(t)),
                   ("Test sessions: mixed ANOVA", r.anova_display(t.test_anova, t.test_corrections)),
                   ("Test sessions: post hoc comparisons (Bonferroni within each family)",
                    r.contrasts_display(t.test_posthoc, t.group))]
    if t.session_model is not None:
        tables.append(("Test sessions, every completed task: type 3 F tests (Satterthwaite df)",
                       r.model_tests_table(t.session_model)))
    if len(t.retention):
        tables.append(("Retention loss (paired, within each group)", r.retention_table(t)))
    return {"results": r.training_paragraphs(t), "notes": list(t.notes), "tables": tables}


def training_methods(training: TrainingAnalysis) -> list[str]:
    """The training section's method statements."""
    t = training
    roles = ", ".join(f"{role} {name}" for role, name in t.roles.items())
    return [
        (
            "Training program (microg.analysis.training): practice is the number of tasks a trainee had done, this "
            "one included, counted across their sessions in session order, then task order (a task that never ran, "
            "with no count of attempts, adds none). Learning curves: every completed task's time against practice. "
            "Each trainee's power law, time = a + b \u00d7 practice^\u2212c, by bounded nonlinear least squares "
            f"(a \u2265 0, b \u2265 0, 0 \u2264 c \u2264 {POWER_LAW_UPPER_C:g}; scipy's trust-region reflective "
            "least_squares, as R's nls with the port algorithm), standard errors as R's summary.nls. Each group's "
            "curve from a linear mixed model of log time on log practice with a random intercept and slope per "
            "trainee (the slope dropped when the fit is singular), REML, Satterthwaite df, as lme4/lmerTest; the "
            "group \u00d7 log practice term tests whether the groups learn at different rates."
        ),
        (
            "Tasks to criterion: per session and phase with a proficiency criterion, the task's place in the phase "
            "on which the criterion was first met; a trainee who reached the phase's bound without meeting it is "
            "censored at the tasks done. Kaplan-Meier curves per group with R's pointwise log band, S exp(\u00b1z "
            "SE(log S)) with Greenwood's variance (survfit's default conf.type \"log\"); the median and its 95 % CI "
            "read off the curve and the band as R's quantile.survfit (where a curve is 0.5 over an interval, its "
            "middle; \"not reached\" when a curve or bound never falls to 0.5). Log-rank test, as R's survdiff."
        ),
        (
            f"Tests: the sessions without a criterion, in order the first the pre-test, the second-to-last the "
            f"post-test, the last the retention test ({roles}). Each trainee's mean time of the session's completed "
            f"tasks; mixed ANOVA, {t.group} between x {t.session} within (type 3, as afex), with the "
            "Greenhouse-Geisser correction when Mauchly's test rejects sphericity, and Bonferroni-adjusted pairs "
            f"(as emmeans); a linear mixed model of every completed test task, log time ~ {t.group} * {t.session} "
            "with a random intercept per trainee (lmerTest). Retention loss: retention minus post-test per trainee, "
            "within each group a paired t-test with d_z and its CI, and the Wilcoxon signed-rank test."
        ),
    ]


def methods(analysis: StudyAnalysis) -> list[str]:
    """The method statements printed in the report."""
    a = analysis
    ss = (
        "Type 3 sums of squares (sum-to-zero coding, equal weight per group; afex's default)"
        if a.ss_type == 3
        else "Type 2 sums of squares (groups weighted by size)"
    )
    statements = [
        (
            f"Unit of analysis: one value per participant, interaction model and {a.within}, the mean of that cell's "
            "trials. Measures of finished tasks (completion time) use completed tasks only (an unfinished task has "
            "no time; it is not a zero); counts (drops) use every task with a recorded count, completed or not. "
            "Withdrawn "
            f"participants and trials of the phase(s) {', '.join(a.excluded_phases) or '(none)'} are left out."
        ),
        (
            f"A participant without a value for every {a.within} is left out of that interaction model's ANOVA and of "
            "the pairs against the baseline (complete cases, as afex does); every N in this report is the N analysed, "
            "and the excluded participants are listed with the reason."
        ),
        (
            f"Mixed ANOVA, {a.group} between x {a.within} within, per interaction model and measure; {ss}, from the "
            f"multivariate linear model of the wide data (as R's afex/car). Effect sizes: partial eta squared "
            f"({r.ETA_P}) with its 95 % CI from the noncentral F on the uncorrected df (R's effectsize), and "
            f"generalised eta squared ({r.ETA_G}, afex's default). "
            "An effect with a sum of squares of 0 has F = 0 and p = 1."
        ),
        (
            "Sphericity: Mauchly's test and the Greenhouse-Geisser epsilon from the pooled within-group covariance "
            "(as afex); the Huynh-Feldt epsilon by car's formula (its p uses min(1, epsilon)). The Greenhouse-Geisser "
            f"correction is applied to a within effect when Mauchly's p < {SPHERICITY_ALPHA}; both corrected p are "
            "listed for every within effect."
        ),
        (
            f"Post hoc: pairwise {a.within} comparisons averaged over {a.group}s with equal weights, and {a.group} "
            f"comparisons at each {a.within}, as emmeans on afex's multivariate model (t tests on the pooled "
            f"within-group covariance, df = N - number of {a.group}s); Bonferroni within each family (all {a.within} "
            f"pairs; all {a.group} pairs across {a.within}s); 95 % CIs Bonferroni-adjusted alike (unadjusted ones "
            "in the CSV). Stars: * p < .05, ** p < .01, *** p < .001 (corrected p)."
        ),
        (
            f"Simple effects, read when the interaction is significant at {a.alpha}: the effect of {a.within} within "
            f"each {a.group}, a Wald F test on the pooled covariance with df ({a.within} levels - 1, N - number of "
            f"{a.group}s), as emmeans' joint_tests, Bonferroni-adjusted over the {a.group}s; then the {a.within} "
            f"pairs within each {a.group}, Bonferroni-adjusted over all of them."
        ),
        (
            f"Assumptions: Levene's test of equal {a.group} variances at each {a.within} (centred on the median, "
            f"R's car::leveneTest default), Box's M test of equal covariance matrices (chi-square approximation, read "
            f"at {BOX_M_ALPHA}), Shapiro-Wilk test of the ANOVA's residuals (values minus their {a.group}'s mean "
            f"at each {a.within}); each at {a.alpha} unless stated, with what follows from it."
        ),
        (
            "Interaction model vs baseline: per participant, the mean over objects; mean and sample SD over "
            "participants; paired t-test with the 95 % CI of the difference, d_z (mean difference / SD of the "
            "differences) with its 95 % CI from the noncentral t, and Cohen's d on the average SD (d_av); Wilcoxon "
            "signed-rank test (zero differences dropped; exact p below 50 pairs without ties, else normal "
            "approximation with continuity correction, as R's wilcox.test) with the rank-biserial correlation r_rb "
            "and its 95 % CI (Fisher z, as R's effectsize); Shapiro-Wilk on the paired differences."
        ),
        (
            "Likert: per item and interaction model the distribution, median and quartiles (linear interpolation); "
            "Wilcoxon signed-rank test of the interaction model under test vs the baseline on participants who "
            "rated both, r = z / sqrt(n) with z the normal approximation without continuity correction and n the "
            "non-zero differences; Bonferroni across items."
        ),
    ]
    if not a.trial_models.empty:
        statements.append(
            f"Trial models (an addition to the paper's analysis): per measure of finished tasks, a linear mixed "
            f"model of every finished task of every interaction model (no averaging, no complete-case rule), "
            f"the measure log-transformed when every value is positive; fixed effects {a.group} x {a.within} x "
            "interaction model (sum-to-zero coding)"
            + (f" and practice ({a.practice}, the task's place in the session)" if a.practice else "")
            + "; a random intercept per participant"
            + (f" and a correlated random slope of {a.practice}, dropped when the fit is singular (lme4's rule)"
               if a.practice else "")
            + ". REML (statsmodels' MixedLM, finished to lme4's optimum); type 3 F tests and t tests with "
            "Satterthwaite df, as R's lmerTest."
        )
    if not a.likert_art.empty:
        statements.append(
            f"Aligned rank transform ANOVA of the ratings, {a.group} x interaction model per item (Wobbrock et al., "
            "CHI 2011; ARTool's alignment): each effect's aligned values ranked (ties averaged) and tested with the "
            f"type {a.ss_type} mixed ANOVA above, on the participants who rated every interaction model; ART-C contrasts "
            "(Elkin et al., UIST 2021) of the cells, on the pooled within-group covariance (df = N - number of "
            f"{a.group}s), Bonferroni over the pairs."
        )
    if a.counts:
        statements.append(
            "Counts (an addition to the paper's analysis): each task's count as Poisson with a log link, group x "
            f"{a.within} in sum-to-zero coding, the tasks of a participant correlated (GEE, exchangeable working "
            "correlation, robust standard errors; statsmodels, as R's geepack); Wald chi-square test per term. When "
            "some group x level cell has no event the interaction cannot be estimated and main effects are tested "
            "alone; when a whole group or level has none, no model is fitted."
        )
    return statements


def _csv(frame: pd.DataFrame, path: Path) -> Path:
    frame.to_csv(path, index=False)
    return path


def _figure(fig, stem: Path, caption: str) -> dict:
    png, svg = save_figure(fig, stem)
    encoded = base64.b64encode(png.read_bytes()).decode("ascii")
    return {"png": encoded, "caption": caption, "files": f"figures/{png.name}, figures/{svg.name}"}


def _html(table: pd.DataFrame) -> Markup:
    return Markup(table.to_html(index=False, na_rep="", border=0))


def markdown_table(table: pd.DataFrame) -> str:
    """A pipe table; cells padded so that the raw text reads as a table too."""
    cells = [list(map(str, table.columns))] + [["" if pd.isna(v) else str(v) for v in row] for row in table.to_numpy()]
    widths = [max(len(row[i]) for row in cells) for i in range(len(table.columns))]
    lines = ["| " + " | ".join(text.ljust(w) for text, w in zip(row, widths)) + " |" for row in cells]
    lines.insert(1, "|" + "|".join("-" * (w + 2) for w in widths) + "|")
    return "\n".join(lines).replace("\n\n", "\n")
