"""A population of simulated participants fitted to data by simulation-based inference.

``calibrate`` runs pyabc's ABC-SMC (Klinger et al. 2018; Toni et al. 2009): each particle is one
set of the free population values (``Free``: a parameter's population mean, or its spread between
people as a coefficient of variation), with a wide uniform prior inside the parameter's bounds;
its model is one whole simulated study (``simulate_trials`` with that population, the protocol
resized to ``participants`` per group); its distance to the data is the root mean square of the
fitted targets' gaps in standard errors (``Target.z``), a fixed distance, so that a resumed run
sees exactly what an uninterrupted one saw; epsilon is the median of the last generation's
distances (the first from a sample of the prior). The evaluations run on Dask in a fixed order
(``sampler.OrderedDaskSampler``): the same seed gives the same posterior whatever the workers.

The run's files sit next to ``PROFILE.toml``:

- ``calibration.json``: the request (a resumed run must match it);
- ``calibration.db``: pyabc's history (every generation; ``ABCSMC.load`` continues it);
- ``calibration-evaluations.db``: every finished study's particle, so that an interrupted
  generation loses nothing;
- ``posterior.csv``: each free value's posterior mean and 90 % credible interval;
- ``calibration.csv`` and ``calibration.png``: the posterior-predictive check, every target
  against ``check`` studies simulated from posterior draws;
- ``PROFILE.toml``: the fitted population, with its ``[calibration]`` table.
"""

from __future__ import annotations

import datetime
import fnmatch
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import cloudpickle
import numpy as np
import pandas as pd

from microg.participant.population import NAMES, SPEC, Population, Spread, default_population
from microg.study.protocol import Protocol

from .sampler import EvaluationCache, OrderedDaskSampler, pickled_call
from .studies import protocol_through, simulate_trials
from .targets import Target, TargetError, simulated_values

RECORD, HISTORY, EVALUATIONS = "calibration.json", "calibration.db", "calibration-evaluations.db"
POSTERIOR, CHECK, PICTURE = "posterior.csv", "calibration.csv", "calibration.png"
CHECK_STREAM = 0x434845
"""Mixed into the seeds of the posterior-predictive check's draws and studies."""
CV_HIGH = 1.0
"""The largest coefficient of variation between people a fitted spread's prior allows."""
PRIOR_FACTOR = 5.0
"""A fitted mean's prior spans from the base's mean over this to the base's mean times this."""
DEFAULT_FIT = ("hesitation_s", "hesitation_s:sd", "movement_slope", "carry_slowdown", "shape_caution",
               "learning_rate", "aim_sd", "grip_lapse")
"""What ``--fit`` frees by default: the means of the parameters that move time (pauses, movements,
carrying), the object effect (caution with elongated objects), practice, precision and the grip's
lapses (drops), and the spread between people of the largest source of time differences.
(``hold_margin_s`` does not move time in a session: the task's display shows when a hold is done.)"""
LEVEL = 0.90
"""The credible and predictive intervals' level."""


MAX_PARTICIPANTS = 1000
"""The largest group a simulated study of the calibration has (as ``microg power``'s ``--n``): a
larger one would run for days; the fit needs no more than the data's own groups."""


class CalibrationError(ValueError):
    """A calibration that cannot run as asked; the message names the option, file, key and value."""


@dataclass(frozen=True)
class Free:
    """One fitted value: the population mean of ``name`` (``what = "mean"``) or its spread between
    people (``"sd"``, fitted as the coefficient of variation sd / mean), with its uniform prior
    (``with_prior``): ``low`` and ``high`` on the value's own scale, pyabc working on their
    logarithm where ``logged``."""

    name: str
    what: str = "mean"
    low: float = 0.0
    high: float = CV_HIGH
    logged: bool = False

    @property
    def key(self) -> str:
        """How ``--fit`` and the posterior name it: ``NAME`` or ``NAME:sd``."""
        return self.name if self.what == "mean" else f"{self.name}:sd"

    def with_prior(self, base: Spread) -> Free:
        """The value with its prior, from the base population's mean: a mean is log-uniform from
        a fifth to five times the base's mean, inside the parameter's bounds (uniform over the
        bounds for a fraction, or where the base's mean is 0); a spread's sd / mean is uniform in
        [0, CV_HIGH]."""
        spec = SPEC[self.name]
        if self.what == "sd":
            return replace(self, low=0.0, high=CV_HIGH, logged=False)
        if spec.scale == "log" and base.mean > 0:
            return replace(self, low=max(spec.low, base.mean / PRIOR_FACTOR), high=min(spec.high, base.mean * PRIOR_FACTOR),
                           logged=True)  # fmt: skip
        return replace(self, low=spec.low, high=spec.high, logged=False)

    @property
    def prior(self) -> tuple[float, float]:
        """The uniform prior's bounds on pyabc's scale."""
        return (np.log(self.low), np.log(self.high)) if self.logged else (self.low, self.high)

    @property
    def prior_text(self) -> str:
        """The prior in words, e.g. ``log-uniform in [0.05, 1.25] s/bit``."""
        if self.what == "sd":
            return f"sd / mean uniform in [0, {CV_HIGH:g}]"
        return f"{'log-' if self.logged else ''}uniform in [{self.low:.4g}, {self.high:.4g}] {SPEC[self.name].unit}"

    def natural(self, theta: np.ndarray) -> np.ndarray:
        return np.exp(theta) if self.logged else np.asarray(theta, dtype=float)


