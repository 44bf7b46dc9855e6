"""The effects a study expects: cell means per group and within level, and the covariance of a
participant's repeated measures in each group.

An effects file (TOML) gives the means and either SDs and correlations or a full covariance per
group. The SD is one number or a table per group of one SD per level; the correlation one number
between any two repeated measures (compound symmetry) or a table per group of every pair (a
correlation matrix: sphericity need not hold)::

    sd = 20.0
    correlation = 0.5
    [means.veteran]
    cube = 45.0
    flat_cuboid = 55.0
    long_cuboid = 55.0
    [means.beginner]
    cube = 55.0
    flat_cuboid = 70.0
    long_cuboid = 70.0

    # a correlation matrix per group instead of the one correlation, every pair named:
    [correlation.veteran]
    cube = { cube = 1.0, flat_cuboid = 0.6, long_cuboid = 0.3 }
    ...
    # an SD per group and level instead of the one SD:
    [sd.veteran]
    cube = 18.0
    ...
    # or, instead of sd and correlation, a covariance per group, every pair named:
    [covariance.veteran]
    cube = { cube = 400.0, flat_cuboid = 200.0, long_cuboid = 200.0 }
    ...

Every error names the file, the key and the value. The numbers must lie where the analysis can
resolve them in double precision: every SD between ``MIN_SD`` and ``MAX_SD`` and every mean within
``MAX_MEAN_SDS`` SDs of zero (the ANOVA sums the squared values: with means 10^5 SDs from zero, the
SD is lost to rounding and the exact power of the paper's design is off by 0.03).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from microg.power.design import Design, PowerInputError

MIN_SD, MAX_SD = 1e-50, 1e50
"""The SDs (and square roots of the variances) the analysis handles: their squares and the sums of
squares over participants stay normal double-precision numbers."""
MAX_MEAN_SDS = 1e4
"""How far from zero a mean may lie, in the smallest SD; the exact power of the paper's design is
the same to 1e-11 up to here, and off by 0.03 at 1e5."""
MAX_FILE_BYTES = 1 << 20
"""An effects file is a few hundred bytes; anything over a megabyte is not one."""


@dataclass(frozen=True)
class Effects:
    """Population cell means ``(groups, levels)`` and covariances ``(groups, levels, levels)`` for a
    design, in the design's order; ``source`` says where they came from."""

    design: Design
    means: np.ndarray
    covariances: np.ndarray
    source: str

    def as_dict(self) -> dict:
        """The effects in the effects file's layout (full covariance form)."""
        d = self.design
        return {
            "means": {g: {level: float(self.means[i, j]) for j, level in enumerate(d.levels)}
                      for i, g in enumerate(d.groups)},
            "covariance": {g: {a: {b: float(self.covariances[i, j, m]) for m, b in enumerate(d.levels)}
                               for j, a in enumerate(d.levels)} for i, g in enumerate(d.groups)},
        }

    def to_toml(self) -> str:
        """The effects as an effects file that ``read_effects`` reads back."""
        d = self.design
        lines = [f"# effects for protocol {d.protocol!r}: {d.between} x {d.within}; {self.source}", ""]
        for i, group in enumerate(d.groups):
            lines.append(f"[means.{group}]")
            lines += [f"{level} = {float(self.means[i, j])!r}" for j, level in enumerate(d.levels)]
            lines.append("")
        for i, group in enumerate(d.groups):
            lines.append(f"[covariance.{group}]")
            for j, a in enumerate(d.levels):
                row = ", ".join(f"{b} = {float(self.covariances[i, j, m])!r}" for m, b in enumerate(d.levels))
                lines.append(f"{a} = {{ {row} }}")
            lines.append("")
        return "\n".join(lines)


def compound_symmetry(sd: float, correlation: float, k: int) -> np.ndarray:
    """The k x k covariance with variance sd**2 and covariance correlation * sd**2 off the diagonal."""
    return sd**2 * ((1 - correlation) * np.eye(k) + correlation * np.ones((k, k)))


