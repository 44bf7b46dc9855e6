"""What a reader of the report reads: the Results paragraphs (APA style) and the tables with
readable headers and journal-formatted numbers, made from a :class:`StudyAnalysis`. The CSV files
keep the raw numbers at full precision."""

from __future__ import annotations

import numpy as np
import pandas as pd

from microg.analysis.analyse import PICK_AND_PLACE, StudyAnalysis
from microg.analysis.apa import (
    bounded,
    chi_square,
    degrees,
    f_test,
    interval,
    number,
    p_cell,
    p_value,
    t_test,
)
from microg.analysis.art import CELL_SEPARATOR
from microg.analysis.assumptions import BOX_M_ALPHA
from microg.analysis.likert import SCALE
from microg.analysis.questionnaires import PAIRED_T, QuestionnaireAnalysis
from microg.analysis.training import POWER_LAW_UPPER_C, TrainingAnalysis
from microg.schema import PICK_AND_PLACE as PICK_AND_PLACE_INFO, KindInfo

MEASURE_LABELS = {"time_s": "completion time (s)"}
ETA_P, ETA_G, EPSILON, CHI2 = "\u03b7p\u00b2", "\u03b7G\u00b2", "\u03b5", "\u03c7\u00b2"
MINUS = " \u2212 "
ALPHA_SIGN = "\u03b1"


def measure_label(dv: str, kind: KindInfo = PICK_AND_PLACE_INFO) -> str:
    """How a reader sees a measure of a task kind: "completion time (s)" for time_s, the attempts by
    what the kind counts, the kind's own measures by their labels, else the column's name."""
    if dv == "attempts":
        return f"attempts ({kind.attempts})"
    return {m.name: m.label for m in kind.measures}.get(dv, MEASURE_LABELS.get(dv, dv))


def sample_size(analysis: StudyAnalysis, kind: str, interaction: str = "", measure: str = "") -> str:
    """The N an analysis used, per group: "N = 28 (B: 14, V: 14)"."""
    rows = _rows(analysis.sample, kind, interaction, measure)
    groups = ", ".join(f"{g}: {n}" for g, n in zip(rows[analysis.group], rows["n"]))
    return f"N = {int(rows['n'].sum())} ({groups})"


def exclusions(analysis: StudyAnalysis, kind: str, interaction: str = "", measure: str = "") -> str:
    """Who an analysis left out and why, or "" when nobody."""
    rows = _rows(analysis.dropped, kind, interaction, measure)
    if rows.empty:
        return ""
    listed = "; ".join(f"{who} ({why})" for who, why in zip(rows[analysis.subject], rows["reason"]))
    return f"{len(rows)} excluded: {listed}"


def anova_paragraph(analysis: StudyAnalysis, interaction: str, dv: str) -> str:
    """The Results paragraph of one interaction's mixed ANOVA of ``dv``: N and who was excluded, the
    effects, post hoc tests, simple effects after a significant interaction and, for counts, the
    count model."""
    a = analysis
    anova = a.table("anova", interaction, dv).set_index("source")
    chosen = a.table("corrections", interaction, dv).set_index("source")
    cells = a.table("cells", interaction, dv)
    n_levels, n_groups = cells[a.within].nunique(), cells[a.group].nunique()
    left_out, label = exclusions(a, "ANOVA", interaction, dv), measure_label(dv, a.kind_info)
    text = [
        f"{label.capitalize()} with {a.label(interaction)}: {sample_size(a, 'ANOVA', interaction, dv)}"
        + (f"; {left_out}." if left_out else ".")
    ]
    if np.isclose(cells["value"].std(), 0):
        value = number(cells["value"].iloc[0])
        text.append(
            f"Every participant's {label} is {value}: the measure does not vary, so there is nothing "
            "to test (the ANOVA table reports F = 0 and p = 1 for each effect, as R does)."
        )
        return " ".join(text + _count_sentences(a, interaction, dv))
    group_by_within = f"{a.group}:{a.within}"
    names = {a.group: f"main effect of {a.group}", a.within: f"main effect of {a.within}",
             group_by_within: f"{a.group} \u00d7 {a.within} interaction"}  # fmt: skip
    effects = []
    for source in (a.group, a.within, group_by_within):
        row, choice = anova.loc[source], chosen.loc[source]
        wording = "a significant" if choice["p"] < a.alpha else "no significant"
        effect = (
            f"{wording} {names[source]}, {f_test(row['F'], choice['df1'], choice['df2'], choice['p'])}, "
            f"{ETA_P} = {bounded(row['np2'])}, 95 % CI {interval(row['np2_ci_low'], row['np2_ci_high'], bounded)}, "
            f"{ETA_G} = {bounded(row['ges'])}"
        )
        if choice["correction"] == "Greenhouse-Geisser":
            effect += f" (Greenhouse-Geisser corrected, {EPSILON} = {bounded(choice['epsilon'])})"
        effects.append(effect)
    text.append(
        f"A {n_groups} \u00d7 {n_levels} mixed ANOVA ({a.group} between, {a.within} within participants; type "
        f"{a.ss_type} sums of squares) showed {effects[0]}; {effects[1]}; and {effects[2]}."
    )
    significant = {source: chosen.loc[source, "p"] < a.alpha for source in chosen.index}
    text.extend(
        _posthoc_sentences(a, interaction, dv, significant[a.within],
                           significant[a.group] or significant[group_by_within])
    )
    if crossed_effect_significant(a, interaction, dv):
        text.extend(_simple_effect_sentences(a, interaction, dv))
    return " ".join(text + _count_sentences(a, interaction, dv))


def assumptions_paragraph(analysis: StudyAnalysis, interaction: str, dv: str) -> str:
    """The assumption checks of one interaction's ANOVA of ``dv`` in words, each with what follows from it."""
    return " ".join(_assumption_sentences(analysis, interaction, dv))


def crossed_effect_significant(analysis: StudyAnalysis, interaction: str, dv: str) -> bool:
    """Whether the crossed effect (the ``group:within`` term of the ANOVA with this interaction model)
    is significant: its p as read (corrected where sphericity is violated) below alpha."""
    chosen = analysis.table("corrections", interaction, dv).set_index("source")
    return bool(chosen.loc[f"{analysis.group}:{analysis.within}", "p"] < analysis.alpha)


