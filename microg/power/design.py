"""The design a power analysis plans for, read from the protocol: groups between participants and
one factor within them (the objects, or the interaction models of the phases), and the tests the report
runs on it: three ANOVA terms and three families of Bonferroni-corrected pairwise contrasts."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # a Dask worker unpickling a Design needs no protocol machinery
    from microg.study.protocol import Protocol

WITHIN_FACTORS = ("object", "interaction")
MAX_N_PER_GROUP = 1000
"""The largest group size planned: exact power builds an n x n basis (8 MB at 1000), and 1000 per
group detect a standardised difference of 0.13 with power 0.8; a study needing more is not planned
by participants."""
"""What the within factor can be: the protocol's objects, or the interaction models its phases compare."""
CORRECTIONS = ("mauchly", "none", "GG", "HF")
"""Which p a within effect's test reads: ``mauchly`` the report's rule (Greenhouse-Geisser where
Mauchly's test rejects sphericity at alpha), ``none`` the uncorrected p, ``GG`` and ``HF`` always
the Greenhouse-Geisser or the Huynh-Feldt (capped at 1) corrected p, as Superpower's ``correction``."""


class PowerInputError(ValueError):
    """Input a power analysis cannot use; the message names the file (or option), key and value."""


@dataclass(frozen=True)
class Contrast:
    """One pairwise comparison of the report's post hoc tests.

    ``pair`` (A, B) is compared by ``factor`` at ``at`` (a level, a group, or None: averaged over
    groups), as a row of ``microg.analysis.posthoc``; ``family`` is its Bonferroni family.
    ``levels`` weights the within levels of each participant (a difference of two levels, or one
    level), ``groups`` weights the group means of that value.
    """

    name: str
    family: str
    factor: str
    at: str | None
    pair: tuple[str, str]
    levels: tuple[float, ...]
    groups: tuple[float, ...]