def parse_fit(text: str) -> tuple[Free, ...]:
    """``--fit NAME[:sd],...`` as free values (errors name the option and the value)."""
    free = []
    for part in (p.strip() for p in text.split(",")):
        name, _, what = part.partition(":")
        if name not in SPEC or what not in ("", "sd"):
            raise CalibrationError(f"--fit {text!r}: {part!r}: give NAME (its population mean) or NAME:sd (its spread "
                                   f"between people), NAME one of {', '.join(NAMES)}")
        free.append(Free(name, "sd" if what else "mean"))
    if len({f.key for f in free}) != len(free):
        raise CalibrationError(f"--fit {text!r}: names a value twice")
    return tuple(free)


def hold_out(targets, patterns) -> tuple[Target, ...]:
    """The targets with those whose key matches one of ``patterns`` (shell patterns) held out."""
    targets = list(targets)
    for pattern in patterns:
        if not any(fnmatch.fnmatchcase(t.key, pattern) for t in targets):
            raise CalibrationError(f"--hold-out {pattern!r}: matches no number (the numbers: "
                                   f"{', '.join(t.key for t in targets)})")
    held = [replace(t, held_out=True) if any(fnmatch.fnmatchcase(t.key, p) for p in patterns) else t for t in targets]
    if patterns and all(t.held_out for t in held):
        raise CalibrationError(f"--hold-out {' '.join(map(repr, patterns))}: every number is held out: nothing is "
                               "left to fit")
    return tuple(held)


@dataclass(frozen=True)
class CalibrationRequest:
    """What a calibration fits, to what, and how hard it tries."""

    protocol: Protocol
    targets: tuple[Target, ...]
    source: str
    """What the targets came from (a study, a trials table, a targets file), for the record."""
    digest: str
    """The SHA-256 of that data."""
    free: tuple[Free, ...] = field(default_factory=lambda: parse_fit(",".join(DEFAULT_FIT)))
    base: Population | None = None
    """The population whose values are kept where nothing is fitted (None: the default)."""
    particles: int = 100
    generations: int = 5
    participants: int = 15
    """Participants per group of each simulated study."""
    check: int = 20
    seed: int = 1
    unused: tuple[str, ...] = ()
    """What of the data the targets do not use, in words."""

    def __post_init__(self):
        for option, value, least in (("--particles", self.particles, 2), ("--generations", self.generations, 1),
                                     ("--participants", self.participants, 2), ("--check", self.check, 2)):
            if value < least:
                raise CalibrationError(f"{option} = {value!r}: must be at least {least}")
        if self.participants > MAX_PARTICIPANTS:
            raise CalibrationError(f"--participants = {self.participants!r}: simulated studies have at most "
                                   f"{MAX_PARTICIPANTS} participants per group (without --participants, the data's "
                                   "smallest group sets it: give --participants N)")
        if not self.free:
            raise CalibrationError("--fit: free at least one value")
        if not any(not t.held_out for t in self.targets):
            raise CalibrationError(f"{self.source}: every number is held out: nothing is left to fit")
        retained = [f.name for f in self.free if SPEC[f.name].retention]
        if retained and not self.protocol.program:
            raise CalibrationError(f"--fit: {', '.join(retained)}: a parameter of retention across sessions, which "
                                   f"protocol {self.protocol.name!r} (one session, no [[sessions]]) carries nothing "
                                   "about; fit it to a training program's pilot")
        base = self.population.parameters
        object.__setattr__(self, "free", tuple(f.with_prior(base[f.name]) for f in self.free))  # priors from the base

    @property
    def population(self) -> Population:
        return self.base or default_population()

    def record(self, profile: str) -> dict:
        """Everything the result depends on (``calibration.json``; a resumed run must match it)."""
        return json.loads(json.dumps({
            "profile": profile,
            "source": self.source,
            "sha256": self.digest,
            "protocol_sha256": self.protocol.sha256,
            "targets": [[t.key, t.value, t.se, t.held_out] for t in self.targets],
            "free": [[f.key, f.prior_text] for f in self.free],
            "base_sha256": self.population.sha256,
            "particles": self.particles,
            "generations": self.generations,
            "participants": self.participants,
            "check": self.check,
            "seed": self.seed,
        }))  # fmt: skip