def comparison_paragraph(analysis: StudyAnalysis, dv: str) -> str:
    """Interaction model vs baseline on ``dv`` (the paper's Table 1) in words."""
    a = analysis
    row = a.comparison.set_index("measure").loc[dv]
    left_out = exclusions(a, "pairs", a.interaction, dv)
    versus = f"{a.label(a.interaction)} vs {a.label(a.baseline)}"
    lead = f"{measure_label(dv, a.kind_info).capitalize()}, {versus}: {sample_size(a, 'pairs', a.interaction, dv)} pairs"
    text = [lead + (f"; {left_out}." if left_out else ".")]
    text.append(
        f"M = {number(row['mean_interaction'])} (SD = {number(row['sd_interaction'])}) vs "
        f"M = {number(row['mean_baseline'])} "
        f"(SD = {number(row['sd_baseline'])}); difference M = {number(row['mean_diff'])}, 95 % CI "
        f"{interval(row['diff_ci_low'], row['diff_ci_high'])}, {t_test(row['T'], row['dof'], row['p_t'])}, "
        f"d_z = {number(row['d_z'])}, 95 % CI {interval(row['d_z_ci_low'], row['d_z_ci_high'])}; Wilcoxon "
        f"signed-rank V = {number(row['V'], 1)}, p {p_value(row['p_wilcoxon'])}, r_rb = {bounded(row['rbc'])}, "
        f"95 % CI {interval(row['rbc_ci_low'], row['rbc_ci_high'], bounded)}."
    )
    if row["p_shapiro"] < a.alpha:
        text.append(
            f"The paired differences are far from normal (Shapiro-Wilk p {p_value(row['p_shapiro'])}): "
            "the Wilcoxon test is the one to read."
        )
    return " ".join(text)


def likert_paragraph(analysis: StudyAnalysis) -> str:
    """The questionnaire's tests in words (Bonferroni across items)."""
    a = analysis
    tests = a.likert_tests
    parts = [
        f"{row['item']} (n = {int(row['n'])}): Mdn = {number(row['median_interaction'], 1)} vs "
        f"{number(row['median_baseline'], 1)}, V = {number(row['V'], 1)}, p {p_value(row['p_bonf'])}, "
        f"r_rb = {bounded(row['rbc'])}, 95 % CI {interval(row['rbc_ci_low'], row['rbc_ci_high'], bounded)}"
        for _, row in tests.iterrows()
    ]
    return (
        f"Ratings of {a.label(a.interaction)} vs {a.label(a.baseline)} (Wilcoxon signed-rank tests on participants who "
        f"rated both; p Bonferroni-corrected over {len(tests)} items): " + "; ".join(parts) + "."
    )


def anova_table(analysis: StudyAnalysis, interaction: str, dv: str) -> pd.DataFrame:
    """The ANOVA table with readable headers; df and p are those of the test read (Greenhouse-Geisser
    corrected where sphericity is violated, as in the Results paragraph)."""
    return anova_display(analysis.table("anova", interaction, dv), analysis.table("corrections", interaction, dv))


def anova_display(table: pd.DataFrame, chosen: pd.DataFrame) -> pd.DataFrame:
    """A :func:`microg.analysis.mixed_anova` table with readable headers, df and p those of the test
    read (``chosen``, its :func:`microg.analysis.sphericity_correction`)."""
    return pd.DataFrame(
        {
            "Effect": _sources(table["source"]),
            "SS": table["SS"].map(number),
            "df": chosen["df1"].map(degrees),
            "df error": chosen["df2"].map(degrees),
            "MS": table["MS"].map(number),
            "F": table["F"].map(number),
            "p": chosen["p"].map(p_cell),
            ETA_P: table["np2"].map(bounded),
            f"{ETA_P} 95 % CI": [
                interval(lo, hi, bounded) for lo, hi in zip(table["np2_ci_low"], table["np2_ci_high"])
            ],
            ETA_G: table["ges"].map(bounded),
        }
    )


def sphericity_table(analysis: StudyAnalysis, interaction: str, dv: str) -> pd.DataFrame:
    """Mauchly's test, both epsilons with their corrected p, and the correction used, per within effect."""
    table = analysis.table("anova", interaction, dv).iloc[1:]
    chosen = analysis.table("corrections", interaction, dv).iloc[1:]
    return pd.DataFrame(
        {
            "Effect": _sources(table["source"]),
            "Mauchly's W": table["W_mauchly"].map(bounded),
            "p (Mauchly)": table["p_mauchly"].map(p_cell),
            f"{EPSILON} (GG)": table["eps_GG"].map(bounded),
            "p (GG)": table["p_GG"].map(p_cell),
            f"{EPSILON} (HF)": table["eps_HF"].map(bounded),
            "p (HF)": table["p_HF"].map(p_cell),
            "Correction used": chosen["correction"].to_numpy(),
        }
    )


def contrasts_table(analysis: StudyAnalysis, table: pd.DataFrame) -> pd.DataFrame:
    """Post hoc comparisons (or the simple effects' pairs) with readable headers."""
    return contrasts_display(table, analysis.group)


def contrasts_display(table: pd.DataFrame, group: str) -> pd.DataFrame:
    """A :func:`microg.analysis.posthoc` table with readable headers (``group`` the between factor)."""

    def comparison(row) -> str:
        pair = f"{row['A']}{MINUS}{row['B']}"
        if row["factor"] == group:
            return f"{pair} at {row['at']}"
        return pair if pd.isna(row["at"]) else f"{pair} in {group} {row['at']}"

    return pd.DataFrame(
        {
            "Comparison": table.apply(comparison, axis=1),
            "Estimate": table["estimate"].map(number),
            "SE": table["SE"].map(number),
            "t": table["T"].map(number),
            "df": table["df"].map(degrees),
            "p": table["p_unc"].map(p_cell),
            "p (Bonferroni)": table["p_bonf"].map(p_cell),
            "95 % CI (Bonferroni)": [interval(lo, hi) for lo, hi in zip(table["ci_low_bonf"], table["ci_high_bonf"])],
        }
    )


def simple_effects_table(analysis: StudyAnalysis, interaction: str, dv: str) -> pd.DataFrame:
    """The effect of the within factor in each group."""
    table = analysis.table("simple_effects", interaction, dv)
    return pd.DataFrame(
        {
            analysis.group.capitalize(): table["at"],
            "F": table["F"].map(number),
            "df": table["df1"].map(degrees),
            "df error": table["df2"].map(degrees),
            "p": table["p_unc"].map(p_cell),
            "p (Bonferroni)": table["p_bonf"].map(p_cell),
        }
    )


def assumptions_table(analysis: StudyAnalysis, interaction: str, dv: str) -> pd.DataFrame:
    """Each assumption check and what follows from it."""
    table = analysis.table("assumptions", interaction, dv)
    names = {"Levene": "Levene (median)", "Box's M": f"Box's M ({CHI2})", "Shapiro-Wilk of residuals": "Shapiro-Wilk W"}
    return pd.DataFrame(
        {
            "Check": table["check"].map(names),
            "At": table["at"],
            "Statistic": [
                bounded(v, 3) if c.startswith("Shapiro") else number(v)
                for c, v in zip(table["check"], table["statistic"])
            ],
            "df": [", ".join(d for d in (degrees(d1), degrees(d2)) if d) for d1, d2 in zip(table["df1"], table["df2"])],
            "p": table["p"].map(p_cell),
            "What follows": table["consequence"],
        }
    )