@dataclass(frozen=True)
class Design:
    """Groups (between) x levels of one within factor, with the names the protocol gives them.

    ``group_codes`` and ``level_codes`` map the codes in exported tables (V, C, ...) to names;
    ``interactions`` are the interaction models the protocol's phases run, the one under test first.
    """

    protocol: str
    between: str
    groups: tuple[str, ...]
    within: str
    levels: tuple[str, ...]
    group_codes: dict
    level_codes: dict
    interactions: tuple[str, ...]

    @property
    def terms(self) -> tuple[str, ...]:
        """The ANOVA terms, named as in the ANOVA table."""
        return (self.between, self.within, f"{self.between}:{self.within}")

    @property
    def contrasts(self) -> tuple[Contrast, ...]:
        """The report's post hoc comparisons, each named by its levels.

        ``a - b`` compares two within levels averaged over groups (one family); ``g1 - g2 | level``
        compares groups at one level (one family); ``a - b | group`` compares levels inside one group
        (one family), as ``microg.analysis.posthoc(..., within_by_group=True)``.
        """
        k, g = len(self.levels), len(self.groups)
        unit_level, unit_group = np.eye(k), np.eye(g)
        level_pairs = list(combinations(range(k), 2))
        lv, gr = self.levels, self.groups
        found = [
            Contrast(f"{lv[a]} - {lv[b]}", self.within, self.within, None, (lv[a], lv[b]),
                     tuple(unit_level[a] - unit_level[b]), (1 / g,) * g)
            for a, b in level_pairs
        ]
        found += [
            Contrast(f"{gr[a]} - {gr[b]} | {level}", f"{self.between} | {self.within}", self.between, level,
                     (gr[a], gr[b]), tuple(unit_level[j]), tuple(unit_group[a] - unit_group[b]))
            for j, level in enumerate(lv)
            for a, b in combinations(range(g), 2)
        ]
        found += [
            Contrast(f"{lv[a]} - {lv[b]} | {group}", f"{self.within} | {self.between}", self.within, group,
                     (lv[a], lv[b]), tuple(unit_level[a] - unit_level[b]), tuple(unit_group[i]))
            for i, group in enumerate(gr)
            for a, b in level_pairs
        ]
        return tuple(found)

    @property
    def tests(self) -> tuple[str, ...]:
        """Every test a power table reports: the ANOVA terms, then the contrasts."""
        return self.terms + tuple(c.name for c in self.contrasts)

    def report_p(self, corrections, post):
        """The p the report reads for each of ``tests``, from its ``sphericity_correction`` table (one
        row per term, in order) and its ``posthoc(..., within_by_group=True)`` table; pandas Series."""
        import pandas as pd

        found = {(r.factor, None if pd.isna(r.at) else r.at, frozenset((r.A, r.B))): r.p_bonf
                 for r in post.itertuples(index=False)}
        p = dict(zip(self.terms, corrections["p"]))
        p.update({c.name: found[(c.factor, c.at, frozenset(c.pair))] for c in self.contrasts})
        return pd.Series(p)[list(self.tests)]

    def group_sizes(self, sample) -> tuple[int, ...]:
        """Participants in each group (the design's order) of a sample: a whole number (every group that
        size), a mapping group -> size, or one size per group (a tuple in the design's order)."""
        if isinstance(sample, dict):
            unknown = sorted(set(sample) - set(self.groups))
            if unknown:
                raise PowerInputError(f"--n {unknown[0]}={sample[unknown[0]]!r}: no group {unknown[0]!r} in protocol "
                                      f"{self.protocol!r} (groups: {', '.join(self.groups)})")
            missing = [group for group in self.groups if group not in sample]
            if missing:
                raise PowerInputError(f"--n: no size for group {missing[0]!r} (give one per group: "
                                      f"{', '.join(f'{g}=N' for g in self.groups)})")
            return tuple(sample[group] for group in self.groups)
        if isinstance(sample, (tuple, list)):
            return tuple(sample)
        return (sample,) * len(self.groups)

    def samples(self, n_per_group) -> list:
        """The samples asked for: one (a whole number or a mapping group -> size) or a sequence of them
        (each a number, a mapping, or a tuple of one size per group)."""
        if np.isscalar(n_per_group) or isinstance(n_per_group, dict):
            return [n_per_group]
        return list(n_per_group)

    def sample_key(self, sample) -> int | str:
        """How tables name a sample: its group size when the groups are equal, else
        ``"veteran=15,beginner=12"``."""
        sizes = self.group_sizes(sample)
        if len(set(sizes)) == 1:
            return int(sizes[0])
        return ",".join(f"{group}={size}" for group, size in zip(self.groups, sizes))

    def check_sample(self, sample, key: str = "--n") -> None:
        """Refuse a sample the report could not analyse (a group of fewer than 2, a size per group that
        names no group, or fewer error degrees of freedom than the within levels need) or the planning
        does not handle (a group over ``MAX_N_PER_GROUP``)."""
        g, k = len(self.groups), len(self.levels)
        sizes = self.group_sizes(sample)
        if len(sizes) != g:
            raise PowerInputError(f"{key} = {sample!r}: give one size per group ({', '.join(self.groups)})")
        for group, size in zip(self.groups, sizes):
            if isinstance(size, bool) or not isinstance(size, int) or size < 2:
                raise PowerInputError(f"{key} = {self.sample_key(sample) if isinstance(size, int) else sample!r}: "
                                      f"group {group} needs at least 2 participants, not {size!r}")
            if size > MAX_N_PER_GROUP:
                raise PowerInputError(f"{key} = {self.sample_key(sample)}: at most {MAX_N_PER_GROUP} participants per "
                                      "group are planned")
        if sum(sizes) - g < k - 1:
            raise PowerInputError(f"{key} = {self.sample_key(sample)}: {g} groups of {', '.join(map(str, sizes))} "
                                  f"leave {sum(sizes) - g} error degrees of freedom; {k} levels of {self.within} "
                                  f"need at least {k - 1}")

    def as_dict(self) -> dict:
        return {"protocol": self.protocol, "between": self.between, "groups": list(self.groups),
                "within": self.within, "levels": list(self.levels)}


def design_from_protocol(protocol: Protocol, within: str = "object") -> Design:
    """The protocol's groups x its objects (``within="object"``) or x the interaction models its phases run
    (``within="interaction"``, each participant's value being the mean over the objects).

    Examples
    --------
    >>> from microg.paths import protocol_file
    >>> from microg.study.protocol import load_protocol
    >>> design = design_from_protocol(load_protocol(protocol_file("paper")))
    >>> design.groups, design.levels, design.terms
    (('veteran', 'beginner'), ('cube', 'flat_cuboid', 'long_cuboid'), ('group', 'object', 'group:object'))
    """
    if within not in WITHIN_FACTORS:
        raise PowerInputError(f"--within = {within!r}: must be one of {list(WITHIN_FACTORS)}")
    groups = {g.code: g.name for g in protocol.groups}
    if within == "object":
        levels = {o.code: o.name for o in protocol.objects}
    else:
        levels = {interaction: interaction for interaction in protocol.interactions}
    if len(groups) < 2 or len(levels) < 2:
        raise PowerInputError(f"{protocol.where}: {len(groups)} group(s) and {len(levels)} {within} level(s): "
                              "a mixed design needs at least two of each")
    return Design(protocol.name, "group", tuple(groups.values()), within, tuple(levels.values()), groups, levels,
                  protocol.interactions)