@dataclass(frozen=True)
class StudyModel:
    """pyabc's model: one simulated study from a particle's population, as the targets' statistics."""

    protocol: Protocol
    participants: int
    base: Population
    free: tuple[Free, ...]
    targets: tuple[Target, ...]
    simulate: Callable = simulate_trials

    def population(self, parameters) -> Population:
        """The base population with the particle's free values."""
        spreads = dict(self.base.parameters)
        for name in {f.name for f in self.free}:
            base = self.base.parameters[name]
            mean = self.value(parameters, Free(name, "mean"), base.mean)
            cv = self.value(parameters, Free(name, "sd"), base.sd / base.mean if base.mean > 0 else None)
            spreads[name] = Spread(mean, base.sd if cv is None else cv * mean)
        return Population(spreads, where="a calibration particle")

    def value(self, parameters, free: Free, otherwise):
        chosen = [f for f in self.free if f.key == free.key]
        return float(chosen[0].natural(parameters[_pyabc_name(chosen[0])])) if chosen else otherwise

    def __call__(self, parameters) -> dict:
        study_seed = int(np.random.randint(0, 2**31 - 1))
        trials = self.simulate(self.protocol, self.participants, study_seed, population=self.population(parameters))
        return {_stat_name(i): float(v) for i, v in enumerate(simulated_values(trials, self.targets))}


def _pyabc_name(free: Free) -> str:
    """The name pyabc knows the value by (its value on pyabc's scale: a logarithm where logged)."""
    return f"{free.name}.{'cv' if free.what == 'sd' else 'log_mean' if free.logged else 'mean'}"


def _stat_name(index: int) -> str:
    return f"s{index:03d}"


@dataclass(frozen=True)
class Discrepancy:
    """pyabc's distance: the root mean square, over the fitted targets, of each one's gap in
    standard errors (``Target.z``)."""

    targets: tuple[Target, ...]

    def __call__(self, x: dict, x_0: dict) -> float:
        gaps = [t.z(x[_stat_name(i)]) for i, t in enumerate(self.targets) if not t.held_out]
        return float(np.sqrt(np.mean(np.square(gaps))))


@dataclass(frozen=True)
class CalibrationResult:
    """The fitted population, the posterior (``POSTERIOR``'s rows), the check (``CHECK``'s rows),
    the run's summary and where the files are."""

    population: Population
    posterior: pd.DataFrame
    check: pd.DataFrame
    summary: dict
    profile: Path


