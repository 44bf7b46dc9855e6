"""The study report: one self-contained HTML file (figures embedded), the tables as CSV, and the
figures as PNG and SVG."""

from __future__ import annotations

import base64
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import jinja2
import numpy as np
import pandas as pd
from markupsafe import Markup

from microg import __version__
from microg.analysis.analyse import (BETWEEN, EXCLUDED_STAGES, NORMALITY_ALPHA, SPHERICITY_ALPHA, WITHIN,
                                    StudyAnalysis, analyse_study)
from microg.analysis.anova import ANOVA_COLUMNS
from microg.analysis.figures import plot_bars, plot_ratings, save_figure
from microg.analysis.posthoc import POSTHOC_COLUMNS
from microg.analysis.tables import MEASURES
from microg.analysis.report_template import TEMPLATE

MEASURE_NAMES = {"time_s": "time", "attempts": "attempts"}
MEASURE_LABELS = {"time_s": "completion time (s)", "attempts": "attempts (drops)"}
SYSTEM_DESCRIPTIONS = {
    "impulse_penetration": "impulse + penetration contact model, the paper's method",
    "soft_hand": "compliant soft-hand coupling, standing in for the paper's comparison system",
    "penetration_only": "penetration phase only, the prior method the paper improves on",
}
REPORT_FILE = "report.html"
SIMULATED_TRIALS = "Simulated data: some or all trials come from simulated participants (a motor model), not people."
SIMULATED_RATINGS = "Simulated ratings: some or all questionnaire answers come from a rating model, not people."


def write_report(
    trials: pd.DataFrame | str | Path,
    questionnaire: pd.DataFrame | str | Path | None,
    out_dir: str | Path,
    system: str | None = None,
    baseline: str | None = None,
    ss_type: int = 3,
    excluded_stages: Sequence[str] = EXCLUDED_STAGES,
    title: str = "Study report",
) -> Path:
    """Analyse a study's tables and write ``out_dir``/report.html, the CSV tables and the figures.

    CSV files: anova_time.csv, anova_attempts.csv, posthoc_time.csv, posthoc_attempts.csv for the
    system under test (the same with a ``_<system>`` suffix for each other system), systems.csv,
    likert.csv (when a questionnaire is given) and dropped.csv. Returns the HTML file's path.
    """
    analysis = analyse_study(trials, questionnaire, system, baseline, ss_type, excluded_stages)
    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    write_tables(analysis, out)
    figures = write_figures(analysis, out / "figures")
    html = render_html(analysis, figures, title)
    path = out / REPORT_FILE
    path.write_text(html, encoding="utf-8")
    return path


def write_tables(analysis: StudyAnalysis, out: Path) -> list[Path]:
    """The CSV tables at full precision. An ANOVA the data cannot support (too few complete
    participants, or a measure without variation) is written with its sources and empty statistics;
    the report says why."""
    written = []
    not_estimable = pd.DataFrame({"source": [BETWEEN, WITHIN, f"{BETWEEN}:{WITHIN}"]}).reindex(columns=ANOVA_COLUMNS)
    for name, dv in ((name, dv) for name in analysis.systems for dv in MEASURES):
        suffix = "" if name == analysis.system else f"_{name}"
        anova = analysis.anova.get((name, dv), not_estimable)
        post = analysis.posthoc.get((name, dv), pd.DataFrame(columns=POSTHOC_COLUMNS))
        for kind, frame in (("anova", anova), ("posthoc", post)):
            path = out / f"{kind}_{MEASURE_NAMES[dv]}{suffix}.csv"
            frame.to_csv(path, index=False)
            written.append(path)
    if analysis.comparison is not None:
        analysis.comparison.to_csv(out / "systems.csv", index=False)
        written.append(out / "systems.csv")
    if analysis.likert_summary is not None:
        likert_table(analysis).to_csv(out / "likert.csv", index=False)
        written.append(out / "likert.csv")
    analysis.dropped.to_csv(out / "dropped.csv", index=False)
    return [*written, out / "dropped.csv"]


def likert_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Distribution per item and system, with the item's system-vs-baseline test on each row."""
    if analysis.likert_tests is None:
        return analysis.likert_summary
    tests = analysis.likert_tests.drop(columns=["median_system", "median_baseline"]).rename(
        columns={"system": "test_system", "baseline": "test_baseline", "n": "n_pairs"}
    )
    return analysis.likert_summary.merge(tests, on="item", how="left")


def write_figures(analysis: StudyAnalysis, folder: Path) -> list[dict]:
    """Bars per system and measure, and the rating distribution; PNG and SVG files."""
    figures = []
    for (name, dv), cells in analysis.cells.items():
        fig = plot_bars(cells, dv, analysis.posthoc[(name, dv)], ylabel=MEASURE_LABELS[dv], title=name)
        caption = (
            f"{MEASURE_LABELS[dv].capitalize()} with {name} per object and group, mean \u00b1 SE over participants; "
            "brackets mark Bonferroni-significant post hoc comparisons (* p < .05, ** p < .01, *** p < .001)"
        )
        figures.append(_figure(fig, folder / f"bars_{MEASURE_NAMES[dv]}_{name}", caption))
    if analysis.likert_summary is not None:
        fig = plot_ratings(analysis.likert_summary, title="Ratings (simulated)" if analysis.simulated_ratings else None)
        caption = "Distribution of the 0-10 ratings per item and system (diverging at the neutral 5)"
        figures.append(_figure(fig, folder / "ratings", caption))
    return figures


