"""Statistics and reports for microg studies: reads tidy tables (trials, questionnaire, answers), never the
simulation. Like pingouin, every function takes a tidy DataFrame and the names of its columns and
returns one tidy DataFrame; the numbers match R (afex, emmeans, car, effectsize, geepack, ARTool,
lme4 and lmerTest, survival, nls)."""

from microg.analysis.analyse import StudyAnalysis, analyse_study, choose_interactions, kinds_present
from microg.analysis.anova import (
    ANOVA_COLUMNS,
    mixed_anova,
    partial_eta_squared_ci,
    sphericity_correction,
)
from microg.analysis.art import ART_COLUMNS, ART_CONTRAST_COLUMNS, art_anova, art_contrasts
from microg.analysis.assumptions import assumption_checks
from microg.analysis.counts import count_model
from microg.analysis.describe import cell_means
from microg.analysis.figures import plot_bars, plot_ratings, plot_scores
from microg.analysis.likert import likert_summary, likert_tests, unpaired_raters
from microg.analysis.mixed_model import COEFFICIENT_COLUMNS, MODEL_ANOVA_COLUMNS, TrialModel, trial_model
from microg.analysis.paired import (
    compare_interactions,
    paired_means,
    signed_rank,
    unpaired_participants,
)
from microg.analysis.posthoc import POSTHOC_COLUMNS, posthoc, simple_effects
from microg.analysis.questionnaires import (
    analyse_questionnaires,
    compare_scores,
    internal_consistency,
    score_changes,
    score_summary,
)
from microg.analysis.report import write_report
from microg.analysis.survival import kaplan_meier, logrank, median_survival
from microg.analysis.scoring import check_answers, missing_items, score_answers
from microg.analysis.tables import (
    AnalysisInputError,
    check_questionnaire,
    check_trials,
    complete_cases,
    incomplete_cases,
    participant_cells,
    read_questionnaire,
    read_trials,
)
from microg.analysis.training import (
    TrainingAnalysis,
    analyse_training,
    criterion_tasks,
    is_training,
    power_law_fits,
    practice_model,
    retention_loss,
    session_roles,
)

__all__ = [
    "ANOVA_COLUMNS",
    "ART_COLUMNS",
    "ART_CONTRAST_COLUMNS",
    "COEFFICIENT_COLUMNS",
    "MODEL_ANOVA_COLUMNS",
    "POSTHOC_COLUMNS",
    "AnalysisInputError",
    "StudyAnalysis",
    "TrainingAnalysis",
    "TrialModel",
    "analyse_questionnaires",
    "analyse_study",
    "analyse_training",
    "art_anova",
    "art_contrasts",
    "assumption_checks",
    "cell_means",
    "check_answers",
    "check_questionnaire",
    "check_trials",
    "choose_interactions",
    "compare_interactions",
    "compare_scores",
    "complete_cases",
    "count_model",
    "criterion_tasks",
    "incomplete_cases",
    "internal_consistency",
    "is_training",
    "kaplan_meier",
    "kinds_present",
    "likert_summary",
    "likert_tests",
    "logrank",
    "median_survival",
    "missing_items",
    "mixed_anova",
    "paired_means",
    "partial_eta_squared_ci",
    "participant_cells",
    "plot_bars",
    "plot_ratings",
    "plot_scores",
    "posthoc",
    "power_law_fits",
    "practice_model",
    "read_questionnaire",
    "read_trials",
    "retention_loss",
    "score_answers",
    "score_changes",
    "score_summary",
    "session_roles",
    "signed_rank",
    "simple_effects",
    "sphericity_correction",
    "trial_model",
    "unpaired_participants",
    "unpaired_raters",
    "write_report",
]