def calibrate(request: CalibrationRequest, profile: str | Path, client, *, resume: bool = False,
              progress: bool = True, simulate: Callable = simulate_trials) -> CalibrationResult:
    """Fit the population to ``request.targets`` and write the run's files (module docstring).

    Parameters
    ----------
    request : CalibrationRequest
        What to fit, to what.
    profile : str or Path
        Where the fitted ``PROFILE.toml`` goes; the run's other files go beside it.
    client : distributed.Client
        The Dask client the simulated studies run on (``microg.power.run.dask_client``).
    resume : bool
        Continue the run already beside ``profile`` (same request); without it such a folder is refused.
    progress : bool
        Show progress (accepted particles, studies done, their rate, time left).
    simulate : callable
        The in-silico study, ``simulate_trials``'s signature.
    """
    import pyabc

    logging.getLogger("ABC").setLevel(logging.WARNING)  # the progress bars say what pyabc's log would
    started = time.monotonic()
    profile = Path(profile)
    folder = profile.parent
    _claim(folder, profile, request.record(profile.name), resume)
    needed = protocol_through(request.protocol, [t.statistic for t in request.targets])  # fitted and held out
    model = StudyModel(needed, request.participants, request.population, request.free, request.targets, simulate)
    prior = pyabc.Distribution(**{_pyabc_name(f): pyabc.RV("uniform", f.prior[0], f.prior[1] - f.prior[0])
                                  for f in request.free})  # fmt: skip
    cache = EvaluationCache(folder / EVALUATIONS)
    sampler = OrderedDaskSampler(client, request.seed, cache, request.generations, progress)
    abc = pyabc.ABCSMC(model, prior, Discrepancy(request.targets), population_size=request.particles,
                       eps=pyabc.MedianEpsilon("from_sample"), sampler=sampler)  # fmt: skip
    observed = {_stat_name(i): t.value for i, t in enumerate(request.targets)}
    database = f"sqlite:///{(folder / HISTORY).resolve()}"
    history = abc.load(database, 1, observed) if (folder / HISTORY).exists() else abc.new(database, observed)
    remaining = request.generations - history.n_populations
    if remaining > 0:
        history = abc.run(max_nr_populations=remaining)
    parameters, weights = history.get_distribution(0, history.max_t)
    posterior = posterior_table(request.free, parameters, weights)
    population = fitted_population(request, parameters, weights, str(profile))
    draws = _check_draws(request, parameters, weights)
    simulated, fresh = _check_studies(client, model, draws, request.seed, cache)
    cache.close()
    check = check_table(request.targets, simulated)
    epsilon = float(history.get_all_populations()["epsilon"].iloc[-1])
    studies = int(history.total_nr_simulations)
    summary = {
        "seconds": round(time.monotonic() - started, 2),
        "studies": studies + request.check,
        "studies_run": sampler.studies_run + fresh,
        "epsilon": epsilon,
        "workers": max(sampler.workers_seen, len(client.scheduler_info()["workers"])),
    }
    population = Population(population.parameters, _calibration_table(request, studies, epsilon), str(profile))
    posterior.to_csv(folder / POSTERIOR, index=False)
    check.to_csv(folder / CHECK, index=False)
    plot_check(check, folder / PICTURE, f"{request.source}: {request.check} studies from the posterior")
    profile.write_text(population.to_toml() + "\n", encoding="utf-8")
    return CalibrationResult(population, posterior, check, summary, profile)


def _weighted_quantile(values: np.ndarray, weights: np.ndarray, alpha: float) -> float:
    from pyabc.weighted_statistics import weighted_quantile

    return float(weighted_quantile(np.asarray(values, dtype=float), np.asarray(weights, dtype=float), alpha=alpha))