def effects_from_means(
    means: pd.DataFrame,
    design: Design,
    dv: str = "mean",
    sd: float | None = None,
    correlation: float | None = None,
    covariance: dict | None = None,
    source: str = "means table",
) -> Effects:
    """Effects from a tidy table of cell means and either ``sd`` + ``correlation`` (compound
    symmetry) or ``covariance`` (group -> k x k array in the design's level order).

    Parameters
    ----------
    means : pandas.DataFrame
        One row per group and within level; columns ``design.between``, ``design.within`` and ``dv``.
    design : Design
        The design the means belong to.
    dv : str
        Column of the means.
    sd, correlation : float, optional
        Common SD and correlation between any two repeated measures.
    covariance : dict, optional
        A full covariance per group instead.
    source : str
        Where the effects come from, for messages and the run's record.

    Returns
    -------
    Effects

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> from microg.power import design_from_protocol, effects_from_means
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> means = pd.DataFrame({"group": ["veteran"] * 3 + ["beginner"] * 3, "object": list(design.levels) * 2,
    ...                       "mean": [45.0, 55, 55, 55, 70, 70]})
    >>> effects_from_means(means, design, sd=20.0, correlation=0.5).covariances[0]
    array([[400., 200., 200.],
           [200., 400., 200.],
           [200., 200., 400.]])
    """
    wide = means.pivot_table(index=design.between, columns=design.within, values=dv, aggfunc="first")
    raw = {g: {level: wide.at[g, level] for level in wide.columns if pd.notna(wide.at[g, level])} for g in wide.index}
    data: dict = {"means": raw}
    if covariance is not None:
        data["covariance"] = {g: {a: {b: float(np.asarray(c)[i, j]) for j, b in enumerate(design.levels)}
                                  for i, a in enumerate(design.levels)} for g, c in covariance.items()}
    else:
        data.update(sd=sd, correlation=correlation)
    return _effects(data, design, source)