def count_model_table(analysis: StudyAnalysis, interaction: str, dv: str) -> pd.DataFrame:
    """The count model's Wald tests."""
    table = analysis.table("count_model", interaction, dv)
    return pd.DataFrame(
        {
            "Term": _sources(table["term"]),
            CHI2: table["chi2"].map(number),
            "df": table["df"].map(degrees),
            "p": table["p_unc"].map(p_cell),
        }
    )


def cell_means_table(analysis: StudyAnalysis, interaction: str, dv: str) -> pd.DataFrame:
    """Mean, SD, SE and n per group and level (share of zeros for counts)."""
    a = analysis
    table = a.table("cell_means", interaction, dv)
    shown = pd.DataFrame(
        {
            a.group.capitalize(): table[a.group],
            a.within.capitalize(): table[a.within],
            "n": table["n"].astype(int),
            "M": table["mean"].map(number),
            "SD": table["sd"].map(number),
            "SE": table["se"].map(number),
        }
    )
    if dv in a.counts:
        shown["% zero"] = (100 * table["share_zero"]).map(lambda v: number(v, 0))
    return shown


def description_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Mean, SD, SE and n of every interaction model and measure per group and level, whether or not an
    ANOVA could be made (a task kind's description)."""
    a = analysis
    table = a.description
    return pd.DataFrame(
        {
            "Interaction model": table["interaction"].map(a.label),
            "Measure": table["measure"].map(lambda m: measure_label(m, a.kind_info)),
            a.group.capitalize(): table[a.group],
            a.within.capitalize(): table[a.within],
            "n": table["n"].astype(int),
            "M": table["mean"].map(number),
            "SD": table["sd"].map(number),
            "SE": table["se"].map(number),
        }
    )


def table1(analysis: StudyAnalysis) -> pd.DataFrame:
    """The paper's Table 1 with its n: M (SD) of each measure for the interaction model under test and the baseline."""
    a = analysis
    comparison = a.comparison.set_index("measure")
    rows = []
    for who, prefix in ((a.interaction, "interaction"), (a.baseline, "baseline")):
        row = {"Interaction model": a.label(who)}
        for dv, values in comparison.iterrows():
            row[f"{measure_label(dv, a.kind_info)}, n"] = str(int(values["n"]))
            row[f"{measure_label(dv, a.kind_info)}, M (SD)"] = (
                f"{number(values[f'mean_{prefix}'])} ({number(values[f'sd_{prefix}'])})"
            )
        rows.append(row)
    return pd.DataFrame(rows)


def ttest_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Table 1's paired t-tests: difference with 95 % CI, t, p and effect sizes."""
    table = analysis.comparison
    return pd.DataFrame(
        {
            "Measure": table["measure"].map(lambda m: measure_label(m, analysis.kind_info)),
            "n": table["n"].astype(int),
            "Difference M": table["mean_diff"].map(number),
            "95 % CI": [interval(lo, hi) for lo, hi in zip(table["diff_ci_low"], table["diff_ci_high"])],
            "t": table["T"].map(number),
            "df": table["dof"].map(degrees),
            "p": table["p_t"].map(p_cell),
            "d_z [95 % CI]": _with_interval(table, "d_z", number),
            "d_av": table["cohen_d"].map(number),
        }
    )


def wilcoxon_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Table 1's Wilcoxon signed-rank tests with the rank-biserial correlation and normality of the differences."""
    table = analysis.comparison
    return pd.DataFrame(
        {
            "Measure": table["measure"].map(lambda m: measure_label(m, analysis.kind_info)),
            "n (non-zero)": [f"{int(n)} ({int(m)})" for n, m in zip(table["n"], table["n_nonzero"])],
            "V": table["V"].map(lambda v: number(v, 1)),
            "p": table["p_wilcoxon"].map(p_cell),
            "r_rb [95 % CI]": _with_interval(table, "rbc", bounded),
            "Shapiro-Wilk p of differences": table["p_shapiro"].map(p_cell),
        }
    )


def likert_distribution_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Median, quartiles, mean and the count of each rating, per item and interaction model."""
    table = analysis.likert_summary
    shown = pd.DataFrame(
        {
            "Item": table.iloc[:, 0],
            "Interaction model": table.iloc[:, 1].map(analysis.label),
            "n": table["n"].astype(int),
            "Mdn": table["median"].map(lambda v: number(v, 1)),
            "Q1-Q3": [f"{number(lo, 1)}-{number(hi, 1)}" for lo, hi in zip(table["q1"], table["q3"])],
            "M": table["mean"].map(number),
        }
    )
    for score in SCALE:
        shown[str(score)] = table[f"count_{score}"].astype(int)
    return shown


def likert_analyse_batch(analysis: StudyAnalysis) -> pd.DataFrame:
    """The per-item Wilcoxon tests."""
    table = analysis.likert_tests
    return pd.DataFrame(
        {
            "Item": table["item"],
            "n": table["n"].astype(int),
            f"Mdn {analysis.label(analysis.interaction)}": table["median_interaction"].map(lambda v: number(v, 1)),
            f"Mdn {analysis.label(analysis.baseline)}": table["median_baseline"].map(lambda v: number(v, 1)),
            "V": table["V"].map(lambda v: number(v, 1)),
            "z": table["z"].map(number),
            "p": table["p_unc"].map(p_cell),
            "p (Bonferroni)": table["p_bonf"].map(p_cell),
            "r": table["r"].map(bounded),
            "r_rb [95 % CI]": _with_interval(table, "rbc", bounded),
        }
    )


def instrument_paragraphs(found: QuestionnaireAnalysis, instrument: str, label) -> list[str]:
    """An instrument's comparisons in words: each pair of interaction models in an administration and each
    later administration against the first (e.g. SSQ post vs pre), then its internal consistency.
    ``label`` names an interaction model for the reader."""
    title = next(i.title for i in found.instruments if i.id == instrument)
    paragraphs = []
    for table in (found.rows("comparisons", instrument), found.rows("changes", instrument)):
        for (first, second, held), rows in table.groupby(["first", "second", "held"], sort=False):
            if rows["compared"].iloc[0] == "interaction":
                what = f"{label(first)} vs {label(second)} ({held})"
            else:
                what = f"{first} vs {second}" + (f", about {label(held)}" if held else "")
            parts = [_test_words(row) for _, row in rows.iterrows()]
            paragraphs.append(f"{title}, {what}; p Bonferroni-corrected over {len(rows)} scale(s): "
                              + "; ".join(parts) + ".")
    consistency = found.rows("consistency", instrument)
    if len(consistency):
        parts = [f"{row['scale']} ({_condition(row['administration'], row['interaction'], label)}, n = "
                 f"{int(row['n'])}, {int(row['items'])} items) {bounded(row['alpha'])} "
                 f"{interval(row['alpha_ci_low'], row['alpha_ci_high'], bounded)}"
                 for _, row in consistency.iterrows()]
        paragraphs.append(f"Internal consistency of the {title} (Cronbach's {ALPHA_SIGN} [95 % CI]): "
                          + "; ".join(parts) + ".")
    return paragraphs


def instrument_summary_table(found: QuestionnaireAnalysis, instrument: str, label) -> pd.DataFrame:
    """An instrument's scores per scale, administration and interaction model."""
    table = found.rows("summary", instrument)
    return pd.DataFrame(
        {
            "Scale": table["scale"],
            "Administration": table["administration"],
            "Interaction model": table["interaction"].map(lambda code: label(code) if code else ""),
            "n": table["n"].astype(int),
            "M": table["mean"].map(number),
            "SD": table["sd"].map(number),
            "Mdn": table["median"].map(number),
            "IQR [Q1, Q3]": [f"{number(iqr)} [{number(lo)}, {number(hi)}]"
                             for iqr, lo, hi in zip(table["iqr"], table["q1"], table["q3"])],
        }
    )


def instrument_tests_table(found: QuestionnaireAnalysis, instrument: str, label) -> pd.DataFrame:
    """An instrument's paired comparisons (interaction models, administrations) with the test read."""
    table = pd.concat([found.rows("comparisons", instrument), found.rows("changes", instrument)], ignore_index=True)

    def compared(row) -> str:
        if row["compared"] == "interaction":
            return f"{label(row['first'])}{MINUS}{label(row['second'])} ({row['held']})"
        return f"{row['first']}{MINUS}{row['second']}" + (f" ({label(row['held'])})" if row["held"] else "")

    return pd.DataFrame(
        {
            "Scale": table["scale"],
            "Compared": table.apply(compared, axis=1) if len(table) else [],
            "n": table["n"].astype(int),
            "Difference M [95 % CI]": [f"{number(d)} {interval(lo, hi)}" for d, lo, hi in
                                       zip(table["mean_diff"], table["diff_ci_low"], table["diff_ci_high"])],
            "Test": table["test"],
            "Statistic": [f"t({degrees(row['dof'])}) = {number(row['T'])}" if row["test"] == PAIRED_T
                          else f"V = {number(row['V'], 1)}" for _, row in table.iterrows()],
            "p": table["p"].map(p_cell),
            "p (Bonferroni)": table["p_bonf"].map(p_cell),
            "Effect [95 % CI]": [_effect(row) for _, row in table.iterrows()],
        }
    )


def consistency_table(found: QuestionnaireAnalysis, instrument: str, label) -> pd.DataFrame:
    """Cronbach's alpha of an instrument's multi-item scales."""
    table = found.rows("consistency", instrument)
    return pd.DataFrame(
        {
            "Scale": table["scale"],
            "Administration": table["administration"],
            "Interaction model": table["interaction"].map(lambda code: label(code) if code else ""),
            "n": table["n"].astype(int),
            "Items": table["items"].astype(int),
            f"Cronbach's {ALPHA_SIGN} [95 % CI]": _with_interval(table, "alpha", bounded),
        }
    )


def _test_words(row) -> str:
    """One comparison in APA style: the test read, its p (Bonferroni) and effect size."""
    if row["test"] == PAIRED_T:
        return (f"{row['scale']} (n = {int(row['n'])}): M = {number(row['mean_first'])} (SD = "
                f"{number(row['sd_first'])}) vs M = {number(row['mean_second'])} (SD = {number(row['sd_second'])}), "
                f"{t_test(row['T'], row['dof'], row['p_bonf'])}, d_z = {number(row['d_z'])}, 95 % CI "
                f"{interval(row['d_z_ci_low'], row['d_z_ci_high'])}")
    return (f"{row['scale']} (n = {int(row['n'])}): Mdn = {number(row['median_first'], 1)} vs "
            f"{number(row['median_second'], 1)}, Wilcoxon signed-rank V = {number(row['V'], 1)}, p "
            f"{p_value(row['p_bonf'])}, r_rb = {bounded(row['rbc'])}, 95 % CI "
            f"{interval(row['rbc_ci_low'], row['rbc_ci_high'], bounded)}")


def _effect(row) -> str:
    if row["test"] == PAIRED_T:
        return f"d_z = {number(row['d_z'])} {interval(row['d_z_ci_low'], row['d_z_ci_high'])}"
    return f"r_rb = {bounded(row['rbc'])} {interval(row['rbc_ci_low'], row['rbc_ci_high'], bounded)}"


def _condition(administration: str, interaction: str, label) -> str:
    return ", ".join(part for part in (administration, label(interaction) if interaction else "") if part)


def sample_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """The participants each analysis used, per group (the effective N), beside those in the data."""
    a = analysis
    keys = a.sample[["analysis", "interaction", "measure"]].drop_duplicates()
    names = {
        "data": "in the data",
        "ANOVA": "mixed ANOVA",
        "pairs": "interaction model vs baseline",
        "Likert": "questionnaire item",
        "ART": "aligned rank transform ANOVA, item",
    }
    rows = []
    for kind, interaction, measure in keys.itertuples(index=False):
        what = names[kind] if kind not in ("Likert", "ART") else f"{names[kind]} {measure}"
        if kind in ("ANOVA", "pairs"):
            what += f", {measure_label(measure, a.kind_info)}"
        if kind == "ANOVA":
            what += f", {a.label(interaction)}"
        rows.append({"Analysis": what,
                     "N (per group)": sample_size(a, kind, interaction, measure).removeprefix("N = ")})
    return pd.DataFrame(rows)


def dropped_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """Who was left out of which analysis, and why."""
    a = analysis
    table = a.dropped
    what = []
    for kind, interaction, measure in table[["analysis", "interaction", "measure"]].itertuples(index=False):
        label = a.label(interaction) if interaction else ""
        names = {
            "all": "all analyses",
            "ANOVA": f"mixed ANOVA, {measure_label(measure, a.kind_info)}, {label}",
            "pairs": f"interaction model vs baseline, {measure_label(measure, a.kind_info)}",
            "Likert": "questionnaire",
            "ART": f"aligned rank transform ANOVA, item {measure}",
        }
        what.append(names[kind])
    return pd.DataFrame({"Analysis": what, a.subject.capitalize(): table[a.subject], "Reason": table["reason"]})


def trial_model_paragraph(analysis: StudyAnalysis, dv: str) -> str:
    """The linear mixed model of every finished task of ``dv`` in words: what was fitted, its F tests and,
    when it has one, the practice slope."""
    a = analysis
    model = a.table("trial_models", "", dv).iloc[0]
    tests = a.table("trial_anova", "", dv)
    effects = []
    for name, row in zip(_model_sources(a, tests["source"]), tests.itertuples(index=False)):
        wording = "a significant" if row.p_unc < a.alpha else "no significant"
        effects.append(f"{wording} effect of {name}, {f_test(row.F, row.df1, row.df2, row.p_unc)}")
    text = [
        f"{measure_label(dv, a.kind_info).capitalize()}, every finished task (a linear mixed model beside the ANOVA of "
        f"participant means, an addition to the paper's analysis): {int(model['n_trials'])} tasks of "
        f"{int(model['n_subjects'])} participants, {model['formula']} (REML; type 3 F tests with Satterthwaite df; "
        f"{model['note']}). It showed " + "; ".join(effects) + "."
    ]
    if a.practice is not None:
        slope = a.table("trial_coefficients", "", dv).set_index("term").loc[a.practice]
        test = t_test(slope["t"], slope["df"], slope["p_unc"])
        measure = measure_label(dv, a.kind_info).split(" (")[0]
        if model["formula"].startswith("log("):
            text.append(
                f"Practice: each further task multiplied the {measure} by {number(np.exp(slope['estimate']), 3)} "
                f"(b = {number(slope['estimate'], 3)} on the log scale, SE = {number(slope['SE'], 3)}, {test})."
            )
        else:
            text.append(f"Practice: each further task changed the {measure} by b = {number(slope['estimate'])} "
                        f"(SE = {number(slope['SE'])}, {test}).")
    return " ".join(text)


def trial_anova_table(analysis: StudyAnalysis, dv: str) -> pd.DataFrame:
    """The trial model's type 3 F tests."""
    table = analysis.table("trial_anova", "", dv)
    return pd.DataFrame({"Effect": _model_sources(analysis, table["source"]), "F": table["F"].map(number),
                         "df": table["df1"].map(degrees), "df error": table["df2"].map(degrees),
                         "p": table["p_unc"].map(p_cell)})  # fmt: skip


def trial_coefficients_table(analysis: StudyAnalysis, dv: str) -> pd.DataFrame:
    """The trial model's coefficients (sum-to-zero coding: ``group1`` is the first level's deviation)."""
    table = analysis.table("trial_coefficients", "", dv)
    return pd.DataFrame({"Term": table["term"], "Estimate": table["estimate"].map(lambda v: number(v, 3)),
                         "SE": table["SE"].map(lambda v: number(v, 3)), "df": table["df"].map(degrees),
                         "t": table["t"].map(number), "p": table["p_unc"].map(p_cell)})  # fmt: skip


def trial_random_table(analysis: StudyAnalysis, dv: str) -> pd.DataFrame:
    """The trial model's random effects and residual."""
    table = analysis.table("trial_random", "", dv)
    return pd.DataFrame({"Random effect": table["name"], "Variance": table["variance"].map(lambda v: number(v, 4)),
                         "SD": table["sd"].map(lambda v: number(v, 4)),
                         "Correlation": table["correlation"].map(bounded)})  # fmt: skip


def art_paragraph(analysis: StudyAnalysis) -> str:
    """The questionnaire's aligned rank transform ANOVAs in words, with the ART-C contrasts of the cells
    where group x interaction model is significant."""
    a = analysis
    names = [a.group, "interaction model", f"{a.group} \u00d7 interaction model"]
    parts = []
    for item, tests in a.likert_art.groupby("item", sort=True):
        effects = ", ".join(f"{name}, {f_test(row.F, row.df1, row.df2, row.p_unc)}"
                            for name, row in zip(names, tests.itertuples(index=False)))  # fmt: skip
        part = f"{item} ({sample_size(a, 'ART', '', item)}): {effects}"
        if tests["p_unc"].iloc[2] < a.alpha:
            pairs = _art_cell_rows(a, item)
            listed = "; ".join(
                f"{_cell(a, row.A)}{MINUS}{_cell(a, row.B)} = {number(row.estimate)}, {t_test(row.T, row.df, row.p_bonf)}"
                for row in pairs.itertuples(index=False)
            )
            part += f"; ART-C contrasts of the cells (Bonferroni over {len(pairs)} pairs, in ranks): {listed}"
        parts.append(part)
    return (
        f"Ratings by {a.group} and interaction model, aligned rank transform ANOVA per item (ARTool's alignment, "
        f"type {a.ss_type} mixed ANOVA of the aligned ranks): " + "; ".join(parts) + "."
    )


def art_table(analysis: StudyAnalysis) -> pd.DataFrame:
    """The aligned rank transform ANOVA of every item."""
    a = analysis
    table = a.likert_art
    names = [a.group, "interaction model", f"{a.group} \u00d7 interaction model"] * table["item"].nunique()
    return pd.DataFrame({"Item": table["item"], "Effect": names, "F": table["F"].map(number),
                         "df": table["df1"].map(degrees), "df error": table["df2"].map(degrees),
                         "p": table["p_unc"].map(p_cell)})  # fmt: skip


def art_cells(analysis: StudyAnalysis, item: str) -> pd.DataFrame:
    """The ART-C contrasts of one item's group x interaction model cells, each interaction model shown by
    its label."""
    a = analysis
    pairs = _art_cell_rows(a, item)
    return pd.DataFrame({
        "Comparison": [f"{_cell(a, x)}{MINUS}{_cell(a, y)}" for x, y in zip(pairs["A"], pairs["B"])],
        "Estimate (ranks)": pairs["estimate"].map(number), "SE": pairs["SE"].map(number),
        "t": pairs["T"].map(number), "df": pairs["df"].map(degrees), "p": pairs["p_unc"].map(p_cell),
        "p (Bonferroni)": pairs["p_bonf"].map(p_cell),
    })  # fmt: skip


def _art_cell_rows(a: StudyAnalysis, item: str) -> pd.DataFrame:
    table = a.likert_art_contrasts
    rows = table[(table["item"] == item) & table["term"].str.contains(":", regex=False)]
    return rows.reset_index(drop=True)


def _cell(a: StudyAnalysis, name: str) -> str:
    """An ART-C cell ("V,soft_hand") as a reader sees it: "V, <the interaction model's label>"."""
    group, interaction = name.split(CELL_SEPARATOR, 1)
    return f"{group}, {a.label(interaction)}"


def _posthoc_sentences(a: StudyAnalysis, interaction: str, dv: str, levels: bool, groups: bool) -> list[str]:
    table = a.table("posthoc", interaction, dv)
    sentences = []
    pairs = table[table["factor"] == a.within]
    if levels and len(pairs):
        sentences.append(
            f"Pairwise comparisons of {a.within} (averaged over {a.group}s; p and 95 % CIs Bonferroni-adjusted over "
            f"{len(pairs)} pairs): " + "; ".join(_contrast(row) for _, row in pairs.iterrows()) + "."
        )
    at_levels = table[table["factor"] == a.group]
    if groups and len(at_levels):
        sentences.append(
            f"{a.group.capitalize()} comparisons at each {a.within} (Bonferroni-adjusted over {len(at_levels)} "
            "comparisons): " + "; ".join(f"at {row['at']}, {_contrast(row)}" for _, row in at_levels.iterrows()) + "."
        )
    return sentences


def _simple_effect_sentences(a: StudyAnalysis, interaction: str, dv: str) -> list[str]:
    effects = a.table("simple_effects", interaction, dv)
    tests = "; ".join(
        f"{a.group} {row['at']}, {f_test(row['F'], row['df1'], row['df2'], row['p_bonf'])}"
        for _, row in effects.iterrows()
    )
    pairs = a.table("simple_pairs", interaction, dv)
    listed = "; ".join(f"in {row['at']}, {_contrast(row)}" for _, row in pairs.iterrows())
    return [
        (
            f"As the interaction was significant, the effect of {a.within} was tested within each {a.group} (Wald F on "
            f"the pooled covariance, as emmeans' joint tests; p Bonferroni-adjusted over the {len(effects)} "
            f"{a.group}s): {tests}. Pairwise comparisons of {a.within} within each {a.group} (Bonferroni-adjusted "
            f"over {len(pairs)} comparisons): {listed}."
        )
    ]


def _assumption_sentences(a: StudyAnalysis, interaction: str, dv: str) -> list[str]:
    checks = a.table("assumptions", interaction, dv)
    levene = checks[checks["check"] == "Levene"]
    tested = levene.dropna(subset=["p"])
    parts = []
    if len(tested):
        listed = "; ".join(
            f"{row['at']}, F({degrees(row['df1'])}, {degrees(row['df2'])}) = {number(row['statistic'])}, "
            f"p {p_value(row['p'])}"
            for _, row in tested.iterrows()
        )
        violated = tested[tested["violated"]]
        follows = (
            "; ".join(violated["consequence"])
            if len(violated)
            else f"equal variances of the {a.group}s are plausible at every {a.within}"
        )
        parts.append(f"Levene's test (median-centred) of the {a.group}s' variances: {listed}: {follows}.")
    for _, row in checks[checks["check"] != "Levene"].iterrows():
        if np.isnan(row["p"]):
            parts.append(f"{row['check']}: {row['consequence']}.")
        elif row["check"] == "Box's M":
            parts.append(
                f"Box's M: {chi_square(row['statistic'], row['df1'], row['p'])} (read at {bounded(BOX_M_ALPHA, 3)}): "
                f"{row['consequence']}."
            )
        else:
            parts.append(
                f"Shapiro-Wilk test of the ANOVA residuals: W = {bounded(row['statistic'], 3)}, p {p_value(row['p'])}: "
                f"{row['consequence']}."
            )
    return parts


def _count_sentences(a: StudyAnalysis, interaction: str, dv: str) -> list[str]:
    if dv not in a.counts:
        return []
    table = a.table("count_model", interaction, dv)
    if table.empty:
        return []
    first = table.iloc[0]
    zeros = f"{number(100 * first['share_zero'], 0)} % of them 0"
    lead = (
        f"In addition to the paper's analysis, the counts of the {int(first['n_tasks'])} tasks ({zeros}) of the "
        f"{int(first['n_subjects'])} participants were modelled with a Poisson GEE (log link, exchangeable correlation "
        "within participant, robust Wald tests)"
    )
    if first["model"] == "none":
        return [f"{lead}: {first['note']}."]
    tests = "; ".join(
        f"{name}, {chi_square(row['chi2'], row['df'], row['p_unc'])}"
        for name, (_, row) in zip(_sources(table["term"]), table.iterrows())
        if not np.isnan(row["chi2"])
    )
    correlation = f"estimated correlation {bounded(first['correlation'])}"
    extra = "" if first["model"] == "main effects and interaction" else f"; {first['note']}"
    return [f"{lead}; {correlation}{extra}: {tests}."]


def _with_interval(table: pd.DataFrame, column: str, format_one) -> list[str]:
    """ "estimate [low, high]" from the columns ``column``, ``column``_ci_low and ``column``_ci_high."""
    values = zip(table[column], table[f"{column}_ci_low"], table[f"{column}_ci_high"])
    return [f"{format_one(value)} {interval(low, high, format_one)}" for value, low, high in values]


def _contrast(row) -> str:
    return (
        f"{row['A']}{MINUS}{row['B']} = {number(row['estimate'])}, 95 % CI "
        f"{interval(row['ci_low_bonf'], row['ci_high_bonf'])}, p {p_value(row['p_bonf'])}"
    )


def _sources(sources: pd.Series) -> list[str]:
    return [source.replace(":", " \u00d7 ") for source in sources]


def _model_sources(a: StudyAnalysis, sources: pd.Series) -> list[str]:
    """A trial model's sources as a reader sees them: the interaction model's column named as such."""
    return [" \u00d7 ".join("interaction model" if part == a.interaction_column else part for part in source.split(":"))
            for source in sources]


def _rows(table: pd.DataFrame, kind: str, interaction: str, measure: str) -> pd.DataFrame:
    return table[(table["analysis"] == kind) & (table["interaction"] == interaction) & (table["measure"] == measure)]


# Training programs (microg.analysis.training)

NOT_REACHED = "not reached"


def training_paragraphs(training: TrainingAnalysis) -> list[str]:
    """The training section's Results in words: the learning curves, the tasks to criterion of each
    phase with one, the tests and the retention loss."""
    t = training
    paragraphs = [learning_paragraph(t)] if t.practice_model is not None else []
    for session, phase in t.medians[[t.session, t.phase]].drop_duplicates().itertuples(index=False):
        paragraphs.append(criterion_paragraph(t, session, phase))
    if len(t.test_anova):
        paragraphs.append(tests_paragraph(t))
    if t.session_model is not None:
        paragraphs.append(session_model_paragraph(t))
    if len(t.retention):
        paragraphs.append(retention_paragraph(t))
    return paragraphs


def learning_paragraph(training: TrainingAnalysis) -> str:
    """The learning curves: each group's curve from the mixed model of log time on log practice, the
    test of the groups' slopes, and the trainees' own power laws."""
    t = training
    model = t.practice_model
    label = measure_label(t.dv)
    curves = t.group_curves.set_index([t.group, "parameter"])
    parts = []
    for name in sorted(t.group_curves[t.group].unique()):
        slope = curves.loc[(name, "slope")]
        scale = np.exp(curves.loc[(name, "intercept"), "estimate"])
        parts.append(f"{t.group} {name}: {label.split(' (')[0]} = {number(scale)}"
                     f" \u00d7 practice^{number(slope['estimate'])} (slope b = {number(slope['estimate'], 3)}, "
                     f"SE = {number(slope['SE'], 3)}, {t_test(slope['t'], slope['df'], slope['p_unc'])})")
    tests = model.anova.set_index("source")
    crossed = tests.iloc[-1] if ":" in tests.index[-1] else None
    if crossed is not None:
        wording = "differed significantly" if crossed["p_unc"] < t.alpha else "did not differ significantly"
        test = f_test(crossed["F"], crossed["df1"], crossed["df2"], crossed["p_unc"])
        slopes = f" The groups' slopes {wording}, {test} ({_model_term(crossed.name)})."
    else:
        slopes = ""
    fits = t.power_law[t.power_law["converged"]]
    per_group = "; ".join(
        f"{name}, median c = {number(rows['c'].median())} (IQR {number(rows['c'].quantile(0.25))}-"
        f"{number(rows['c'].quantile(0.75))}, n = {len(rows)})" for name, rows in fits.groupby(t.group, sort=True))
    bounded_fits = int((fits["at_bound"] != "").sum())
    return (
        f"Learning curves ({label.split(' (')[0]} of every completed task against practice, the tasks a trainee had "
        "done; "
        f"{model.n_trials} tasks of {model.n_subjects} trainees): a linear mixed model, {model.formula} (REML; "
        f"Satterthwaite df; {model.note}), gave " + "; ".join(parts) + f".{slopes} "
        f"Each trainee's power law, time = a + b \u00d7 practice^\u2212c (bounded least squares; a, b \u2265 0, "
        f"0 \u2264 c \u2264 {POWER_LAW_UPPER_C:g}): {per_group}; {bounded_fits} of {len(fits)} fits at a bound."
    )


def criterion_paragraph(training: TrainingAnalysis, session: str, phase: str) -> str:
    """Tasks to criterion in one session's phase: who met it, the Kaplan-Meier medians with their 95 %
    CIs, and the log-rank test."""
    t = training
    medians = t.medians[(t.medians[t.session] == session) & (t.medians[t.phase] == phase)]
    tests = t.logrank[(t.logrank[t.session] == session) & (t.logrank[t.phase] == phase)]
    met = ", ".join(f"{int(row.events)} of {int(row.n)} in {row[t.group]}" for _, row in medians.iterrows())
    middles = "; ".join(f"{row[t.group]}, {median_text(row['median'], row['ci_low'], row['ci_high'])}"
                        for _, row in medians.iterrows())
    if len(tests):
        test = tests.iloc[0]
        wording = "differed significantly" if test["p_unc"] < t.alpha else "did not differ significantly"
        compared = f"The groups {wording}, log-rank {chi_square(test['chi2'], test['df'], test['p_unc'])}."
    else:
        compared = "No log-rank test (one group, or nobody met the criterion)."
    return (
        f"Tasks to criterion, {session} ({phase}): {met} met the criterion (the others censored at the tasks "
        f"they did). Kaplan-Meier median tasks to criterion: {middles}. {compared}"
    )


def median_text(median: float, low: float, high: float) -> str:
    """A median time to the criterion with its 95 % CI: "Mdn = 4.5, 95 % CI [3, not reached]".

    Examples
    --------
    >>> from microg.analysis.results import median_text
    >>> median_text(4.5, 3.0, float("nan")), median_text(float("nan"), 14.0, float("nan"))
    ('Mdn = 4.5, 95 % CI [3, not reached]', 'Mdn not reached, 95 % CI [14, not reached]')
    """
    head = "Mdn not reached" if pd.isna(median) else f"Mdn = {tasks_text(median)}"
    return f"{head}, 95 % CI [{tasks_text(low)}, {tasks_text(high)}]"


def tasks_text(value: float) -> str:
    """A number of tasks: whole, or with its half (a median between two tasks); "not reached" for none."""
    if pd.isna(value):
        return NOT_REACHED
    return f"{value:.0f}" if float(value).is_integer() else number(value, 1)


def tests_paragraph(training: TrainingAnalysis) -> str:
    """The test sessions' mixed ANOVA in words, with the pairs of sessions."""
    t = training
    anova = t.test_anova.set_index("source")
    chosen = t.test_corrections.set_index("source")
    crossed = f"{t.group}:{t.session}"
    names = {t.group: f"main effect of {t.group}", t.session: f"main effect of {t.session}",
             crossed: f"{t.group} \u00d7 {t.session} interaction"}  # fmt: skip
    effects = []
    for source in (t.group, t.session, crossed):
        row, choice = anova.loc[source], chosen.loc[source]
        wording = "a significant" if choice["p"] < t.alpha else "no significant"
        effect = (f"{wording} {names[source]}, {f_test(row['F'], choice['df1'], choice['df2'], choice['p'])}, "
                  f"{ETA_P} = {bounded(row['np2'])}, 95 % CI "
                  f"{interval(row['np2_ci_low'], row['np2_ci_high'], bounded)}, {ETA_G} = {bounded(row['ges'])}")
        if choice["correction"] == "Greenhouse-Geisser":
            effect += f" (Greenhouse-Geisser corrected, {EPSILON} = {bounded(choice['epsilon'])})"
        effects.append(effect)
    n_groups, n_sessions = t.test_cells[t.group].nunique(), t.test_cells[t.session].nunique()
    sizes = t.test_cells.drop_duplicates(t.subject).groupby(t.group).size()
    text = (f"Tests ({', '.join(t.test_order())}; each trainee's mean {measure_label(t.dv).split(' (')[0]} of the "
            f"session's completed tasks; N = {int(sizes.sum())}: "
            + ", ".join(f"{g}: {n}" for g, n in sizes.items())
            + f"): a {n_groups} \u00d7 {n_sessions} mixed ANOVA ({t.group} between, {t.session} within; type 3 sums "
            f"of squares) showed {effects[0]}; {effects[1]}; and {effects[2]}.")
    pairs = t.test_posthoc[t.test_posthoc["factor"] == t.session]
    if chosen.loc[t.session, "p"] < t.alpha and len(pairs):
        text += (f" Pairwise comparisons of {t.session} (averaged over {t.group}s; p and 95 % CIs Bonferroni-adjusted "
                 f"over {len(pairs)} pairs): " + "; ".join(_contrast(row) for _, row in pairs.iterrows()) + ".")
    return text


def session_model_paragraph(training: TrainingAnalysis) -> str:
    """The linear mixed model of every completed test task in words."""
    t = training
    model = t.session_model
    effects = []
    for row in model.anova.itertuples(index=False):
        wording = "a significant" if row.p_unc < t.alpha else "no significant"
        effects.append(f"{wording} effect of {_model_term(row.source)}, {f_test(row.F, row.df1, row.df2, row.p_unc)}")
    return (f"Every completed test task ({model.n_trials} tasks of {model.n_subjects} trainees), a linear mixed model "
            f"{model.formula} (REML; type 3 F tests with Satterthwaite df; {model.note}): " + "; ".join(effects) + ".")


def retention_paragraph(training: TrainingAnalysis) -> str:
    """The retention loss (retention minus post-test) of each group in words."""
    t = training
    parts = []
    for _, row in t.retention.iterrows():
        parts.append(
            f"{t.group} {row[t.group]} (n = {int(row['n'])}): M = {number(row['mean_posttest'])} vs "
            f"{number(row['mean_retention'])}, loss M = {number(row['mean_diff'])}, 95 % CI "
            f"{interval(row['diff_ci_low'], row['diff_ci_high'])}, {t_test(row['T'], row['dof'], row['p_t'])}, "
            f"d_z = {number(row['d_z'])}, 95 % CI {interval(row['d_z_ci_low'], row['d_z_ci_high'])}; Wilcoxon "
            f"signed-rank V = {number(row['V'], 1)}, p {p_value(row['p_wilcoxon'])}"
        )
    return (f"Retention loss ({t.roles['retention']}{MINUS}{t.roles['posttest']}, each trainee's mean "
            f"{measure_label(t.dv).split(' (')[0]}; paired tests within each {t.group}): " + "; ".join(parts) + ".")


def training_sessions_table(training: TrainingAnalysis) -> pd.DataFrame:
    """Each session in order, its role and whether it trains to a criterion."""
    table = training.sessions
    return pd.DataFrame({"Session": table[training.session], "Order": table["order"].astype(int),
                         "Role": table["role"], "Criterion": table["criterion"].map({True: "yes", False: "no"}),
                         "Trainees": table["participants"].astype(int)})  # fmt: skip


def group_curves_table(training: TrainingAnalysis) -> pd.DataFrame:
    """Each group's learning curve from the mixed model: time = exp(intercept) practice^slope."""
    t = training
    rows = []
    for name, part in t.group_curves.groupby(t.group, sort=True):
        curve = part.set_index("parameter")
        slope, intercept = curve.loc["slope"], curve.loc["intercept"]
        rows.append({t.group.capitalize(): name,
                     "Curve": f"{number(np.exp(intercept['estimate']))} \u00d7 practice^{number(slope['estimate'], 3)}",
                     "Intercept (log) [SE]": f"{number(intercept['estimate'], 3)} [{number(intercept['SE'], 3)}]",
                     "Slope [SE]": f"{number(slope['estimate'], 3)} [{number(slope['SE'], 3)}]",
                     "df": degrees(slope["df"]), "t": number(slope["t"]), "p": p_cell(slope["p_unc"])})
    return pd.DataFrame(rows)


def model_tests_table(model) -> pd.DataFrame:
    """A linear mixed model's type 3 F tests (:class:`microg.analysis.TrialModel`)."""
    table = model.anova
    return pd.DataFrame({"Effect": [_model_term(source) for source in table["source"]], "F": table["F"].map(number),
                         "df": table["df1"].map(degrees), "df error": table["df2"].map(degrees),
                         "p": table["p_unc"].map(p_cell)})  # fmt: skip


def power_law_table(training: TrainingAnalysis) -> pd.DataFrame:
    """Each trainee's power law of practice with the standard errors."""
    t = training
    table = t.power_law
    return pd.DataFrame({
        t.subject.capitalize(): table[t.subject], t.group.capitalize(): table[t.group], "Tasks": table["n"],
        "a [SE]": [f"{number(v)} [{number(se)}]" for v, se in zip(table["a"], table["a_se"])],
        "b [SE]": [f"{number(v)} [{number(se)}]" for v, se in zip(table["b"], table["b_se"])],
        "c [SE]": [f"{number(v, 3)} [{number(se, 3)}]" for v, se in zip(table["c"], table["c_se"])],
        "Residual SD": table["sigma"].map(number), "At a bound": table["at_bound"],
        "Note": table["note"],
    })  # fmt: skip


def criterion_table(training: TrainingAnalysis) -> pd.DataFrame:
    """Per session, phase and group: who met the criterion and the median tasks to it."""
    t = training
    table = t.medians
    return pd.DataFrame({
        "Session": table[t.session], "Phase": table[t.phase], t.group.capitalize(): table[t.group],
        "n": table["n"].astype(int), "Met the criterion": table["events"].astype(int),
        "Median tasks to criterion [95 % CI]": [
            f"{tasks_text(m)} [{tasks_text(lo)}, {tasks_text(hi)}]"
            for m, lo, hi in zip(table["median"], table["ci_low"], table["ci_high"])],
    })  # fmt: skip


def logrank_table(training: TrainingAnalysis) -> pd.DataFrame:
    """The log-rank test of each session's phase with a criterion."""
    t = training
    table = t.logrank
    return pd.DataFrame({"Session": table[t.session], "Phase": table[t.phase], CHI2: table["chi2"].map(number),
                         "df": table["df"].map(degrees), "p": table["p_unc"].map(p_cell),
                         "Trainees (met)": [f"{int(n)} ({int(e)})" for n, e in zip(table["n"], table["events"])]})


def test_means_table(training: TrainingAnalysis) -> pd.DataFrame:
    """Mean, SD and SE of the trainees' means per group and test session, in session order."""
    t = training
    order = {name: index for index, name in enumerate(t.test_order())}
    table = t.test_cell_means.assign(_order=t.test_cell_means[t.session].map(order)).sort_values(
        [t.group, "_order"])
    return pd.DataFrame({t.group.capitalize(): table[t.group], "Session": table[t.session],
                         "n": table["n"].astype(int), "M": table["mean"].map(number), "SD": table["sd"].map(number),
                         "SE": table["se"].map(number)})  # fmt: skip


def retention_table(training: TrainingAnalysis) -> pd.DataFrame:
    """Each group's retention loss with its paired tests."""
    t = training
    table = t.retention
    return pd.DataFrame({
        t.group.capitalize(): table[t.group], "n": table["n"].astype(int),
        f"M {t.roles.get('posttest', 'posttest')} (SD)": [
            f"{number(m)} ({number(sd)})" for m, sd in zip(table["mean_posttest"], table["sd_posttest"])],
        f"M {t.roles.get('retention', 'retention')} (SD)": [
            f"{number(m)} ({number(sd)})" for m, sd in zip(table["mean_retention"], table["sd_retention"])],
        "Loss M [95 % CI]": [f"{number(m)} {interval(lo, hi)}"
                             for m, lo, hi in zip(table["mean_diff"], table["diff_ci_low"], table["diff_ci_high"])],
        "t": table["T"].map(number), "df": table["dof"].map(degrees), "p": table["p_t"].map(p_cell),
        "d_z [95 % CI]": _with_interval(table, "d_z", number), "V": table["V"].map(lambda v: number(v, 1)),
        "p (Wilcoxon)": table["p_wilcoxon"].map(p_cell),
    })  # fmt: skip


def _model_term(source: str) -> str:
    return " \u00d7 ".join(part.replace("_", " ") for part in source.split(":"))