def _natural_values(request: CalibrationRequest, parameters: pd.DataFrame) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each fitted parameter's (mean, sd) per particle, on the parameter's own scale."""
    base = request.population.parameters
    values = {}
    for name in dict.fromkeys(f.name for f in request.free):
        spread = base[name]
        mean = np.full(len(parameters), spread.mean)
        sd = np.full(len(parameters), spread.sd)
        for f in request.free:
            if f.key == name:
                mean = f.natural(parameters[_pyabc_name(f)].to_numpy())
        cv = next((parameters[_pyabc_name(f)].to_numpy() for f in request.free if f.key == f"{name}:sd"), None)
        if cv is not None:
            sd = cv * mean
        elif spread.mean > 0:
            sd = spread.sd / spread.mean * mean
        values[name] = (mean, sd)
    return values


def posterior_table(free, parameters: pd.DataFrame, weights: np.ndarray) -> pd.DataFrame:
    """One row per free value: its prior, posterior mean and 90 % credible interval (its own
    scale; a spread as sd / mean)."""
    rows = []
    tail = (1 - LEVEL) / 2
    for f in free:
        values = f.natural(parameters[_pyabc_name(f)].to_numpy())
        rows.append({"value": f.key, "unit": "sd / mean" if f.what == "sd" else SPEC[f.name].unit,
                     "prior": f.prior_text,
                     "mean": float(np.sum(values * weights)),
                     "ci_low": _weighted_quantile(values, weights, tail),
                     "ci_high": _weighted_quantile(values, weights, 1 - tail)})  # fmt: skip
    return pd.DataFrame(rows)


def fitted_population(request: CalibrationRequest, parameters: pd.DataFrame, weights: np.ndarray,
                      where: str) -> Population:
    """The base population with each fitted parameter's posterior mean as ``mean``, the posterior
    mean of its SD between people as ``sd`` (fitted, or the base's coefficient of variation kept),
    and the 90 % credible interval of the mean as ``ci_low``, ``ci_high`` where the mean was fitted."""
    tail = (1 - LEVEL) / 2
    spreads = dict(request.population.parameters)
    fitted_means = {f.name for f in request.free if f.what == "mean"}
    for name, (mean, sd) in _natural_values(request, parameters).items():
        spec = SPEC[name]
        centre = float(np.clip(np.sum(mean * weights), spec.low, spec.high))
        interval = ((_weighted_quantile(mean, weights, tail), _weighted_quantile(mean, weights, 1 - tail))
                    if name in fitted_means else (None, None))  # fmt: skip
        spreads[name] = Spread(centre, float(np.sum(sd * weights)), *interval)
    return Population(spreads, where=where)


def _check_draws(request: CalibrationRequest, parameters: pd.DataFrame, weights: np.ndarray) -> list[dict]:
    """``request.check`` particles drawn from the posterior (with replacement, by weight), seeded."""
    rng = np.random.default_rng(np.random.SeedSequence([request.seed, CHECK_STREAM]))
    rows = rng.choice(len(parameters), size=request.check, p=weights / weights.sum())
    return [{k: float(v) for k, v in parameters.iloc[row].items()} for row in rows]


def _check_studies(client, model: StudyModel, draws: list[dict], seed: int,
                   cache: EvaluationCache) -> tuple[np.ndarray, int]:
    """The targets' statistics in one simulated study per draw (studies x targets), on Dask, and how
    many studies ran now; each study seeded from the run's seed and its index, each kept in the
    cache as it arrives."""
    from distributed import as_completed
    from pyabc.parameters import Parameter

    done = cache.read("check")
    pickled = client.scatter(cloudpickle.dumps(model), broadcast=True)
    futures = {client.submit(pickled_call, pickled, [seed, CHECK_STREAM, i], Parameter(draw), pure=False): i
               for i, draw in enumerate(draws) if i not in done}  # fmt: skip
    for future in as_completed(futures):
        done[futures[future]] = future.result()
        cache.write("check", futures[future], done[futures[future]])
        future.release()
    values = np.array([[done[i][_stat_name(j)] for j in range(len(model.targets))] for i in range(len(draws))])
    return values, len(futures)


def check_table(targets, simulated: np.ndarray) -> pd.DataFrame:
    """The posterior-predictive check (``CHECK``): each target's value beside the simulated
    studies' mean and 90 % interval of the same statistic, and whether it was fitted or held out."""
    tail = (1 - LEVEL) / 2
    rows = []
    for j, t in enumerate(targets):
        column = simulated[:, j]
        column = column[np.isfinite(column)]
        low, high = (np.quantile(column, [tail, 1 - tail]) if len(column) else (np.nan, np.nan))
        inside = (low > t.value if t.direction == "above" else high < t.value if t.direction == "below"
                  else low <= t.value <= high)  # fmt: skip
        rows.append({"measure": t.key, "data": t.value, "se": t.se,
                     "simulated_mean": float(column.mean()) if len(column) else np.nan,
                     "simulated_low": float(low), "simulated_high": float(high),
                     "studies": len(column), "within": bool(inside),
                     "use": "held_out" if t.held_out else "fitted"})  # fmt: skip
    return pd.DataFrame(rows)


def plot_check(check: pd.DataFrame, path: Path, title: str) -> None:
    """The check as a picture: one panel per kind of number (measure and statistic), one row per
    number: the simulated studies' 90 % interval and mean, and the data (filled: fitted; open: held out)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = check["measure"].str.extract(r"^([^\[]+)\[")[0]
    panels = list(dict.fromkeys(kinds))
    heights = [max(1, (kinds == k).sum()) for k in panels]
    figure, axes = plt.subplots(len(panels), 1, figsize=(8, 1.2 + 0.32 * sum(heights) + 0.5 * len(panels)),
                                gridspec_kw={"height_ratios": heights}, squeeze=False)  # fmt: skip
    for axis, kind in zip(axes[:, 0], panels):
        rows = check[kinds == kind].reset_index(drop=True)
        y = np.arange(len(rows))[::-1]
        axis.hlines(y, rows["simulated_low"], rows["simulated_high"], color="tab:blue", lw=3, alpha=0.5,
                    label="simulated, 90 % interval")  # fmt: skip
        axis.plot(rows["simulated_mean"], y, "|", color="tab:blue", ms=12, label="simulated mean")
        fitted = (rows["use"] == "fitted").to_numpy()
        axis.plot(rows["data"][fitted], y[fitted], "o", color="black", label="data, fitted")
        axis.plot(rows["data"][~fitted], y[~fitted], "o", mfc="none", color="black", label="data, held out")
        axis.set_yticks(y, [m[len(kind):] for m in rows["measure"]], fontsize=7)
        axis.set_title(kind, fontsize=9, loc="left")
        axis.grid(axis="x", alpha=0.3)
    figure.suptitle(title, fontsize=9)
    figure.legend(*axes[0, 0].get_legend_handles_labels(), loc="upper center", ncol=4, fontsize=7,
                  bbox_to_anchor=(0.5, 0.97), frameon=False)  # above the panels, off their data
    figure.tight_layout(rect=(0, 0, 1, 0.95))
    figure.savefig(path, dpi=120)
    plt.close(figure)


def _calibration_table(request: CalibrationRequest, studies: int, epsilon: float) -> dict:
    """The profile's ``[calibration]`` table: what it was fitted to, how and when."""
    from microg import __version__

    return {
        "fitted_to": request.source,
        "sha256": request.digest,
        "protocol": request.protocol.name,
        "protocol_sha256": request.protocol.sha256,
        "measures_fitted": [t.key for t in request.targets if not t.held_out],
        "measures_held_out": [t.key for t in request.targets if t.held_out],
        "not_used": list(request.unused),
        "free": [f.key for f in request.free],
        "priors": [f"{f.key}: {f.prior_text}" for f in request.free],
        "method": "ABC-SMC (pyabc), one simulated study per particle, distance the RMS of the fitted numbers' gaps in "
                  "standard errors, epsilon the median of the last generation's distances",
        "particles": request.particles,
        "generations": request.generations,
        "participants_per_group": request.participants,
        "studies": studies,
        "final_epsilon": epsilon,
        "check_studies": request.check,
        "seed": request.seed,
        "date": datetime.date.today().isoformat(),
        "microg_version": __version__,
    }


def _claim(folder: Path, profile: Path, record: dict, resume: bool) -> None:
    """Make ``folder`` this run's: new, or the same run when resuming."""
    path = folder / RECORD
    if path.exists():
        if not resume:
            raise CalibrationError(f"--out {profile}: {folder} holds a calibration already ({RECORD}); continue it "
                                   "with --resume or write the profile into another folder")
        before = json.loads(path.read_text())
        for key, value in record.items():
            if before.get(key) != value:
                raise CalibrationError(f"--resume: {path}: {key} = {json.dumps(before.get(key))[:200]}, but this run "
                                       f"asks for {json.dumps(value)[:200]}; a run resumes only with the same settings")
        return
    folder.mkdir(parents=True, exist_ok=True)
    for name in (profile.name, HISTORY, EVALUATIONS, POSTERIOR, CHECK, PICTURE):
        if (folder / name).exists():
            raise CalibrationError(f"--out {profile}: {folder} holds {name} from another run; write the profile into "
                                   "another folder")
    path.write_text(json.dumps(record, indent=2) + "\n")


def describe(result: CalibrationResult) -> str:
    """The posterior and what was fitted, as the command prints it."""
    posterior = result.posterior.rename(columns={"ci_low": "5 %", "ci_high": "95 %"})
    check = result.check
    lines = ["posterior (mean and 90 % credible interval):",
             posterior.to_string(index=False, float_format=lambda v: f"{v:.4g}"), "",
             f"fitted ({(check['use'] == 'fitted').sum()} numbers):"]  # fmt: skip
    table = check[["measure", "data", "simulated_mean", "simulated_low", "simulated_high", "within"]]
    lines.append(table[check["use"] == "fitted"].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    held = check["use"] == "held_out"
    if held.any():
        lines += ["", f"held out ({held.sum()} numbers, reported, not fitted):",
                  table[held].to_string(index=False, float_format=lambda v: f"{v:.4g}")]  # fmt: skip
    unused = result.population.calibration.get("not_used", [])
    if unused:
        lines += ["", "not used: " + "; ".join(unused)]
    return "\n".join(lines)


__all__ = ["CalibrationError", "CalibrationRequest", "CalibrationResult", "Free", "TargetError", "calibrate",
           "describe", "hold_out", "parse_fit"]
