"""Linear mixed models of the trials: every task a row, participants as random effects, with the
numbers R's lme4 and lmerTest report.

The ANOVA of cell means needs one value per participant and level: it averages a participant's
tasks, drops a participant with a missing cell and cannot follow practice over tasks. A linear
mixed model takes every finished task as it is: fixed effects written as an R formula (``"group *
object * interaction + task_index"``), a random intercept per participant and, where the fit
supports it, a random slope of a numeric column (practice) per participant.

Fitted by statsmodels' ``MixedLM`` (REML), finished by a trust-region Newton search on MixedLM's
own likelihood (see :func:`fit_mixed`: MixedLM's optimisers stop about 1e-5 from the optimum lme4
reaches, and short of a boundary). Why MixedLM: it is the maintained frequentist
LMM in Python, fits correlated random intercepts and slopes by REML exactly as lme4 does, and
needs nothing outside Python; it reports no denominator degrees of freedom, so those are computed
here. Categorical columns are coded sum-to-zero (R's ``contr.sum``; a coefficient ``group1`` is the
first level's deviation from the mean of the levels, levels sorted), so every term is tested as in a
type 3 ANOVA.

Degrees of freedom are Satterthwaite's, as lmerTest computes them: for a contrast L,
df = 2 (L C L')^2 / (g' A g), with C the covariance of the fixed effects, g its gradient in the
variance parameters and A the inverse of the REML log-likelihood's observed information. Both are
computed analytically here (lmerTest differentiates numerically, which agrees to about 1e-7). A term
with several degrees of freedom is tested on lmerTest's type 3 hypothesis matrix (SAS's
construction on treatment coding, mapped to the sum-coded coefficients) with lmerTest's combination
of the eigen-decomposed contrasts: that combination depends on the basis, so the basis is lmerTest's.
Kenward-Roger's method (pbkrtest) is not offered: it also adjusts the covariance of the fixed
effects, which needs the second-order terms of the variance parameters; Satterthwaite is
lmerTest's default and what afex's ``mixed(method = "S")`` reports.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from itertools import product

import numpy as np
import pandas as pd
import statsmodels.api as sm
from scipy import optimize, stats
from statsmodels.regression.mixed_linear_model import MixedLMParams
from statsmodels.tools.numdiff import approx_fprime

from microg.analysis.tables import AnalysisInputError

MODEL_ANOVA_COLUMNS = ("source", "F", "df1", "df2", "p_unc")
COEFFICIENT_COLUMNS = ("term", "estimate", "SE", "df", "t", "p_unc")
RANDOM_COLUMNS = ("name", "variance", "sd", "correlation")
TRANSFORMS = ("log",)
SINGULAR = 1e-4
"""A fit is singular when a diagonal element of the random effects' Cholesky factor relative to the
residual SD is below this (lme4's ``isSingular`` tolerance): a variance at 0 or a correlation at +-1."""
ZAP_DIGITS = 7
"""lmerTest rounds its hypothesis matrices to 7 significant digits (R's ``zapsmall``); so do we."""


@dataclass(frozen=True)
class TrialModel:
    """A fitted linear mixed model of the trials.

    ``anova``: one row per fixed term (MODEL_ANOVA_COLUMNS; type 3 F tests, Satterthwaite df2);
    ``coefficients``: one row per coefficient (COEFFICIENT_COLUMNS); ``random``: the random effects'
    variances, SDs and correlation, then the residual's (RANDOM_COLUMNS); ``formula``: the model in
    lme4's notation; ``note``: what was fitted and why (a random slope dropped, a singular fit);
    ``fit``: the REML fit itself, for contrasts of the fixed effects (:meth:`MixedFit.satterthwaite`).
    """

    anova: pd.DataFrame
    coefficients: pd.DataFrame
    random: pd.DataFrame
    formula: str
    n_trials: int
    n_subjects: int
    note: str
    fit: MixedFit | None = field(default=None, repr=False, compare=False)


@dataclass(frozen=True)
class MixedFit:
    """A REML fit: fixed effects ``beta`` (named ``names``), their covariance ``covariance``, the
    derivatives of that covariance in each variance parameter (``jacobians``) and the covariance of
    the variance parameters (``parameter_covariance``); ``random`` the random effects' covariance
    (q x q), ``residual`` the residual variance."""

    names: tuple[str, ...]
    beta: np.ndarray
    covariance: np.ndarray
    jacobians: tuple[np.ndarray, ...]
    parameter_covariance: np.ndarray
    random: np.ndarray
    residual: float

    @property
    def singular(self) -> bool:
        """lme4's ``isSingular``: the relative Cholesky factor has a diagonal element below SINGULAR."""
        try:
            factor = np.linalg.cholesky(self.random / self.residual)
        except np.linalg.LinAlgError:
            return True
        return bool(np.any(np.diag(factor) < SINGULAR))

    def satterthwaite(self, contrast: np.ndarray) -> tuple[float, float, float]:
        """Estimate, SE and Satterthwaite df of one contrast of the fixed effects."""
        contrast = np.asarray(contrast, float)
        variance = float(contrast @ self.covariance @ contrast)
        gradient = np.array([contrast @ jacobian @ contrast for jacobian in self.jacobians])
        df = 2 * variance**2 / float(gradient @ self.parameter_covariance @ gradient)
        return float(contrast @ self.beta), math.sqrt(variance), df

    def f_test(self, hypothesis: np.ndarray) -> tuple[float, int, float]:
        """F, df1 and Satterthwaite df2 of ``hypothesis`` (rows of contrasts) = 0, as lmerTest's
        ``contestMD``: the contrasts' covariance eigen-decomposed, each component's df by
        :meth:`satterthwaite`, combined by E = sum nu / (nu - 2), df2 = 2 E / (E - q)."""
        hypothesis = np.atleast_2d(np.asarray(hypothesis, float))
        values, vectors = np.linalg.eigh(hypothesis @ self.covariance @ hypothesis.T)
        order = np.argsort(values)[::-1]
        values, vectors = values[order], vectors[:, order]
        kept = values > max(np.sqrt(np.finfo(float).eps) * values[0], 0)
        rotated = (vectors.T @ hypothesis)[kept]
        q = int(kept.sum())
        F = float(np.sum((rotated @ self.beta) ** 2 / values[kept]) / q)
        dfs = np.array([self.satterthwaite(row)[2] for row in rotated])
        if q == 1 or np.all(np.abs(np.diff(dfs)) < 1e-8):
            return F, q, float(dfs.mean())
        if np.any(dfs <= 2):
            return F, q, 2.0
        expected = float(np.sum(dfs / (dfs - 2)))
        return F, q, 2 * expected / (expected - q)


def trial_model(
    trials: pd.DataFrame, dv: str, fixed: str, subject: str, transform: str | None = None, *, slope: str | None = None
) -> TrialModel:
    """Linear mixed model of ``dv`` on every trial: fixed effects ``fixed``, random intercepts per
    ``subject`` (and a random slope of ``slope`` where the fit is not singular), as lme4/lmerTest.

    Parameters
    ----------
    trials : pandas.DataFrame
        One row per trial; rows without a value of ``dv`` are left out (an unfinished task has no time).
    dv : str
        The measure.
    fixed : str
        Fixed effects as an R formula's right-hand side: column names joined by ``+`` (added), ``*``
        (crossed: the terms and all their combinations) and ``:`` (one combination); e.g.
        ``"group * object + task_index"``. Text columns are factors (sum-to-zero coding, levels
        sorted), number columns covariates; every combination's lower-order terms must be in it.
    subject : str
        Column of the participant: one random intercept each.
    transform : {None, "log"}
        ``"log"`` models the natural log of ``dv`` (completion times: right-skewed, effects
        multiplicative); every value must then be positive.
    slope : str, optional
        A number column (e.g. the task's position, for practice) whose slope varies between
        participants, correlated with the intercept; dropped, with a note, when that fit is singular
        (a variance at 0 or a correlation at +-1, lme4's ``isSingular``) or does not converge.

    Returns
    -------
    TrialModel
        ``.anova`` (source, F, df1, df2, p_unc: type 3 F tests with Satterthwaite df2, lmerTest's
        ``anova(type = 3)``), ``.coefficients`` (term, estimate, SE, df, t, p_unc: lmerTest's
        ``summary``), ``.random``, ``.formula``, ``.note``.

    Raises
    ------
    AnalysisInputError
        For a missing column, a formula that names none or is not hierarchical, too few trials for
        the model, or a value the transform cannot take.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from microg.analysis import trial_model
    >>> rng = np.random.default_rng(1)
    >>> trials = pd.DataFrame({"p": np.repeat([f"P{i}" for i in range(8)], 4), "g": np.repeat(["a", "b"], 16),
    ...                        "o": ["cube", "ball"] * 16})
    >>> trials["rt"] = 10 + (trials["o"] == "ball") * 3 + np.repeat(rng.normal(0, 2, 8), 4) + rng.normal(0, 1, 32)
    >>> model = trial_model(trials, "rt", "g * o", "p")
    >>> model.formula
    'rt ~ g * o + (1 | p)'
    >>> model.anova.round(3)
      source       F  df1   df2  p_unc
    0      g   0.176    1   6.0  0.689
    1      o  90.780    1  22.0  0.000
    2    g:o   0.381    1  22.0  0.543
    """
    terms = parse_fixed(fixed)
    variables = list(dict.fromkeys(name for term in terms for name in term))
    needed = [dv, subject, *variables, *([slope] if slope else [])]
    missing = [column for column in needed if column not in trials.columns]
    if missing:
        raise AnalysisInputError(f"trial model: missing column {missing[0]!r} (columns: {', '.join(trials.columns)})")
    positions = np.flatnonzero(trials[dv].notna().to_numpy())
    rows = trials.iloc[positions].reset_index(drop=True)
    y = pd.to_numeric(rows[dv], errors="raise").to_numpy(float)
    response = dv
    if transform is not None:
        if transform not in TRANSFORMS:
            raise ValueError(f"transform must be one of {TRANSFORMS} or None, not {transform!r}")
        bad = np.flatnonzero(y <= 0)
        if len(bad):
            raise AnalysisInputError(f"trial model: column {dv!r} value {float(y[bad[0]])!r} cannot be log-transformed "
                                     f"(data row {positions[bad[0]] + 1}, {subject} {rows[subject].iloc[bad[0]]!r})")
        y, response = np.log(y), f"log({dv})"
    factors = {name: sorted(rows[name].astype(str).unique()) for name in variables if _is_factor(rows[name])}
    design = fixed_design(rows, terms, factors)
    if len(rows) <= design.sum_coded.shape[1] + 1 or np.linalg.matrix_rank(design.sum_coded) < design.sum_coded.shape[1]:
        raise AnalysisInputError(f"trial model: {len(rows)} trials cannot estimate the {design.sum_coded.shape[1]} "
                                 f"coefficients of {fixed!r} (a combination without trials, or too few trials)")
    groups = rows[subject].astype(str).to_numpy()
    fixed_text = " ".join(fixed.split())
    note, fit, with_slope = "random intercept per participant", None, False
    if slope is not None:
        covariate = pd.to_numeric(rows[slope], errors="raise").to_numpy(float)
        fit = fit_mixed(y, design.sum_coded, design.names, groups, np.column_stack([np.ones(len(rows)), covariate]))
        if fit is None or fit.singular:
            why = "did not converge" if fit is None else "is singular (a variance at 0 or a correlation at +-1)"
            note = f"random intercept per participant; the model with a random slope of {slope} {why}, so it was dropped"
            fit = None
        else:
            note, with_slope = f"random intercept and slope of {slope} per participant, correlated", True
            random_text = f"(1 + {slope} | {subject})"
    if fit is None:
        fit = fit_mixed(y, design.sum_coded, design.names, groups, np.ones((len(rows), 1)))
        random_text = f"(1 | {subject})"
        if fit is None:
            raise AnalysisInputError(f"trial model: the REML fit of {response} ~ {fixed_text} did not converge")
    if fit.singular:
        note += "; singular fit (the participant variance is estimated at 0): read the tests with care"
    coefficients = pd.DataFrame(
        [(name, *fit.satterthwaite(unit)) for name, unit in zip(fit.names, np.eye(len(fit.names)))],
        columns=["term", "estimate", "SE", "df"],
    )
    coefficients["t"] = coefficients["estimate"] / coefficients["SE"]
    coefficients["p_unc"] = 2 * stats.t.sf(coefficients["t"].abs(), coefficients["df"])
    anova = pd.DataFrame(
        [(_term_text(term), *fit.f_test(hypothesis)) for term, hypothesis in design.type3.items()],
        columns=["source", "F", "df1", "df2"],
    )
    anova["p_unc"] = stats.f.sf(anova["F"], anova["df1"], anova["df2"])
    return TrialModel(
        anova=anova[list(MODEL_ANOVA_COLUMNS)],
        coefficients=coefficients[list(COEFFICIENT_COLUMNS)],
        random=_random_table(fit, subject, slope if with_slope else None),
        formula=f"{response} ~ {fixed_text} + {random_text}",
        n_trials=len(rows),
        n_subjects=len(set(groups)),
        note=note,
        fit=fit,
    )


def parse_fixed(fixed: str) -> list[tuple[str, ...]]:
    """The terms of an R formula's right-hand side, in R's order (by number of variables, then as
    written).

    Examples
    --------
    >>> from microg.analysis.mixed_model import parse_fixed
    >>> parse_fixed("group * object + task_index")
    [('group',), ('object',), ('task_index',), ('group', 'object')]
    """
    terms = _formula_terms(fixed)
    if not terms:
        raise AnalysisInputError(f"trial model: the fixed effects {fixed!r} name no column")
    present = set(terms)
    for term in terms:
        for size in range(1, len(term)):
            for part in _subsets(term, size):
                if part not in present:
                    raise AnalysisInputError(f"trial model: fixed effects {fixed!r} have {_term_text(term)} without "
                                             f"{_term_text(part)}; write the combination with * (e.g. "
                                             f"{' * '.join(term)})")
    return sorted(terms, key=len)


def fit_mixed(y: np.ndarray, x: np.ndarray, names, groups: np.ndarray, z: np.ndarray) -> MixedFit | None:
    """REML fit of y = x beta + z_j b_j + e, b_j ~ N(0, G) per group j, e ~ N(0, s2 I).

    statsmodels' MixedLM fits it (BFGS, then L-BFGS when the search from BFGS's fit stalls:
    START_METHODS); its optimisers stop about 1e-5 short of the optimum and creep
    towards a boundary (a variance at 0) without reaching it, where lme4 stops exactly. So the fit
    is finished by scipy's trust-region Newton (``trust-exact``) on MixedLM's own REML likelihood
    and score in lme4's parametrisation (the Cholesky factor of G / s2, with the fixed effects and
    s2 profiled out; the Hessian by differences of the analytic score), until the score is 0 to
    SCORE_TOLERANCE; where it stalls short of a boundary (the score loses its accuracy there), by
    Powell's derivative-free search within bounds (the Cholesky factor's diagonal at BOUNDARY or more,
    as lme4's bobyqa bounds it at 0), which reaches it. A singular
    fit (at the boundary) need not have a zero score; any other must. The fixed effects and their
    covariance are the GLS ones at that optimum. None when no fit converges.
    """
    model = sm.MixedLM(y, x, groups=groups, exog_re=z)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            found = None
            for method in START_METHODS:  # a start: converged or not, the searches below finish it
                try:
                    start = model.fit(reml=True, method=method)
                    packed = MixedLMParams.from_components(cov_re=np.atleast_2d(start.cov_re) / start.scale)
                    searched = optimize.minimize(
                        lambda p: -model.loglike(p), packed.get_packed(use_sqrt=True, has_fe=False),
                        jac=lambda p: -model.score(p), hess=lambda p: _symmetric(approx_fprime(p, model.score)),
                        method="trust-exact", options={"gtol": SCORE_TOLERANCE / 10, "maxiter": 200},
                    )  # fmt: skip
                except (np.linalg.LinAlgError, ValueError):
                    continue  # this optimiser's start is singular: the next may not be
                found = searched if found is None or searched.fun < found.fun else found
                if np.max(np.abs(model.score(found.x))) <= SCORE_TOLERANCE:
                    break
            if found is None:
                return None
            if np.max(np.abs(model.score(found.x))) > SCORE_TOLERANCE:  # stalled by a boundary: search within it
                rows, columns = np.tril_indices(model.k_re)
                bounds = [(BOUNDARY, None) if row == column else (None, None) for row, column in zip(rows, columns)]
                diagonal = rows == columns
                found = optimize.minimize(
                    lambda p: -model.loglike(p), np.where(diagonal, np.maximum(np.abs(found.x), BOUNDARY), found.x),
                    bounds=bounds, method="Powell", options={"xtol": 1e-6, "ftol": 1e-12, "maxfev": 20000},
                )  # fmt: skip
            if not np.all(np.isfinite(found.x)):
                return None
            relative = MixedLMParams.from_packed(found.x, model.k_fe, model.k_re, use_sqrt=True, has_fe=False).cov_re
            fixed, _ = model.get_fe_params(relative, np.zeros(0))
            scale = float(model.get_scale(fixed, relative, np.zeros(0)))
        except (np.linalg.LinAlgError, ValueError):
            return None
    fit = _Covariance(x, groups, z).fit(y, scale * relative, scale, tuple(names))
    if not fit.singular and np.max(np.abs(model.score(found.x))) > SCORE_TOLERANCE:
        return None  # at a boundary the score need not vanish; elsewhere it must
    return fit


SCORE_TOLERANCE = 1e-6
START_METHODS = ("bfgs", "lbfgs")
"""MixedLM's optimisers that give the Newton search its start, the next tried when the search from one
stalls: BFGS can stop far from the optimum (a random slope of log practice: a start from which the
search fails), L-BFGS then starts it well."""
BOUNDARY = 1e-8
"""The bounded search keeps the Cholesky factor's diagonal at this or more rather than 0, where MixedLM's
computations are singular; far below SINGULAR, so such a fit is singular all the same."""


def _symmetric(matrix: np.ndarray) -> np.ndarray:
    return -(matrix + matrix.T) / 2


class _Covariance:
    """V = s2 I + Z (I kron G) Z' as a linear function of phi = (the lower triangle of G, s2)."""

    def __init__(self, x: np.ndarray, groups: np.ndarray, z: np.ndarray):
        n, q = z.shape
        labels, members = np.unique(groups, return_inverse=True)
        blocks = np.zeros((n, len(labels) * q))
        for j in range(q):
            blocks[np.arange(n), members * q + j] = z[:, j]
        self.x, self.q, self.n = x, q, n
        self.pairs = [(a, b) for a in range(q) for b in range(a + 1)]
        self.pieces = []
        for a, b in self.pairs:
            unit = np.zeros((q, q))
            unit[a, b] = unit[b, a] = 1.0
            self.pieces.append(blocks @ np.kron(np.eye(len(labels)), unit) @ blocks.T)
        self.pieces.append(np.eye(n))

    def _solve(self, phi: np.ndarray):
        variance = sum(value * piece for value, piece in zip(phi, self.pieces))
        inverse = np.linalg.inv(variance)
        weighted = inverse @ self.x
        covariance = np.linalg.inv(self.x.T @ weighted)
        projection = inverse - weighted @ covariance @ weighted.T
        return weighted, covariance, projection

    def fit(self, y: np.ndarray, random: np.ndarray, residual: float, names: tuple[str, ...]) -> MixedFit:
        """At G = ``random`` and s2 = ``residual``: the GLS fixed effects, their covariance C,
        dC/dphi_i = C X'V^-1 V_i V^-1 X C, and the covariance of phi, the inverse of the REML
        log-likelihood's observed information -d2l/dphi_i dphi_j = y'P V_i P V_j P y - tr(P V_i P V_j) / 2."""
        phi = np.array([*(random[a, b] for a, b in self.pairs), residual])
        weighted, covariance, projection = self._solve(phi)
        beta = covariance @ weighted.T @ y
        fitted = projection @ y
        spread = [projection @ piece for piece in self.pieces]
        information = np.array([[fitted @ self.pieces[i] @ spread[j] @ fitted - 0.5 * np.trace(a @ b)
                                 for j, b in enumerate(spread)] for i, a in enumerate(spread)])  # fmt: skip
        jacobians = tuple(covariance @ weighted.T @ piece @ weighted @ covariance for piece in self.pieces)
        return MixedFit(names, beta, covariance, jacobians, np.linalg.inv(information), random, residual)


@dataclass(frozen=True)
class _Design:
    names: tuple[str, ...]
    sum_coded: np.ndarray
    type3: dict  # term -> hypothesis matrix on the sum-coded coefficients


def fixed_design(rows: pd.DataFrame, terms: list[tuple[str, ...]], factors: dict) -> _Design:
    """The sum-coded design (R's model.matrix with contr.sum) and lmerTest's type 3 hypotheses."""
    coded = {"sum": [("(Intercept)", np.ones(len(rows)))], "treatment": [("(Intercept)", np.ones(len(rows)))]}
    indicators = [("(Intercept)", np.ones(len(rows)))]
    owner = {"treatment": [None]}
    for term in terms:
        for coding in ("sum", "treatment"):
            columns = _columns(rows, term, factors, coding)
            coded[coding] += columns
            if coding == "treatment":
                owner["treatment"] += [term] * len(columns)
        indicators += _columns(rows, term, factors, "indicator")
    names = tuple(name for name, _ in coded["sum"])
    sum_coded = np.column_stack([values for _, values in coded["sum"]])
    treatment = np.column_stack([values for _, values in coded["treatment"]])
    treatment_names = [name for name, _ in coded["treatment"]]
    full = np.column_stack([values for _, values in indicators])
    full_names = [name for name, _ in indicators]
    # SAS-style type 3 hypotheses on the treatment coding, as lmerTest's extract_contrasts_type3
    pinv = np.linalg.pinv(treatment)
    hypotheses = _zap((pinv @ full).T)  # rows: the indicator parameters; columns: the treatment coefficients
    where = {term: [i for i, t in enumerate(owner["treatment"]) if t == term] for term in terms}
    contains = {term: [other for other in terms if _contained(term, other, factors)] for term in terms}
    for term in sorted(terms, key=len, reverse=True):
        if contains[term]:
            basis = hypotheses[:, [i for other in contains[term] for i in where[other]]]
            target = hypotheses[:, where[term]]
            fitted = basis @ np.linalg.lstsq(basis, target, rcond=None)[0]
            hypotheses[:, where[term]] = _zap(target - fitted)
    rows_named = [full_names.index(name) for name in treatment_names]
    square = hypotheses[rows_named]  # rows and columns: the treatment coefficients
    to_sum = _zap(pinv @ sum_coded)
    type3 = {}
    for term in terms:
        block = square[:, where[term]].T
        block = block[np.abs(block).sum(axis=1) > 1e-8]
        type3[term] = block @ to_sum
    return _Design(names, sum_coded, type3)


def _columns(rows: pd.DataFrame, term: tuple[str, ...], factors: dict, coding: str) -> list[tuple[str, np.ndarray]]:
    """One term's model-matrix columns in R's order (the first variable varies fastest): ``sum``
    (contr.sum: level i minus the last, named var1 .. var(k-1)), ``treatment`` (indicator of each
    level but the first, named var<level>) or ``indicator`` (every level: ``~ 0 + term``)."""
    per_variable = []
    for name in term:
        if name not in factors:
            per_variable.append([(name, pd.to_numeric(rows[name], errors="raise").to_numpy(float))])
            continue
        values, levels = rows[name].astype(str).to_numpy(), factors[name]
        if coding == "sum":
            last = (values == levels[-1]).astype(float)
            per_variable.append([(f"{name}{i + 1}", (values == level).astype(float) - last)
                                 for i, level in enumerate(levels[:-1])])  # fmt: skip
        else:
            kept = levels[1:] if coding == "treatment" else levels
            per_variable.append([(f"{name}{level}", (values == level).astype(float)) for level in kept])
    found = []
    for combination in product(*reversed(per_variable)):
        combination = combination[::-1]
        found.append((":".join(name for name, _ in combination), np.prod([v for _, v in combination], axis=0)))
    return found


def _contained(term: tuple[str, ...], other: tuple[str, ...], factors: dict) -> bool:
    """lmerTest's containment: ``other`` has all of ``term``'s variables and more, and the same covariates."""
    covariates = {name for name in term if name not in factors}
    return set(term) < set(other) and covariates == {name for name in other if name not in factors}


def _formula_terms(fixed: str) -> list[tuple[str, ...]]:
    terms: list[tuple[str, ...]] = []
    for part in (piece.strip() for piece in fixed.split("+")):
        if not part:
            continue
        if "*" in part:
            names = [name.strip() for name in part.split("*")]
            expanded = [s for size in range(1, len(names) + 1) for s in _subsets(tuple(names), size)]
        else:
            expanded = [tuple(name.strip() for name in part.split(":"))]
        for term in expanded:
            if any(not name for name in term):
                raise AnalysisInputError(f"trial model: cannot read the fixed effects {fixed!r}")
            if term not in terms:
                terms.append(term)
    return terms


def _subsets(names: tuple[str, ...], size: int) -> list[tuple[str, ...]]:
    from itertools import combinations

    return list(combinations(names, size))


def _term_text(term: tuple[str, ...]) -> str:
    return ":".join(term)


def _is_factor(column: pd.Series) -> bool:
    return not pd.api.types.is_numeric_dtype(column) or pd.api.types.is_bool_dtype(column)


def _zap(values: np.ndarray) -> np.ndarray:
    """R's zapsmall: round to ZAP_DIGITS significant digits of the largest magnitude."""
    largest = np.max(np.abs(values)) if values.size else 0.0
    if largest == 0:
        return values
    return np.round(values, max(0, ZAP_DIGITS - math.ceil(math.log10(largest))))


def _random_table(fit: MixedFit, subject: str, slope: str | None) -> pd.DataFrame:
    names = [f"{subject} (Intercept)", *([f"{subject} {slope}"] if slope else [])]
    sd = np.sqrt(np.diag(fit.random))
    correlation = [np.nan] + ([float(fit.random[0, 1] / (sd[0] * sd[1]))] if slope else [])
    rows = [(name, float(v), float(s), c) for name, v, s, c in zip(names, np.diag(fit.random), sd, correlation)]
    rows.append(("Residual", fit.residual, math.sqrt(fit.residual), np.nan))
    return pd.DataFrame(rows, columns=list(RANDOM_COLUMNS))