def render_html(analysis: StudyAnalysis, figures: list[dict], title: str) -> str:
    """The report page (jinja2), readable from the top: summary, methods, tables, figures."""
    environment = jinja2.Environment(
        autoescape=jinja2.select_autoescape(default=True), undefined=jinja2.StrictUndefined
    )
    template = environment.from_string(TEMPLATE)
    banners = ((analysis.simulated_trials, SIMULATED_TRIALS), (analysis.simulated_ratings, SIMULATED_RATINGS))
    return template.render(
        title=title,
        version=__version__,
        generated=datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
        simulated=[text for flag, text in banners if flag],
        simulated_ratings=SIMULATED_RATINGS if analysis.simulated_ratings else "",
        system=analysis.system,
        baseline=analysis.baseline,
        others=[name for name in analysis.systems if name not in (analysis.system, analysis.baseline)],
        descriptions={name: SYSTEM_DESCRIPTIONS.get(name, "") for name in analysis.systems},
        n_participants=sum(analysis.group_sizes.values()),
        group_sizes=", ".join(f"group {g}: {n}" for g, n in analysis.group_sizes.items()),
        objects=analysis.objects,
        excluded_stages=analysis.excluded_stages,
        warnings=analysis.warnings,
        dropped=_html(analysis.dropped) if len(analysis.dropped) else "",
        methods=methods(analysis),
        anovas=[
            {
                "title": f"{MEASURE_LABELS[dv].capitalize()}, {name}",
                "table": _html(table),
                "corrections": _html(analysis.corrections[(name, dv)]),
            }
            for (name, dv), table in analysis.anova.items()
        ],
        posthocs=[
            {"title": f"{MEASURE_LABELS[dv].capitalize()}, {name}", "table": _html(table)}
            for (name, dv), table in analysis.posthoc.items()
        ],
        table1=_html(table1(analysis)) if analysis.comparison is not None else "",
        comparison=_html(analysis.comparison) if analysis.comparison is not None else "",
        likert_summary=_html(analysis.likert_summary) if analysis.likert_summary is not None else "",
        likert_tests=_html(analysis.likert_tests) if analysis.likert_tests is not None else "",
        figures=figures,
    )


def table1(analysis: StudyAnalysis) -> pd.DataFrame:
    """The paper's Table 1 layout: mean +- SD of time and attempts for the system and the baseline."""
    comparison = analysis.comparison.set_index("measure")
    cells = {}
    for who, prefix in ((analysis.system, "system"), (analysis.baseline, "baseline")):
        cells[who] = {
            MEASURE_LABELS[dv]: f"{row[f'mean_{prefix}']:.1f} \u00b1 {row[f'sd_{prefix}']:.1f}"
            for dv, row in comparison.iterrows()
        }
    return pd.DataFrame(cells).T.rename_axis("system").reset_index()


def methods(analysis: StudyAnalysis) -> list[str]:
    """The method statements printed in the report."""
    ss = (
        "Type 3 sums of squares (sum-to-zero coding, equal weight per group; afex's default)"
        if analysis.ss_type == 3
        else "Type 2 sums of squares (groups weighted by size)"
    )
    return [
        (
            "Unit of analysis: one value per participant, system and object, the mean of that cell's trials. "
            "Completion time uses completed tasks only (an unfinished task has no time; it is not a zero); "
            "attempts use every task with a recorded count, completed or not. Withdrawn participants and "
            f"trials of the stage(s) {', '.join(analysis.excluded_stages) or '(none)'} are left out."
        ),
        (
            "A participant without a value for every object is left out of that system's ANOVA and post hoc "
            "tests and of the system-vs-baseline pairs (complete cases, as afex does); see Dropped participants."
        ),
        (
            f"Mixed ANOVA, group between x object within, per system and measure; {ss}, from the multivariate "
            "linear model of the wide data (as R's afex/car). Partial eta squared = SS / (SS + SS_error)."
        ),
        (
            "Sphericity: Mauchly's test and the Greenhouse-Geisser epsilon from the pooled within-group "
            "covariance (pingouin's mixed_anova, as afex). The Greenhouse-Geisser correction is applied to a "
            f"within effect when Mauchly's p < {SPHERICITY_ALPHA}; corrected df and p are listed for every "
            "within effect."
        ),
        (
            "Post hoc: pairwise object comparisons averaged over groups with equal weights, and group "
            "comparisons at each object, as emmeans on afex's multivariate model (t tests on the pooled "
            "within-group covariance, df = N - number of groups); Bonferroni within each family (all object "
            "pairs; all group pairs across objects). Stars: * p < .05, ** p < .01, *** p < .001 (corrected p)."
        ),
        (
            "System vs baseline: per participant, the mean over objects; mean and sample SD over participants; "
            "paired t-test with Cohen's d on the average SD; Wilcoxon signed-rank test (zero differences "
            "dropped; exact p below 50 pairs without ties, else normal approximation with continuity "
            "correction, as R's wilcox.test) with the rank-biserial correlation; Shapiro-Wilk on the paired "
            f"differences (p < {NORMALITY_ALPHA} prints a warning)."
        ),
        (
            "Likert: per item and system the distribution, median and quartiles (linear interpolation); "
            "Wilcoxon signed-rank test of the system vs the baseline on participants who rated both, "
            "r = z / sqrt(n) with z the normal approximation without continuity correction and n the non-zero "
            "differences; Bonferroni across items."
        ),
    ]


def _figure(fig, stem: Path, caption: str) -> dict:
    png, svg = save_figure(fig, stem)
    encoded = base64.b64encode(png.read_bytes()).decode("ascii")
    return {"png": encoded, "caption": caption, "files": f"figures/{png.name}, figures/{svg.name}"}


def _html(table: pd.DataFrame) -> Markup:
    return Markup(table.to_html(index=False, na_rep="", float_format=_number, border=0))


def _number(value: float) -> str:
    if not np.isfinite(value):
        return ""
    return f"{value:.4g}"
