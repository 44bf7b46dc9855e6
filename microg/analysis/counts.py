"""A count model for event counts such as drops, beside the paper's ANOVA of per-participant means.

Drops are small counts, mostly zeros, whose spread grows with their mean: an ANOVA of their cell
means treats them as normal with equal variances. The count model treats each task's count as
Poisson with a log link, the groups and levels (sum-to-zero coding, so each term is tested as in a
type 3 ANOVA) as fixed effects, and the tasks of one participant as correlated: a generalised
estimating equation (statsmodels GEE) with an exchangeable working correlation and robust
(sandwich) standard errors. Its tests are Wald chi-square tests per term. Why GEE rather than a
Poisson mixed model: it is deterministic and fitted by statsmodels' frequentist code (its Bayesian
mixed GLM is a variational approximation), its robust errors stay valid when the counts are
overdispersed or the correlation is misspecified, and R's geepack reproduces it.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import statsmodels.api as sm
from statsmodels.genmod.cov_struct import Exchangeable
from statsmodels.tools.sm_exceptions import ConvergenceWarning, DomainWarning

from microg.analysis.tables import stars

COUNT_MODEL_COLUMNS = (
    "term", "chi2", "df", "p_unc", "stars", "model", "n_subjects", "n_tasks", "share_zero", "correlation", "note",
)  # fmt: skip


def count_model(trials: pd.DataFrame, dv: str, within: str, between: str, subject: str) -> pd.DataFrame:
    """Poisson GEE of the counts ``dv`` per task: ``between`` x ``within`` with participants as clusters.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per task with a count (several tasks per participant and level are fine).
    dv, within, between, subject : str
        Columns of the count, the within factor, the between factor and the participant.

    Returns
    -------
    pandas.DataFrame
        One row per term (``between``, ``within``, ``between:within``), columns
        COUNT_MODEL_COLUMNS: the robust Wald chi-square, its df and p; the model fitted; the number
        of participants and tasks; the share of tasks with a count of 0; the estimated exchangeable
        correlation; and a note. Sparse counts are handled as follows: when every count is 0 there
        is nothing to model; when a whole group or level has no event its log rate is minus
        infinity and no model is fitted; when only some group x level cells have no event the
        interaction cannot be estimated and the main-effects model is fitted; when the robust
        covariance is singular (too few participants) no test is given. The note says which.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis import count_model
    >>> trials = pd.DataFrame({"p": [f"P{i}" for i in range(8) for _ in range(2)],
    ...                        "g": ["V"] * 8 + ["B"] * 8, "o": ["cube", "ball"] * 8,
    ...                        "drops": [0, 1, 0, 2, 1, 1, 0, 3, 2, 4, 1, 3, 2, 5, 0, 2]})
    >>> count_model(trials, "drops", "o", "g", "p")[["term", "chi2", "df", "p_unc"]].round(3)
      term   chi2  df  p_unc
    0    g  6.408   1  0.011
    1    o  8.385   1  0.004
    2  g:o  0.795   1  0.373
    """
    rows = trials[trials[dv].notna()].sort_values(subject, kind="stable")
    terms = [between, within, f"{between}:{within}"]
    summary = {
        "n_subjects": rows[subject].nunique(),
        "n_tasks": len(rows),
        "share_zero": float((rows[dv] == 0).mean()) if len(rows) else np.nan,
    }
    if not (rows[dv] > 0).any():
        return _table(terms, None, "none", summary, np.nan, f"no events: every {dv} is 0, nothing to model")
    totals = rows.groupby([between, within], observed=True)[dv].sum()
    for factor in (between, within):
        margin = totals.groupby(level=factor).sum()
        if (margin == 0).any():
            empty = ", ".join(map(str, margin[margin == 0].index))
            note = f"not estimable: no {dv} at all in {factor} {empty} (its log rate is minus infinity)"
            return _table(terms, None, "none", summary, np.nan, note)
    empty_cells = totals[totals == 0]
    interaction = empty_cells.empty
    try:
        result = _fit(rows, dv, within, between, subject, interaction)
        tests = result.wald_test_terms(skip_single=False, scalar=True).table
    except (ValueError, np.linalg.LinAlgError) as error:
        note = f"not estimable: the robust covariance of {summary['n_subjects']} participants is singular ({error})"
        return _table(terms, None, "none", summary, np.nan, note)
    found = dict(zip(terms, tests.index[1:]))
    tested = {term: tests.loc[found[term]] for term in terms if term in found}
    model = "main effects and interaction" if interaction else "main effects only"
    note = (
        "Poisson GEE, log link, exchangeable correlation within participant, robust Wald tests"
        if interaction
        else "the interaction is not estimable (no "
        + dv
        + " in "
        + ", ".join(f"{b} x {w}" for b, w in empty_cells.index)
        + "): main effects only"
    )
    return _table(terms, tested, model, summary, float(result.cov_struct.dep_params), note)


def _fit(rows: pd.DataFrame, dv: str, within: str, between: str, subject: str, interaction: bool):
    names = {"b": between, "w": within, "s": subject}
    data = pd.DataFrame({short: rows[column].astype(str).to_numpy() for short, column in names.items()})
    data["y"] = rows[dv].to_numpy(float)
    formula = "y ~ C(b, Sum) * C(w, Sum)" if interaction else "y ~ C(b, Sum) + C(w, Sum)"
    model = sm.GEE.from_formula(formula, groups="s", data=data, family=sm.families.Poisson(), cov_struct=Exchangeable())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", (ConvergenceWarning, DomainWarning))
        return model.fit()


def _table(terms, tested, model, summary, correlation, note) -> pd.DataFrame:
    rows = []
    for term in terms:
        test = None if tested is None else tested.get(term)
        chi2, df, p = (
            (np.nan, np.nan, np.nan) if test is None else (test["statistic"], test["df_constraint"], test["pvalue"])
        )
        rows.append((term, chi2, df, p, stars(p), model, *summary.values(), correlation, note))
    return pd.DataFrame(rows, columns=list(COUNT_MODEL_COLUMNS)).astype({"df": "Int64"})
