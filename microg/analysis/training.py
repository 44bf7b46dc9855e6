"""A training program's analysis: several sessions per trainee, phases that repeat their task until a
proficiency criterion is met, and tests before, after and a while after the training.

From the trials table alone (its session columns: ``session``, ``session_index``, ``task_in_phase``,
``criterion_met``):

- learning curves: completion time and attempts of every task against practice, the number of tasks
  the trainee has done so far across their sessions (in session, then task order); per trainee a power law of
  practice, time = a + b practice^-c, by bounded nonlinear least squares (scipy's ``least_squares``,
  as R's ``nls(algorithm = "port")``); per group the curve of a linear mixed model of log time on
  log practice with a random intercept and slope per trainee (:func:`microg.analysis.trial_model`,
  as lme4/lmerTest), time = exp(intercept) practice^slope;
- tasks to criterion: per session and phase with a criterion, the place in the phase of the task
  that met it; a trainee who reached the phase's bound without it is censored at the tasks done.
  Kaplan-Meier curves, medians with R's intervals and the log-rank test by group
  (:mod:`microg.analysis.survival`);
- the test sessions (those without a criterion): in session order the first is the pre-test, the
  second-to-last the post-test and the last the retention test (with two, a pre-test and a post-test).
  The mixed ANOVA of each trainee's mean time per test session (group between, session within;
  :func:`microg.analysis.mixed_anova`) with its post hoc pairs, the linear mixed model of every
  completed test task with session as a factor, and per group the retention loss (retention minus
  post-test) with its paired tests (:func:`microg.analysis.compare_interactions`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize, stats

from microg.analysis.anova import ANOVA_COLUMNS, CORRECTION_COLUMNS, mixed_anova, sphericity_correction
from microg.analysis.describe import CELL_MEANS_COLUMNS, cell_means
from microg.analysis.mixed_model import TrialModel, fixed_design, parse_fixed, trial_model
from microg.analysis.paired import compare_interactions
from microg.analysis.posthoc import POSTHOC_COLUMNS, posthoc
from microg.analysis.survival import (
    KAPLAN_MEIER_COLUMNS,
    LOGRANK_COLUMNS,
    MEDIAN_COLUMNS,
    kaplan_meier,
    logrank,
    median_survival,
)
from microg.analysis.tables import (
    AnalysisInputError,
    check_training,
    check_trials,
    exclude_phases,
    is_simulated,
    withdrawn,
)

ALPHA = 0.05
PRACTICE = "practice"
"""The column :func:`add_practice` adds: the tasks a trainee has done so far, this one included."""
POWER_LAW_UPPER_C = 3.0
"""The power law's exponent c is searched in [0, POWER_LAW_UPPER_C]; a and b in [0, inf): a curve that
falls with practice towards an asymptote of 0 or more. Practice rarely gives exponents above 1
(Newell and Rosenbloom 1981: 0.2-0.8); 3 leaves room for a trainee who learns in a few tasks."""
POWER_LAW_COLUMNS = ("n", "a", "b", "c", "a_se", "b_se", "c_se", "rss", "sigma", "at_bound", "converged", "note")
CURVE_COLUMNS = ("measure", "n", "mean", "sd", "se")
GROUP_CURVE_COLUMNS = ("parameter", "estimate", "SE", "df", "t", "p_unc")
CRITERION_COLUMNS = ("tasks", "criterion_met", "tasks_to_criterion", "at_tasks")
RETENTION_COLUMNS = (
    "measure", "n", "mean_posttest", "sd_posttest", "mean_retention", "sd_retention", "mean_diff", "diff_ci_low",
    "diff_ci_high", "T", "dof", "p_t", "d_z", "d_z_ci_low", "d_z_ci_high", "cohen_d", "V", "p_wilcoxon", "rbc",
    "rbc_ci_low", "rbc_ci_high", "n_nonzero", "p_shapiro",
)  # fmt: skip
ROLES = ("pretest", "posttest", "retention")
MIN_POWER_LAW_TASKS = 4
"""A power law has three parameters: a trainee's fit needs a fourth task at least, and three
different amounts of practice."""
MIN_PAIRS = 3


@dataclass(frozen=True)
class TrainingAnalysis:
    """Every table of a training program's analysis, each a tidy DataFrame (see :func:`analyse_training`).

    ``sessions``: each session's order, whether it has a criterion and its role (pretest, training,
    posttest, retention, test). Learning curves: ``curve_tasks`` (the tasks that ran, with
    ``practice``; the time of completed ones only),
    ``learning_curve`` (per group and practice), ``power_law`` (per trainee), ``practice_model``
    (the linear mixed model) and ``group_curves`` (each group's intercept and slope on the log-log
    scale). Tasks to criterion: ``criterion`` (per trainee, session and phase), ``kaplan_meier``,
    ``medians`` and ``logrank`` (each keyed by session and phase). Tests: ``test_cells`` (each
    trainee's mean per test session), ``test_cell_means``, ``test_anova``, ``test_corrections``,
    ``test_posthoc``, ``session_model`` and ``retention`` (per group). A table with no rows means the
    analysis did not apply; ``notes`` says why.
    """

    subject: str
    group: str
    session: str
    phase: str
    dv: str
    attempts: str
    alpha: float
    simulated: bool
    roles: dict
    sessions: pd.DataFrame
    curve_tasks: pd.DataFrame
    learning_curve: pd.DataFrame
    power_law: pd.DataFrame
    practice_model: TrialModel | None
    group_curves: pd.DataFrame
    criterion: pd.DataFrame
    kaplan_meier: pd.DataFrame
    medians: pd.DataFrame
    logrank: pd.DataFrame
    test_cells: pd.DataFrame
    test_cell_means: pd.DataFrame
    test_anova: pd.DataFrame
    test_corrections: pd.DataFrame
    test_posthoc: pd.DataFrame
    session_model: TrialModel | None
    retention: pd.DataFrame
    notes: tuple[str, ...]

    def test_order(self) -> list[str]:
        """The test sessions analysed, in session order."""
        return [name for name in (self.roles.get(role) for role in ROLES) if name]


def is_training(trials: pd.DataFrame, subject: str = "participant", session_index: str = "session_index",
                criterion: str = "criterion_met") -> bool:
    """Whether a trials table is a training program's: a participant with several sessions, or a
    task of a phase with a criterion.

    Parameters
    ----------
    trials : pandas.DataFrame
        A trials table.
    subject, session_index, criterion : str
        The columns of the participant, the session's order for the participant and whether the
        phase's criterion was met (empty in a phase without one).

    Returns
    -------
    bool

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import is_training
    >>> paper = pd.DataFrame({"participant": ["P1", "P1"], "time_s": [30.0, 25.0]})
    >>> program = paper.assign(session_index=[1, 2])
    >>> is_training(paper), is_training(program)
    (False, True)
    """
    if session_index in trials.columns and subject in trials.columns:
        counts = trials.groupby(subject, observed=True)[session_index].nunique()
        if (counts > 1).any():
            return True
    if criterion in trials.columns:
        raw = trials[criterion]
        return bool((raw.notna() & (raw.astype(str).str.strip() != "")).any())
    return False


def add_practice(trials: pd.DataFrame, subject: str = "participant", session_index: str = "session_index",
                 task_index: str = "task_index", attempts: str = "attempts", practice: str = PRACTICE) -> pd.DataFrame:
    """The trials with ``practice``: the number of tasks the participant has done so far, this one
    included, counted across their sessions in session, then task order.

    A task that never ran (no count of attempts, as the export leaves it) adds no practice and has
    none.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task.
    subject, session_index, task_index, attempts : str
        The columns of the participant, the session's order, the task's place in its session and the
        count of attempts.
    practice : str
        Name of the column added.

    Returns
    -------
    pandas.DataFrame
        A copy with ``practice`` (Int64), in the original row order.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import add_practice
    >>> trials = pd.DataFrame({"participant": "P1", "session_index": [2, 1, 1, 2], "task_index": [0, 1, 0, 1],
    ...                        "attempts": [0, 1, None, 2]})
    >>> add_practice(trials)["practice"].tolist()
    [2, 1, <NA>, 3]
    """
    ran = trials[attempts].notna()
    order = trials.assign(_ran=ran.astype(int)).sort_values([subject, session_index, task_index], kind="stable")
    counted = order.groupby(subject, observed=True)["_ran"].cumsum()
    out = trials.copy()
    out[practice] = counted.reindex(trials.index).where(ran).astype("Int64")
    return out


def learning_curve(data: pd.DataFrame, measures: Sequence[str] = ("time_s", "attempts"), practice: str = PRACTICE,
                   group: str = "group") -> pd.DataFrame:
    """Mean, SD and SE of each measure per group and amount of practice (the group's learning curve as
    the tasks show it).

    Parameters
    ----------
    data : pandas.DataFrame
        One row per task with ``practice`` (:func:`add_practice`); a task without a value of a
        measure (an unfinished task's time) does not count for it.
    measures : sequence of str
        The measures' columns.
    practice, group : str
        The columns of the practice and the group.

    Returns
    -------
    pandas.DataFrame
        Columns ``group, practice, measure, n, mean, sd, se``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import learning_curve
    >>> tasks = pd.DataFrame({"group": "P", "practice": [1, 1, 2, 2], "time_s": [40.0, 50.0, 30.0, None],
    ...                       "attempts": [1, 0, 0, 2]})
    >>> learning_curve(tasks)[["practice", "measure", "n", "mean"]]
       practice  measure  n  mean
    0         1   time_s  2  45.0
    1         2   time_s  1  30.0
    2         1 attempts  2   0.5
    3         2 attempts  2   1.0
    """
    parts = []
    for measure in measures:
        rows = data[data[measure].notna() & data[practice].notna()]
        summary = rows.groupby([group, practice], observed=True)[measure].agg(n="count", mean="mean", sd="std",
                                                                              se="sem")  # fmt: skip
        parts.append(summary.reset_index().assign(measure=measure))
    columns = [group, practice, *CURVE_COLUMNS]
    return pd.concat(parts, ignore_index=True)[columns] if parts else pd.DataFrame(columns=columns)


def cohort_band(data: pd.DataFrame, dv: str = "time_s", practice: str = PRACTICE, group: str = "group",
                low: float = 0.1, high: float = 0.9) -> pd.DataFrame:
    """The cohort's band of ``dv`` at each amount of practice, per group: the ``low`` and ``high``
    quantiles and the median of the tasks with a value (a trainee's curve against it shows where they
    stand among their group).

    Parameters
    ----------
    data : pandas.DataFrame
        One row per task with ``practice`` (:func:`add_practice`).
    dv, practice, group : str
        The columns.
    low, high : float
        The band's quantiles (pandas' linear interpolation, R's type 7).

    Returns
    -------
    pandas.DataFrame
        Columns ``group, practice, n, low, median, high``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import cohort_band
    >>> tasks = pd.DataFrame({"group": "P", "practice": [1, 1, 1, 2], "time_s": [40.0, 50.0, 60.0, 30.0]})
    >>> cohort_band(tasks)[["practice", "n", "low", "median", "high"]]
       practice  n   low  median  high
    0         1  3  42.0    50.0  58.0
    1         2  1  30.0    30.0  30.0
    """
    rows = data[data[dv].notna() & data[practice].notna()]
    by = rows.groupby([group, practice], observed=True)[dv]
    table = by.agg(n="count", low=lambda v: v.quantile(low), median="median",
                   high=lambda v: v.quantile(high)).reset_index()
    return table[[group, practice, "n", "low", "median", "high"]]


def power_law_fits(data: pd.DataFrame, dv: str = "time_s", practice: str = PRACTICE, subject: str = "participant",
                   group: str = "group", upper_c: float = POWER_LAW_UPPER_C) -> pd.DataFrame:
    """Each participant's power law of practice, ``dv`` = a + b practice^-c, by bounded nonlinear least
    squares, as R's ``nls(dv ~ a + b * practice^-c, algorithm = "port")`` with the same bounds.

    The bounds: a >= 0 and b >= 0 (a time that falls towards an asymptote of 0 or more), c in [0,
    ``upper_c``]. The search (scipy's trust-region reflective ``least_squares`` with the analytic
    Jacobian) starts where R's is started: a0 = min / 2, and b0 and c0 from the straight line of
    log(dv - a0) on log(practice) (c0 kept 0.01 inside its bounds). Standard errors are R's
    ``summary.nls`` ones, sqrt(diag((J'J)^-1) rss / (n - 3)), J the Jacobian at the estimate.

    Parameters
    ----------
    data : pandas.DataFrame
        One row per task with a value of ``dv`` (completed tasks' times) and of ``practice``.
    dv, practice, subject, group : str
        The columns of the measure, the practice (1 or more), the participant and the group.
    upper_c : float
        Upper bound of the exponent.

    Returns
    -------
    pandas.DataFrame
        One row per participant: ``subject, group``, n (tasks), a, b, c, their standard errors
        a_se, b_se, c_se (empty when the Jacobian is singular, as at b = 0), rss (the residual sum
        of squares), sigma (sqrt(rss / (n - 3))), at_bound (the parameters at a bound, e.g. "c = 3",
        or ""), converged, and a note for a participant with too few tasks for a fit.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from microg.analysis.training import power_law_fits
    >>> practice = np.arange(1, 9)
    >>> noise = np.array([0.4, -0.3, 0.2, -0.1, 0.0, 0.3, -0.2, -0.1])
    >>> tasks = pd.DataFrame({"participant": "T1", "group": "P", "practice": practice,
    ...                       "time_s": 20 + 40 * practice ** -0.8 + noise})
    >>> power_law_fits(tasks)[["n", "a", "b", "c", "a_se", "converged"]].round(3)
       n       a       b      c   a_se  converged
    0  8  20.434  39.914  0.826  0.693       True
    """
    rows = []
    for (who, team), part in data.groupby([subject, group], observed=True, sort=True):
        part = part[part[dv].notna() & part[practice].notna()]
        x, y = part[practice].to_numpy(float), part[dv].to_numpy(float)
        fit = _power_law(x, y, upper_c)
        rows.append({subject: who, group: team, "n": len(x), **fit})
    return pd.DataFrame(rows, columns=[subject, group, *POWER_LAW_COLUMNS])


def practice_model(data: pd.DataFrame, dv: str = "time_s", practice: str = PRACTICE, subject: str = "participant",
                   group: str = "group") -> tuple[TrialModel, pd.DataFrame]:
    """The groups' learning curves: a linear mixed model of log ``dv`` on log practice with a random
    intercept and slope per participant, log(dv) ~ group * log(practice) + (1 + log(practice) |
    participant), as lme4/lmerTest (REML, sum-to-zero coding, Satterthwaite df; the random slope
    dropped when the fit is singular, :func:`microg.analysis.trial_model`).

    Each group's curve is dv = exp(intercept) practice^slope; its intercept and slope are contrasts of
    the fixed effects (lmerTest's estimates of ``log(dv) ~ 0 + group + group:log(practice)``).

    Parameters
    ----------
    data : pandas.DataFrame
        One row per task with a positive value of ``dv`` and ``practice`` (1 or more).
    dv, practice, subject, group : str
        The columns of the measure, the practice, the participant and the group.

    Returns
    -------
    tuple of (TrialModel, pandas.DataFrame)
        The model (its F tests: group, log practice and their crossed term, the difference between
        the groups' slopes; log practice alone for a single group), and per group its ``intercept``
        and ``slope`` (columns ``group, parameter, estimate, SE, df, t, p_unc``).

    Raises
    ------
    AnalysisInputError
        As :func:`microg.analysis.trial_model`.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from microg.analysis.training import practice_model
    >>> tasks = pd.DataFrame({"participant": np.repeat([f"T{i}" for i in range(8)], 10),
    ...                       "group": np.repeat(["B", "P"], 40), "practice": np.tile(np.arange(1, 11), 8)})
    >>> rate = np.where(tasks["group"] == "P", -0.5, -0.3) + np.repeat(np.linspace(-0.06, 0.06, 8), 10)
    >>> wiggle = 0.1 * np.sin(np.arange(80)) + np.repeat(0.1 * np.cos(np.arange(8)), 10)
    >>> tasks["time_s"] = 60 * tasks["practice"] ** rate * np.exp(wiggle)
    >>> model, curves = practice_model(tasks)
    >>> model.formula
    'log(time_s) ~ group * log_practice + (1 + log_practice | participant)'
    >>> curves[curves["parameter"] == "slope"][["group", "estimate", "SE"]].round(3)
      group  estimate     SE
    1     B    -0.330  0.018
    3     P    -0.474  0.018
    """
    logged = f"log_{practice}"
    rows = data.assign(**{logged: np.log(pd.to_numeric(data[practice]).astype(float))})
    levels = sorted(rows[group].astype(str).unique())
    fixed = f"{group} * {logged}" if len(levels) > 1 else logged  # one group: its curve alone
    model = trial_model(rows, dv, fixed, subject, "log", slope=logged)
    at = {value: pd.DataFrame({group: levels, logged: value}) for value in (0.0, 1.0)}
    terms = parse_fixed(fixed)
    factors = {group: levels} if len(levels) > 1 else {}
    design = {value: fixed_design(frame, terms, factors).sum_coded for value, frame in at.items()}
    contrasts = {"intercept": design[0.0], "slope": design[1.0] - design[0.0]}
    found = []
    for index, level in enumerate(levels):
        for parameter, matrix in contrasts.items():
            estimate, se, df = model.fit.satterthwaite(matrix[index])
            t = estimate / se
            found.append((level, parameter, estimate, se, df, t, float(2 * stats.t.sf(abs(t), df))))
    return model, pd.DataFrame(found, columns=[group, *GROUP_CURVE_COLUMNS])


def criterion_tasks(trials: pd.DataFrame, subject: str = "participant", group: str = "group",
                    session: str = "session", session_index: str = "session_index", phase: str = "phase",
                    task_in_phase: str = "task_in_phase", criterion: str = "criterion_met",
                    attempts: str = "attempts") -> pd.DataFrame:
    """Tasks to criterion: per participant, session and phase with a criterion, the place in the phase of
    the first task on which the criterion was met; one who never met it is censored at the tasks done.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task; ``criterion`` True or False in a phase with a criterion, empty elsewhere.
    subject, group, session, session_index, phase, task_in_phase, criterion, attempts : str
        The columns (a task that ran has a count of ``attempts``).

    Returns
    -------
    pandas.DataFrame
        Columns ``subject, group, session, session_index, phase, tasks`` (the phase's tasks done),
        criterion_met, tasks_to_criterion (Int64, empty when not met) and at_tasks (tasks to
        criterion, or the tasks done when censored: the time of the survival analysis).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import criterion_tasks
    >>> trials = pd.DataFrame({"participant": ["T1"] * 3 + ["T2"] * 2, "group": "P", "session": "train1",
    ...                        "session_index": 2, "phase": "training", "task_in_phase": [1, 2, 3, 1, 2],
    ...                        "criterion_met": [False, False, True, False, False], "attempts": 0})
    >>> criterion_tasks(trials)[["participant", "tasks", "criterion_met", "tasks_to_criterion", "at_tasks"]]
      participant  tasks  criterion_met  tasks_to_criterion  at_tasks
    0          T1      3           True                   3         3
    1          T2      2          False                <NA>         2
    """
    flagged = trials[trials[criterion].notna()]
    keys = [subject, group, session, session_index, phase]
    rows = []
    for key, part in flagged.groupby(keys, observed=True, sort=True):
        met = part[part[criterion].astype(bool)]
        to_criterion = int(met[task_in_phase].min()) if len(met) else pd.NA
        tasks = int(part[attempts].notna().sum())
        rows.append((*key, tasks, bool(len(met)), to_criterion, tasks if to_criterion is pd.NA else to_criterion))
    table = pd.DataFrame(rows, columns=[*keys, *CRITERION_COLUMNS])
    table["tasks_to_criterion"] = table["tasks_to_criterion"].astype("Int64")
    return table.sort_values([session_index, session, phase, subject], kind="stable").reset_index(drop=True)


def session_roles(trials: pd.DataFrame, pretest: str | None = None, posttest: str | None = None,
                  retention: str | None = None, session: str = "session", session_index: str = "session_index",
                  criterion: str = "criterion_met", subject: str = "participant") -> pd.DataFrame:
    """Each session's place in the program: the sessions with a criterion train; the others test, the
    first of them the pre-test, the second-to-last the post-test and the last the retention test (with
    two test sessions, a pre-test and a post-test).

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task.
    pretest, posttest, retention : str, optional
        Name a session for the role instead.
    session, session_index, criterion, subject : str
        The columns.

    Returns
    -------
    pandas.DataFrame
        One row per session in order: ``session``, order (its least ``session_index``), criterion
        (whether a phase of it has one), role (pretest, training, posttest, retention, or test for
        another test session) and participants.

    Raises
    ------
    AnalysisInputError
        For a named session that is not in the table, or one session named for two roles.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import session_roles
    >>> trials = pd.DataFrame({"participant": "T1", "session": ["pre", "day1", "post", "week"],
    ...                        "session_index": [1, 2, 3, 4], "criterion_met": [None, True, None, None]})
    >>> session_roles(trials)[["session", "role"]]
      session       role
    0     pre    pretest
    1    day1   training
    2    post   posttest
    3    week  retention
    """
    flagged = trials[criterion].notna() if criterion in trials.columns else pd.Series(False, index=trials.index)
    table = (trials.assign(_flagged=flagged).groupby(session, observed=True)
             .agg(order=(session_index, "min"), criterion=("_flagged", "any"), participants=(subject, "nunique"))
             .reset_index().sort_values(["order", session], kind="stable").reset_index(drop=True))  # fmt: skip
    tests = list(table.loc[~table["criterion"], session])
    chosen = {"pretest": tests[0] if len(tests) >= 2 else None,
              "posttest": tests[-2] if len(tests) >= 3 else (tests[-1] if len(tests) == 2 else None),
              "retention": tests[-1] if len(tests) >= 3 else None}  # fmt: skip
    for role, name in (("pretest", pretest), ("posttest", posttest), ("retention", retention)):
        if name is None:
            continue
        if name not in set(table[session]):
            raise AnalysisInputError(f"the {role} session {name!r} is not in column {session!r} (sessions: "
                                     f"{', '.join(table[session])})")
        chosen = {other: (None if value == name else value) for other, value in chosen.items()}
        chosen[role] = name
    named = [name for name in chosen.values() if name]
    if len(named) != len(set(named)):
        raise AnalysisInputError(f"one session is named for two roles: {chosen}")
    roles = {name: role for role, name in chosen.items() if name}
    table["role"] = [roles.get(name, "training" if flag else "test")
                     for name, flag in zip(table[session], table["criterion"])]
    return table[[session, "order", "criterion", "role", "participants"]]


def retention_loss(cells: pd.DataFrame, dv: str = "time_s", posttest: str = "posttest",
                   retention: str = "retention", subject: str = "participant", group: str = "group",
                   session: str = "session") -> pd.DataFrame:
    """Per group, retention minus post-test on ``dv`` paired by participant: means, the paired t-test,
    d_z and the Wilcoxon signed-rank test (:func:`microg.analysis.compare_interactions`).

    Parameters
    ----------
    cells : pandas.DataFrame
        One row per participant and session: each participant's value of ``dv`` in the session.
    dv, posttest, retention : str
        The measure and the two sessions' names.
    subject, group, session : str
        The columns.

    Returns
    -------
    pandas.DataFrame
        One row per group with at least three pairs: ``group`` and RETENTION_COLUMNS (mean_diff =
        retention - posttest, the loss; positive for a time that grew). Participants without both
        sessions are left out.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import retention_loss
    >>> cells = pd.DataFrame({"participant": ["T1", "T2", "T3"] * 2, "group": "P",
    ...                       "session": ["posttest"] * 3 + ["retention"] * 3,
    ...                       "time_s": [20.0, 24.0, 22.0, 23.0, 25.0, 26.5]})
    >>> retention_loss(cells)[["group", "n", "mean_diff", "T", "dof"]].round(3)
      group  n  mean_diff      T  dof
    0     P  3      2.833  2.795    2
    """
    rows = []
    renamed = {"mean_interaction": "mean_retention", "sd_interaction": "sd_retention",
               "mean_baseline": "mean_posttest", "sd_baseline": "sd_posttest"}  # fmt: skip
    for name, part in cells[cells[session].isin([posttest, retention])].groupby(group, observed=True, sort=True):
        both = part.groupby(subject, observed=True)[session].nunique() == 2
        paired = part[part[subject].isin(both[both].index)].assign(_all="all")
        if paired[subject].nunique() < MIN_PAIRS:
            continue
        row = compare_interactions(paired, dv, retention, posttest, "_all", subject, session).rename(columns=renamed)
        rows.append(row.assign(**{group: name})[[group, *RETENTION_COLUMNS]])
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=[group, *RETENTION_COLUMNS])


def analyse_training(
    trials: pd.DataFrame,
    *,
    pretest: str | None = None,
    posttest: str | None = None,
    retention: str | None = None,
    curve_phases: Sequence[str] | None = None,
    excluded_phases: Sequence[str] = (),
    subject: str = "participant",
    group: str = "group",
    session: str = "session",
    session_index: str = "session_index",
    task_index: str = "task_index",
    task_in_phase: str = "task_in_phase",
    criterion: str = "criterion_met",
    phase: str = "phase",
    interaction: str = "interaction",
    dv: str = "time_s",
    attempts: str = "attempts",
    completed: str = "completed",
    alpha: float = ALPHA,
    source: str = "trials table",
) -> TrainingAnalysis:
    """The training section's analysis of a program's trials table: learning curves, tasks to
    criterion, and the pre-test, post-test and retention test.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task, with the session columns (checked by
        :func:`microg.analysis.tables.check_training`).
    pretest, posttest, retention : str, optional
        The test sessions by name (default: :func:`session_roles`).
    curve_phases : sequence of str, optional
        The phases whose tasks make the learning curves (default: every task of every session, tests
        and training: the program's curve, its start in the pre-test). Practice counts every task
        done either way.
    excluded_phases : sequence of str
        Phases left out of the test sessions' analysis (a warm-up before a test).
    subject, group, session, session_index, task_index, task_in_phase, criterion, phase, interaction : str
        The columns.
    dv, attempts, completed : str
        The time measure (of completed tasks), the count of attempts (of every task that ran) and
        the flag of completed tasks.
    alpha : float
        Level at which a test counts as significant.
    source : str
        How error messages name the table.

    Returns
    -------
    TrainingAnalysis
        Every table; withdrawn participants are left out.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.training import analyse_training
    >>> sessions = ("pre", "train", "post", "week")
    >>> trials = pd.DataFrame([
    ...     {"participant": f"T{k}", "group": "BP"[k % 2], "interaction": "s", "session": name,
    ...      "session_index": index + 1, "phase": "training" if name == "train" else "test", "task_index": task,
    ...      "task_in_phase": task + 1, "completed": True, "attempts": 0,
    ...      "time_s": 20 + 40 / (4 * index + task + 1) ** 0.7 + k + 2 * (name == "week") + (task * k) % 3,
    ...      "criterion_met": task >= k % 4 if name == "train" else None}
    ...     for k in range(8) for index, name in enumerate(sessions) for task in range(4)])
    >>> training = analyse_training(trials)  # 8 trainees, 4 sessions; T<k> meets the criterion on task 1 + k % 4
    >>> training.roles
    {'pretest': 'pre', 'posttest': 'post', 'retention': 'week'}
    >>> training.medians[["group", "n", "events", "median"]]
      group  n  events  median
    0     B  4       4     2.0
    1     P  4       4     3.0
    """
    checked = check_trials(trials, source, subject=subject, group=group, within=session, interaction=interaction,
                           dv=(dv, attempts), counts=(attempts,), completed=completed, design=False)  # fmt: skip
    checked = check_training(checked, source, subject=subject, session=session, session_index=session_index,
                             task_index=task_index, task_in_phase=task_in_phase, criterion=criterion)  # fmt: skip
    if criterion not in checked.columns:
        checked[criterion] = pd.Series(pd.NA, index=checked.index, dtype="boolean")
    notes = []
    gone = sorted(withdrawn(checked, subject))
    if gone:
        notes.append(f"Withdrawn, left out: {', '.join(gone)}.")
    checked = checked[~checked[subject].isin(gone)].reset_index(drop=True)
    sessions = session_roles(checked, pretest, posttest, retention, session, session_index, criterion, subject)
    roles = {role: name for name, role in zip(sessions[session], sessions["role"]) if role in ROLES}
    practised = add_practice(checked, subject, session_index, task_index, attempts)

    in_curve = pd.Series(True, practised.index) if curve_phases is None else practised[phase].isin(list(curve_phases))
    curve_tasks = practised[in_curve & practised[PRACTICE].notna()].reset_index(drop=True)
    curve_tasks[dv] = curve_tasks[dv].where(curve_tasks[completed].astype(bool))  # an unfinished task has no time
    timed = curve_tasks[curve_tasks[dv].notna()]
    curve = learning_curve(curve_tasks, (dv, attempts), PRACTICE, group)
    fits = power_law_fits(timed, dv, PRACTICE, subject, group)
    for who, note in zip(fits[subject], fits["note"]):
        if note:
            notes.append(f"No power-law fit for {who}: {note}.")
    model, curves = None, pd.DataFrame(columns=[group, *GROUP_CURVE_COLUMNS])
    try:
        model, curves = practice_model(timed, dv, PRACTICE, subject, group)
    except AnalysisInputError as error:
        notes.append(f"No mixed model of the learning curves: {error}.")

    reached = criterion_tasks(checked, subject, group, session, session_index, phase, task_in_phase, criterion,
                              attempts)  # fmt: skip
    km, medians, tests = [], [], []
    for (name, step), part in reached.groupby([session, phase], observed=True, sort=False):
        keys = {session: name, phase: step}
        km.append(_keyed(kaplan_meier(part, "at_tasks", "criterion_met", group), keys))
        medians.append(_keyed(median_survival(part, "at_tasks", "criterion_met", group), keys))
        try:
            tests.append(_keyed(logrank(part, "at_tasks", "criterion_met", group), keys))
        except AnalysisInputError as error:
            notes.append(f"No log-rank test for {name}, {step}: {error}.")

    test_part = _tests(checked, roles, dv, subject, group, session, completed, excluded_phases, phase, alpha,
                       notes)  # drops from roles a test session left without tasks to analyse
    keys = [session, phase]
    return TrainingAnalysis(
        subject=subject, group=group, session=session, phase=phase, dv=dv, attempts=attempts, alpha=alpha,
        simulated=is_simulated(checked), roles=roles, sessions=sessions, curve_tasks=curve_tasks,
        learning_curve=curve, power_law=fits, practice_model=model, group_curves=curves, criterion=reached,
        kaplan_meier=_joined(km, [*keys, group, *KAPLAN_MEIER_COLUMNS]),
        medians=_joined(medians, [*keys, group, *MEDIAN_COLUMNS]),
        logrank=_joined(tests, [*keys, *LOGRANK_COLUMNS]),
        notes=tuple(notes), **test_part,
    )  # fmt: skip


def _tests(trials, roles, dv, subject, group, session, completed, excluded_phases, phase, alpha, notes) -> dict:
    """The test sessions' tables: cells, ANOVA, post hoc pairs, the session model and retention loss."""
    order = [name for name in (roles.get(role) for role in ROLES) if name]
    empty = {"test_cells": pd.DataFrame(columns=[subject, group, session, dv]),
             "test_cell_means": pd.DataFrame(columns=[group, session, *CELL_MEANS_COLUMNS]),
             "test_anova": pd.DataFrame(columns=ANOVA_COLUMNS),
             "test_corrections": pd.DataFrame(columns=CORRECTION_COLUMNS),
             "test_posthoc": pd.DataFrame(columns=POSTHOC_COLUMNS), "session_model": None,
             "retention": pd.DataFrame(columns=[group, *RETENTION_COLUMNS])}  # fmt: skip
    if len(order) < 2:
        notes.append(f"{len(order)} test session(s) (sessions without a criterion): no comparison of tests.")
        return empty
    rows = exclude_phases(trials[trials[session].isin(order)], excluded_phases, phase)
    rows = rows[rows[completed].astype(bool) & rows[dv].notna()]
    empty_roles = [role for role in ROLES if roles.get(role) and roles[role] not in set(rows[session])]
    for role in empty_roles:
        notes.append(f"The {role} session {roles.pop(role)} has no completed task outside the phases left out "
                     f"({', '.join(excluded_phases) or 'none'}): it is not analysed.")
    if len(roles) < 2:
        notes.append(f"{len(roles)} test session(s) with completed tasks: no comparison of tests.")
        return empty
    cells = rows.groupby([subject, group, session], observed=True, sort=True)[dv].mean().reset_index()
    found = dict(empty, test_cells=cells, test_cell_means=cell_means(cells, dv, session, group))
    if cells[group].nunique() < 2:
        notes.append(f"One {group}: no mixed ANOVA of the test sessions.")
    else:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                anova = mixed_anova(cells, dv, session, group, subject)
                found.update(test_anova=anova, test_corrections=sphericity_correction(anova, alpha),
                             test_posthoc=posthoc(cells, dv, session, group, subject))
            except AnalysisInputError as error:
                notes.append(f"No mixed ANOVA of the test sessions: {error}.")
        notes.extend(f"Test sessions' ANOVA: {warning.message}." for warning in caught
                     if str(warning.message).startswith("dropped"))
        try:
            found["session_model"] = trial_model(rows, dv, f"{group} * {session}", subject, "log")
        except AnalysisInputError as error:
            notes.append(f"No mixed model of the test sessions: {error}.")
    if roles.get("posttest") and roles.get("retention"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found["retention"] = retention_loss(cells, dv, roles["posttest"], roles["retention"], subject, group,
                                                session)  # fmt: skip
        missing = sorted(set(cells[group]) - set(found["retention"][group]))
        if missing:
            notes.append(f"No retention test for {group} {', '.join(missing)}: fewer than {MIN_PAIRS} trainees "
                         "with both the post-test and the retention test.")
    return found


def _power_law(x: np.ndarray, y: np.ndarray, upper_c: float) -> dict:
    """One bounded least-squares fit of y = a + b x^-c (see :func:`power_law_fits`)."""
    nothing = {"a": np.nan, "b": np.nan, "c": np.nan, "a_se": np.nan, "b_se": np.nan, "c_se": np.nan,
               "rss": np.nan, "sigma": np.nan, "at_bound": "", "converged": False}  # fmt: skip
    if len(x) < MIN_POWER_LAW_TASKS or len(np.unique(x)) < 3:
        return {**nothing, "note": f"{len(x)} task(s) at {len(np.unique(x))} amount(s) of practice; a fit needs "
                                   f"{MIN_POWER_LAW_TASKS} tasks at 3 amounts"}
    start = power_law_start(x, y, upper_c)
    lower, upper = np.array([0.0, 0.0, 0.0]), np.array([np.inf, np.inf, upper_c])

    def residuals(theta):
        a, b, c = theta
        return a + b * x**-c - y

    def jacobian(theta):
        _, b, c = theta
        power = x**-c
        return np.column_stack([np.ones_like(x), power, -b * power * np.log(x)])

    found = optimize.least_squares(residuals, start, jac=jacobian, bounds=(lower, upper), method="trf",
                                   x_scale="jac", ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=10_000)  # fmt: skip
    theta = found.x
    rss = float(np.sum(found.fun**2))
    sigma = math.sqrt(rss / (len(x) - 3))
    j = jacobian(theta)
    try:
        with np.errstate(invalid="ignore"):  # a fit at a bound may leave no variance: its error is NaN
            se = np.sqrt(np.diag(np.linalg.inv(j.T @ j)) * sigma**2)
    except np.linalg.LinAlgError:
        se = np.full(3, np.nan)
    names = ("a", "b", "c")
    touching = [f"{name} = {bound:g}" for name, value, low, high in zip(names, theta, lower, upper)
                for bound in (low, high) if np.isfinite(bound) and abs(value - bound) <= 1e-10 * max(1.0, abs(bound))]
    return {"a": theta[0], "b": theta[1], "c": theta[2], "a_se": se[0], "b_se": se[1], "c_se": se[2], "rss": rss,
            "sigma": sigma, "at_bound": ", ".join(touching), "converged": bool(found.status > 0), "note": ""}


def power_law_start(x: np.ndarray, y: np.ndarray, upper_c: float = POWER_LAW_UPPER_C) -> np.ndarray:
    """Where a power-law fit starts (R's script starts there too): a0 = min(y) / 2; b0 and c0 from the
    least-squares line of log(y - a0) on log(x), c0 kept within [0.01, upper_c - 0.01]."""
    a0 = float(np.min(y)) / 2
    slope, intercept = np.polyfit(np.log(x), np.log(y - a0), 1)
    return np.array([a0, math.exp(intercept), float(np.clip(-slope, 0.01, upper_c - 0.01))])


def _keyed(frame: pd.DataFrame, keys: dict) -> pd.DataFrame:
    return frame.assign(**keys)[[*keys, *frame.columns]]


def _joined(frames: list[pd.DataFrame], columns: list[str]) -> pd.DataFrame:
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=columns)
