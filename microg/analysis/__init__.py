"""Statistics and reports for microg studies: reads exported tidy tables (trials, questionnaire),
never the simulation. Functions take a tidy DataFrame and column names and return a tidy DataFrame,
like pingouin; numbers match R's afex and emmeans."""

from microg.analysis.analyse import StudyAnalysis, analyse_study, choose_systems
from microg.analysis.anova import ANOVA_COLUMNS, mixed_anova, sphericity_correction
from microg.analysis.figures import plot_bars, plot_ratings
from microg.analysis.likert import likert_summary, likert_tests
from microg.analysis.paired import compare_systems, paired_means, signed_rank
from microg.analysis.posthoc import POSTHOC_COLUMNS, posthoc
from microg.analysis.report import write_report
from microg.analysis.tables import (
    AnalysisInputError,
    check_questionnaire,
    check_trials,
    complete_cases,
    participant_cells,
    read_questionnaire,
    read_trials,
)

__all__ = [
    "ANOVA_COLUMNS",
    "POSTHOC_COLUMNS",
    "AnalysisInputError",
    "StudyAnalysis",
    "analyse_study",
    "check_questionnaire",
    "check_trials",
    "choose_systems",
    "compare_systems",
    "complete_cases",
    "likert_summary",
    "likert_tests",
    "mixed_anova",
    "paired_means",
    "participant_cells",
    "plot_bars",
    "plot_ratings",
    "posthoc",
    "read_questionnaire",
    "read_trials",
    "signed_rank",
    "sphericity_correction",
    "write_report",
]
