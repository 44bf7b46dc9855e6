"""Populations of simulated participants: each person draws their own motor parameters.

A population says, for every parameter of the motor model (``PARAMETERS``), its mean and its
spread between people (``sd``); each simulated participant draws one value of each, from a seed of
their own, and keeps it for the whole session. Each parameter is log-normal (a positive time,
distance or ratio: the mean and SD are those of the values themselves) or, for a fraction in
(0, 1), logit-normal (the SD is carried to the logit scale by the delta method). The parameters are
drawn independently: no correlation between them is modelled.

A population is a file, ``PROFILE.toml``::

    [calibration]                 # only for a fitted population: what it was fitted to, how, when
    fitted_to = "..."
    method = "..."
    date = "..."

    [parameters.movement_slope]   # one table per parameter, each with exactly these keys
    mean = 0.35                   # the population mean (the parameter's unit)
    sd = 0.10                     # the SD between people
    ci_low = 0.30                 # with a calibration: the 90 % credible interval of the mean
    ci_high = 0.40

A parameter the file does not name keeps the default population's values (``default.toml``, shipped
in ``microg/protocols/populations``). What each parameter means, its unit and where its default
comes from is in ``PARAMETERS`` (and docs/simulated-participant.md).

Practice and retention: within a session each practised parameter follows the power law of practice
(``practise``); across sessions the practice of earlier sessions enters it discounted by how much of
it is retained after the days since (``effective_practice``: a power law of forgetting whose rate is
lower for practice spread over sessions further apart, the stability of the Predictive Performance
Equation), so a person's first session is exactly the power law of practice.
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from dataclasses import dataclass, field
from numbers import Integral, Real
from pathlib import Path
from typing import Mapping

import numpy as np

from microg.paths import POPULATIONS


class PopulationError(ValueError):
    """A population file that cannot be used; the message names the file, key and value."""


@dataclass(frozen=True)
class Parameter:
    """One parameter of the motor model: what it means, its unit, the values a person can have."""

    name: str
    unit: str
    meaning: str
    low: float
    """The smallest value a person can have (a drawn value is kept inside [low, high])."""
    high: float
    scale: str = "log"
    """``log`` (log-normal between people) or ``logit`` (a fraction, logit-normal)."""
    practised: bool = False
    """Whether practice improves it (``practise``)."""
    error: bool = False
    """A practised chance of an error: practice takes it toward none rather than toward
    ``trained_fraction`` of it (a skill's speed has a floor; a slip of attention need not)."""
    retention: bool = False
    """A parameter of retention across sessions (``effective_practice``), drawn from a random stream
    of its own: adding them changed no other parameter's draw for a given seed."""


PARAMETERS: tuple[Parameter, ...] = (
    Parameter("movement_intercept", "s", "a of Fitts' law T = a + b log2(D / W + 1)", 0.05, 3.0, practised=True),
    Parameter("movement_slope", "s/bit", "b of Fitts' law", 0.02, 2.0, practised=True),
    Parameter("carry_slowdown", "ratio", "movement times with the object held are this many times longer",
              1.0, 5.0),
    Parameter("shape_caution", "ratio", "extra slowdown per unit of log elongation (longest / shortest extent) "
              "of the object: the flat and the long cuboid are handled more carefully than the cube", 0.0, 3.0),
    Parameter("aim_sd", "m", "SD of a reach's or carry's endpoint error, per axis", 0.0005, 0.05, practised=True),
    Parameter("reaction_s", "s", "pause before every new movement", 0.1, 2.0),
    Parameter("hesitation_s", "s", "mean of an extra, exponentially distributed pause before every new movement",
              0.0, 20.0, practised=True),
    Parameter("new_object_pause_s", "s", "mean of an extra pause before the first reach for an object not "
              "handled before in the session", 0.0, 60.0),
    Parameter("drop_pause_s", "s", "mean of an extra pause before reaching again after a drop", 0.0, 60.0),
    Parameter("tremor_rms", "m", "physiological tremor, RMS per axis", 5e-6, 2e-3),
    Parameter("preshape_margin", "m", "how far each pressing phalanx stays from its face while the hand "
              "approaches", 0.002, 0.04),
    Parameter("closing_speed", "m/s", "how fast each side of the grip closes", 0.005, 0.5),
    Parameter("grip_safety", "ratio", "grip force over the force needed to hold the expected load", 0.5, 5.0),
    Parameter("drop_grip_gain", "ratio", "the grip force is raised by this fraction of itself for each drop "
              "in the task (a grip raised after a slip is kept in the lifts that follow)", 0.0, 5.0),
    Parameter("stiffness_belief_sd", "log", "SD of the participant's belief of a phalanx's stiffness (sizes the "
              "squeeze)", 0.0, 2.0, practised=True),
    Parameter("hold_margin_s", "s", "extra hold time beyond the required one", 0.0, 20.0),
    Parameter("clock_cv", "ratio", "coefficient of variation of the internal clock over one hold", 0.0, 0.5),
    Parameter("place_accept", "fraction", "fraction of the place radius the object must be within before "
              "holding starts (else a corrective sub-movement)", 0.05, 0.999, scale="logit"),
    Parameter("learning_rate", "exponent", "practice: what separates the person from their trained self "
              "shrinks as (1 + n)^-rate after n tasks", 0.0, 3.0),
    Parameter("trained_fraction", "fraction", "practice: the trained value of each practised parameter, as a "
              "fraction of the untrained one", 0.05, 0.999, scale="logit"),
    Parameter("grip_lapse", "probability", "chance that the grip lapses open during a carry, until a drop in the "
              "task has made the participant mind its grip (a bare hand feels no grip loosening)", 0.0, 0.95,
              practised=True, error=True),
    Parameter("forgetting_rate", "exponent", "retention: practice done t days before a session counts (1 + t)^-rate "
              "of itself in it, for massed practice (one session's); 0: nothing is forgotten", 0.0, 3.0,
              retention=True),
    Parameter("spaced_forgetting", "fraction", "retention: the forgetting rate of practice spread over sessions far "
              "apart, as a fraction of massed practice's (the rate falls toward it as the gaps between earlier "
              "sessions grow)", 0.05, 0.999, scale="logit", retention=True),
)
"""Every parameter of the motor model, in the order the participant's code reads them; the retention
parameters last."""
NAMES = tuple(p.name for p in PARAMETERS)
SPEC = {p.name: p for p in PARAMETERS}
KEYS = ("mean", "sd", "ci_low", "ci_high")


@dataclass(frozen=True)
class Spread:
    """One parameter across people: the population mean, the SD between people, and (when the
    population was fitted) the 90 % credible interval of the mean."""

    mean: float
    sd: float
    ci_low: float | None = None
    ci_high: float | None = None


@dataclass(frozen=True)
class Population:
    """Every parameter's spread between people; ``calibration`` says how it was fitted (or is empty)."""

    parameters: Mapping[str, Spread]
    calibration: Mapping[str, object] = field(default_factory=dict)
    where: str = "population"
    """The file it came from, for messages."""

    def __post_init__(self) -> None:
        for name in NAMES:
            if name not in self.parameters:
                raise PopulationError(f"{self.where}: [parameters.{name}] is missing")
        for name, spread in self.parameters.items():
            _check(self.where, name, spread)

    def draw(self, seed: int) -> np.ndarray:
        """One person's values of ``PARAMETERS`` (in that order), from their own seed: the motor
        parameters from one random stream, the retention parameters from another."""
        values = np.empty(len(NAMES))
        for stream, indices in _DRAWS:
            normals = np.random.default_rng(np.random.SeedSequence([int(seed), stream])).standard_normal(len(indices))
            for i, z in zip(indices, normals):
                values[i] = _value(PARAMETERS[i], self.parameters[NAMES[i]], z)
        return values

    @property
    def sha256(self) -> str:
        """The hash of its ``PROFILE.toml``: a run records which population it drew from."""
        return hashlib.sha256(self.to_toml().encode()).hexdigest()

    def to_toml(self) -> str:
        """The population as a ``PROFILE.toml`` (``read_population`` reads it back)."""
        lines = []
        if self.calibration:
            lines.append("[calibration]")
            lines += [f"{key} = {_toml_value(value)}" for key, value in self.calibration.items()]
            lines.append("")
        for name in NAMES:
            spread, spec = self.parameters[name], SPEC[name]
            lines.append(f"[parameters.{name}]  # {spec.unit}: {spec.meaning}")
            lines += [f"{key} = {getattr(spread, key)!r}" for key in KEYS if getattr(spread, key) is not None]
            lines.append("")
        return "\n".join(lines)


_PERSON_STREAM = 0x5057
"""Mixed into a participant's seed for their motor parameters, so that no other draw shares its stream."""
_RETENTION_STREAM = 0x5245
"""Mixed into a participant's seed for their retention parameters."""
_DRAWS = tuple((stream, tuple(i for i, p in enumerate(PARAMETERS) if p.retention == retention))
               for stream, retention in ((_PERSON_STREAM, False), (_RETENTION_STREAM, True)))
"""Each random stream and the indices in ``PARAMETERS`` of the parameters drawn from it, in order."""


def _value(spec: Parameter, spread: Spread, z: float) -> float:
    """The parameter's value ``z`` population SDs from the mean, on its scale, kept in [low, high]."""
    mean, sd = spread.mean, spread.sd
    if sd == 0:
        value = mean
    elif spec.scale == "log":
        sigma = math.sqrt(math.log1p((sd / mean) ** 2))
        value = mean * math.exp(sigma * z - sigma * sigma / 2)
    else:
        logit = math.log(mean / (1 - mean)) + z * sd / (mean * (1 - mean))
        value = 1 / (1 + math.exp(-logit))
    return min(max(value, spec.low), spec.high)


def _check(where: str, name: str, spread: Spread) -> None:
    if name not in SPEC:
        raise PopulationError(f"{where}: [parameters.{name}]: unknown parameter (known: {', '.join(NAMES)})")
    spec = SPEC[name]
    for key in KEYS:
        value = getattr(spread, key)
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise PopulationError(f"{where}: parameters.{name}.{key} = {value!r}: must be a finite number")
    if not spec.low <= spread.mean <= spec.high:
        raise PopulationError(f"{where}: parameters.{name}.mean = {spread.mean!r}: must lie in [{spec.low:g}, "
                              f"{spec.high:g}] ({spec.unit}: {spec.meaning})")
    if spread.sd < 0:
        raise PopulationError(f"{where}: parameters.{name}.sd = {spread.sd!r}: must be >= 0 (the SD between people)")
    if spread.sd > spec.high:
        raise PopulationError(f"{where}: parameters.{name}.sd = {spread.sd!r}: larger than the largest value a person "
                              f"may have ({spec.high:g} {spec.unit})")
    if spread.sd > 0 and spec.scale == "log" and spread.mean <= 0:
        raise PopulationError(f"{where}: parameters.{name}.mean = {spread.mean!r}: a log-normal parameter with a "
                              "spread needs a positive mean")
    if spec.scale == "logit" and not 0 < spread.mean < 1:
        raise PopulationError(f"{where}: parameters.{name}.mean = {spread.mean!r}: a fraction must lie in (0, 1)")
    if (spread.ci_low is None) != (spread.ci_high is None):
        raise PopulationError(f"{where}: parameters.{name}: give both ci_low and ci_high, or neither")
    if spread.ci_low is not None and spread.ci_low > spread.ci_high:
        raise PopulationError(f"{where}: parameters.{name}.ci_low = {spread.ci_low!r} is above ci_high = "
                              f"{spread.ci_high!r}")


def _toml_value(value) -> str:
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(value)


def population_from_dict(data: Mapping, where: str, base: Population | None = None) -> Population:
    """A population from a profile's parsed TOML; the parameters it does not name come from
    ``base`` (the default population when None)."""
    unknown = sorted(set(data) - {"parameters", "calibration"})
    if unknown:
        raise PopulationError(f"{where}: [{unknown[0]}]: unknown table (a profile has [parameters.NAME] tables "
                              "and an optional [calibration])")
    tables = data.get("parameters", {})
    if not isinstance(tables, Mapping):
        raise PopulationError(f"{where}: parameters = {tables!r}: must be tables [parameters.NAME]")
    parameters = dict((base or default_population()).parameters)
    for name, table in tables.items():
        if name not in SPEC:
            raise PopulationError(f"{where}: [parameters.{name}]: unknown parameter (known: {', '.join(NAMES)})")
        if not isinstance(table, Mapping):
            raise PopulationError(f"{where}: parameters.{name} = {table!r}: must be a table with mean and sd")
        extra = sorted(set(table) - set(KEYS))
        if extra:
            raise PopulationError(f"{where}: parameters.{name}.{extra[0]}: unknown key (known: {', '.join(KEYS)})")
        for key in ("mean", "sd"):
            if key not in table:
                raise PopulationError(f"{where}: parameters.{name}.{key} is missing")
        parameters[name] = Spread(**{key: table.get(key) for key in KEYS})
        _check(where, name, parameters[name])
    calibration = data.get("calibration", {})
    if not isinstance(calibration, Mapping):
        raise PopulationError(f"{where}: calibration = {calibration!r}: must be a table")
    return Population(parameters, dict(calibration), where)


def read_population(path: str | Path) -> Population:
    """The population in ``PROFILE.toml`` at ``path`` (errors name the file, key and value)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PopulationError(f"{path}: no such population file") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise PopulationError(f"{path}: cannot be read as TOML: {error}") from None
    return population_from_dict(data, str(path))


def default_population() -> Population:
    """The shipped default population (``POPULATIONS / "default.toml"``), read once."""
    global _DEFAULT
    if _DEFAULT is None:
        path = POPULATIONS / "default.toml"
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        _DEFAULT = Population({name: Spread(**table) for name, table in data["parameters"].items()},
                              dict(data.get("calibration", {})), str(path))
    return _DEFAULT


_DEFAULT: Population | None = None


EarlierSessions = tuple[tuple[float, int], ...]
"""A participant's earlier sessions, oldest first: (days from that session's date to this session's
date, tasks done in it)."""


def check_earlier_sessions(earlier_sessions: EarlierSessions, where: str = "earlier_sessions") -> None:
    """Raise ``ValueError`` naming ``where`` and the value unless each earlier session is (days >= 0,
    tasks >= 0), oldest first (days never growing)."""
    days_before = math.inf
    for session in earlier_sessions:
        if (not isinstance(session, tuple) or len(session) != 2
                or not isinstance(session[0], Real) or isinstance(session[0], bool) or not 0 <= session[0] < math.inf
                or not isinstance(session[1], Integral) or isinstance(session[1], bool) or session[1] < 0):
            raise ValueError(f"{where} = {earlier_sessions!r}: {session!r} must be (days >= 0, tasks done >= 0)")
        if session[0] > days_before:
            raise ValueError(f"{where} = {earlier_sessions!r}: sessions must come oldest first (days from each to this "
                             "session never growing)")
        days_before = session[0]


def effective_practice(values: Mapping[str, float], tasks_done: int, earlier_sessions: EarlierSessions = ()) -> float:
    """The practice that enters the power law of practice: the tasks done in this session plus each
    earlier session's, discounted by the days since it (docs/simulated-participant.md, "Learning and
    forgetting across days")::

        practice = k + sum_i n_i (1 + t_i)^-rate
        rate = forgetting_rate (1 - (1 - spaced_forgetting) (1 - S))
        S = mean over the gaps between consecutive earlier sessions of 1 / ln(e + gap)   (1 with one)

    ``k`` is ``tasks_done``, ``t_i`` the days from earlier session ``i`` to this one and ``n_i`` its
    tasks, from ``earlier_sessions`` (oldest first); ``values`` holds the person's
    ``forgetting_rate`` and ``spaced_forgetting`` (e.g. ``practise``'s). Nothing decays within a
    session, so without earlier sessions it is ``tasks_done``.

    >>> effective_practice({"forgetting_rate": 0.5, "spaced_forgetting": 0.5}, 2, ((3.0, 24),))
    14.0
    """
    if not earlier_sessions:
        return float(tasks_done)
    check_earlier_sessions(earlier_sessions)
    gaps = [older[0] - newer[0] for older, newer in zip(earlier_sessions, earlier_sessions[1:])]
    stability = sum(1.0 / math.log(math.e + gap) for gap in gaps) / len(gaps) if gaps else 1.0
    rate = values["forgetting_rate"] * (1.0 - (1.0 - values["spaced_forgetting"]) * (1.0 - stability))
    return tasks_done + sum(tasks * (1.0 + days) ** -rate for days, tasks in earlier_sessions)


def practise(person: np.ndarray, tasks_done: int, earlier_sessions: EarlierSessions = ()) -> dict[str, float]:
    """A person's parameters after ``tasks_done`` tasks of this session and ``earlier_sessions``
    (power law of practice on ``effective_practice`` n): each practised parameter moves from the
    person's drawn, untrained value toward ``trained_fraction`` of it (an error's chance toward none)
    as (1 + n)^-learning_rate, and no lower than the smallest value a person can have (``low``: a
    movement faster than that would jump further in a frame than a hand can); the others stay as
    drawn. ``person`` is ``Population.draw``'s."""
    values = dict(zip(NAMES, (float(v) for v in person)))
    remaining = (1.0 + effective_practice(values, tasks_done, earlier_sessions)) ** -values["learning_rate"]
    trained = values["trained_fraction"]
    for spec in PARAMETERS:
        if spec.practised:
            floor = 0.0 if spec.error else trained
            values[spec.name] = max(spec.low, values[spec.name] * (floor + (1.0 - floor) * remaining))
    return values