def read_effects(path: str | Path, design: Design) -> Effects:
    """Read and check an effects file (format in the module docstring) against the design.

    Raises
    ------
    PowerInputError
        Naming the file, key and value: a file that is not UTF-8 TOML, an unknown or missing group or
        level, a mean that is not a number, an SD (one, or a group's at a level) outside [MIN_SD,
        MAX_SD], a mean more than MAX_MEAN_SDS SDs from zero, a correlation outside (-1/(k-1), 1), a
        correlation matrix whose diagonal is not 1, with an entry outside (-1, 1), or that is not
        symmetric positive definite, a covariance that is not symmetric positive definite, or both
        forms at once.
    """
    path = Path(path)
    try:
        with open(path, "rb") as stream:
            raw = stream.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise PowerInputError(f"{path}: cannot read effects file: {error.strerror}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise PowerInputError(f"{path}: over {MAX_FILE_BYTES >> 20} MiB: not an effects file (a few lines of TOML)")
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as error:
        raise PowerInputError(f"{path}: not UTF-8 text (byte {raw[error.start]:#04x} at position {error.start}); "
                              "save the effects file as UTF-8") from None
    except tomllib.TOMLDecodeError as error:
        raise PowerInputError(f"{path}: not valid TOML: {error}") from None
    except RecursionError:
        raise PowerInputError(f"{path}: not an effects file: its tables or arrays are nested too deeply") from None
    return _effects(data, design, str(path))


def _effects(data: dict, design: Design, where: str) -> Effects:
    def fail(key: str, value, message: str) -> PowerInputError:
        return PowerInputError(f"{where}: {key} = {value!r}: {message}")

    d = design
    unknown = sorted(set(data) - {"means", "sd", "correlation", "covariance"})
    if unknown:
        raise fail(unknown[0], data[unknown[0]], "unknown key (known: means, sd, correlation, covariance)")
    means = np.array([[_number(_cell(data, "means", group, level, d, where), f"means.{group}.{level}", fail)
                       for level in d.levels] for group in d.groups])
    if "covariance" in data:
        for key in ("sd", "correlation"):
            if key in data:
                raise fail(key, data[key], "give either sd and correlation or a covariance per group, not both")
        covariances = np.array([_covariance(data, group, d, where, fail) for group in d.groups])
    else:
        for key in ("sd", "correlation"):
            if data.get(key) is None:
                raise PowerInputError(f"{where}: missing key {key} (or a [covariance.<group>] table per group)")
        sd = _standard_deviations(data, d, where, fail)
        correlations = _correlations(data, d, where, fail)
        covariances = sd[:, :, None] * correlations * sd[:, None, :]
        # symmetric to the last bit: s_i r s_j and s_j r s_i may round apart
        covariances = (covariances + covariances.transpose(0, 2, 1)) / 2
    _check_means(means, covariances, d, fail)
    return Effects(d, means, covariances, where)


def _check_means(means: np.ndarray, covariances: np.ndarray, design: Design, fail) -> None:
    """Every mean within ``MAX_MEAN_SDS`` of the smallest SD of zero."""
    smallest = float(np.sqrt(np.diagonal(covariances, axis1=1, axis2=2).min()))
    i, j = np.unravel_index(np.argmax(np.abs(means)), means.shape)
    if abs(means[i, j]) > MAX_MEAN_SDS * smallest:
        raise fail(f"means.{design.groups[i]}.{design.levels[j]}", float(means[i, j]),
                   f"lies {abs(means[i, j]) / smallest:.5g} SDs (SD {smallest:g}) from zero; the analysis resolves "
                   f"means up to {MAX_MEAN_SDS:g} SDs from zero: give the measure in other units or shift it")


def _cell(data: dict, table: str, group: str, level: str, design: Design, where: str):
    """``data[table][group][level]``, with errors for unknown and missing names."""
    d = design
    section = data.get(table)
    if not isinstance(section, dict):
        raise PowerInputError(f"{where}: missing table [{table}.<group>] (groups: {', '.join(d.groups)})")
    for name, value in section.items():
        if name not in d.groups:
            raise PowerInputError(f"{where}: {table}.{name} = {value!r}: no group {name!r} in protocol "
                                  f"{d.protocol!r} (groups: {', '.join(d.groups)})")
        if not isinstance(value, dict):
            raise PowerInputError(f"{where}: {table}.{name} = {value!r}: must be a table of {d.within} names")
        for other, cell in value.items():
            if other not in d.levels:
                raise PowerInputError(f"{where}: {table}.{name}.{other} = {cell!r}: no {d.within} {other!r} in "
                                      f"protocol {d.protocol!r} ({d.within}s: {', '.join(d.levels)})")
    if group not in section:
        raise PowerInputError(f"{where}: missing table [{table}.{group}]")
    if level not in section[group]:
        raise PowerInputError(f"{where}: missing key {table}.{group}.{level}")
    return section[group][level]


def _number(value, key: str, fail) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise fail(key, value, "must be a finite number")
    try:
        number = float(value)
    except OverflowError:
        raise fail(key, value, "too large for a double-precision number") from None
    if not math.isfinite(number):
        raise fail(key, value, "must be a finite number")
    return number


def _standard_deviations(data: dict, design: Design, where: str, fail) -> np.ndarray:
    """(groups, levels): the one ``sd``, or ``[sd.<group>]`` tables of one SD per level."""
    d = design
    if isinstance(data["sd"], dict):
        sd = np.array([[_number(_cell(data, "sd", group, level, d, where), f"sd.{group}.{level}", fail)
                        for level in d.levels] for group in d.groups])  # fmt: skip
        bad = np.argwhere((sd < MIN_SD) | (sd > MAX_SD))
        if len(bad):
            i, j = bad[0]
            raise fail(f"sd.{d.groups[i]}.{d.levels[j]}", float(sd[i, j]),
                       f"must be a positive number from {MIN_SD:g} to {MAX_SD:g}")
        return sd
    sd = _number(data["sd"], "sd", fail)
    if not MIN_SD <= sd <= MAX_SD:
        raise fail("sd", data["sd"], f"must be a positive number from {MIN_SD:g} to {MAX_SD:g}")
    return np.full((len(d.groups), len(d.levels)), sd)


def _correlations(data: dict, design: Design, where: str, fail) -> np.ndarray:
    """(groups, levels, levels): the one ``correlation`` (compound symmetry), or ``[correlation.<group>]``
    tables of every pair (1 on the diagonal, symmetric, positive definite)."""
    d = design
    k = len(d.levels)
    if isinstance(data["correlation"], dict):
        matrices = []
        for group in d.groups:
            matrix = _matrix(data, "correlation", group, d, where, fail)
            for i, a in enumerate(d.levels):
                if matrix[i, i] != 1:
                    raise fail(f"correlation.{group}.{a}.{a}", float(matrix[i, i]), "a correlation with itself is 1")
                for j, b in enumerate(d.levels):
                    if i != j and not -1 < matrix[i, j] < 1:
                        raise fail(f"correlation.{group}.{a}.{b}", float(matrix[i, j]), "must lie in (-1, 1)")
            if np.linalg.eigvalsh(matrix).min() <= 0:
                raise fail(f"correlation.{group}", data["correlation"][group], "is not positive definite")
            matrices.append(matrix)
        return np.array(matrices)
    rho = _number(data["correlation"], "correlation", fail)
    low = -1 / (k - 1)
    if not low < rho < 1:
        raise fail("correlation", data["correlation"],
                   f"must lie in ({low:.4g}, 1) for {k} levels of {d.within}: otherwise the covariance of "
                   "the repeated measures is not positive definite")
    return np.array([compound_symmetry(1.0, rho, k)] * len(d.groups))


def _covariance(data: dict, group: str, design: Design, where: str, fail) -> np.ndarray:
    matrix = _matrix(data, "covariance", group, design, where, fail)
    for i, a in enumerate(design.levels):
        if not MIN_SD**2 <= matrix[i, i] <= MAX_SD**2:
            raise fail(f"covariance.{group}.{a}.{a}", float(matrix[i, i]),
                       f"a variance must be a positive number from {MIN_SD**2:g} to {MAX_SD**2:g}")
    if np.linalg.eigvalsh(matrix).min() <= 0:
        raise fail(f"covariance.{group}", data["covariance"][group], "is not positive definite")
    return matrix


def _matrix(data: dict, table: str, group: str, design: Design, where: str, fail) -> np.ndarray:
    """A levels x levels table ``[table.<group>]``, every pair named, symmetric."""
    d = design
    rows = []
    for a in d.levels:
        row = _cell(data, table, group, a, d, where)
        if not isinstance(row, dict):
            raise fail(f"{table}.{group}.{a}", row, f"must be a table with one value per {d.within}")
        extra = sorted(set(row) - set(d.levels))
        if extra:
            raise fail(f"{table}.{group}.{a}.{extra[0]}", row[extra[0]],
                       f"no {d.within} {extra[0]!r} in protocol {d.protocol!r}")
        missing = [b for b in d.levels if b not in row]
        if missing:
            raise PowerInputError(f"{where}: missing key {table}.{group}.{a}.{missing[0]}")
        rows.append([_number(row[b], f"{table}.{group}.{a}.{b}", fail) for b in d.levels])
    matrix = np.array(rows)
    for i, a in enumerate(d.levels):
        for j, b in enumerate(d.levels):
            if not math.isclose(matrix[i, j], matrix[j, i], rel_tol=1e-9, abs_tol=1e-12):
                raise fail(f"{table}.{group}.{a}.{b}", float(matrix[i, j]),
                           f"must equal {table}.{group}.{b}.{a} = {float(matrix[j, i])!r} (symmetric)")
    return matrix
