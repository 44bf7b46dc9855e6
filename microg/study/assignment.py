"""Participants, group assignment and object orders: pure functions of the study so far and a seed.

Group assignment (``assign_group``) puts a new participant in the group that has, relative to its
size, the fewest participants of the same gender (when the protocol balances gender), then the
fewest participants; remaining ties are broken by the seeded generator. It counts the participants
who completed or are still to run; a withdrawn participant does not count, so withdrawing frees
the slot (and the order row) for the next participant. Run participants one after another and
every completed set stays balanced; the paper's 20 men and 10 women end as 10 + 5 in each group.

Object orders come from a balanced Latin square (Williams design: every object appears once in
every position, and every object follows every other equally often; for an odd number of objects
the square is paired with its mirror image) or from a seeded permutation per participant.
"""

from __future__ import annotations

import re
import zlib
from dataclasses import dataclass

import numpy as np

from microg.schema import GENDERS, HANDEDNESS

from .protocol import Protocol

MAX_ID = 64
ID = re.compile(rf"[A-Za-z0-9]{{1,{MAX_ID}}}")
"""A participant id: exactly what a BIDS label keeps, so ids and sub-<label>s map one to one
(the store also refuses ids that differ only in case)."""


class ParticipantError(ValueError):
    """A participant that cannot be added; the message names the field and value."""


@dataclass(frozen=True)
class Participant:
    """Demographics, as the paper reports them."""

    id: str
    gender: str
    age: int
    handedness: str
    mr_experience: bool
    """Has used mixed reality before."""


@dataclass(frozen=True)
class Enrolled:
    """A participant already in the study and not withdrawn: what assignment counts."""

    group: str
    gender: str
    order_row: int | None


def check_participant(participant: Participant, protocol: Protocol) -> None:
    """Reject demographics the study cannot use, naming the field and value."""
    p = participant
    if not isinstance(p.id, str) or not ID.fullmatch(p.id):
        raise ParticipantError(f"participant id = {p.id!r}: must be 1 to {MAX_ID} ASCII letters and digits (e.g. "
                               "P01); it becomes the sub-<label> of the Motion-BIDS export, which keeps nothing else")
    if p.gender not in GENDERS:
        raise ParticipantError(f"participant {p.id}: gender = {p.gender!r}: must be one of {list(GENDERS)}")
    if p.handedness not in HANDEDNESS:
        raise ParticipantError(f"participant {p.id}: handedness = {p.handedness!r}: must be one of {list(HANDEDNESS)}")
    if not isinstance(p.mr_experience, bool):
        raise ParticipantError(f"participant {p.id}: mr_experience = {p.mr_experience!r}: must be true or false")
    if not isinstance(p.age, int) or isinstance(p.age, bool) or p.age <= 0:
        raise ParticipantError(f"participant {p.id}: age = {p.age!r}: must be a whole number of years")
    if protocol.age_range and not protocol.age_range[0] <= p.age <= protocol.age_range[1]:
        raise ParticipantError(f"participant {p.id}: age = {p.age}: the protocol {protocol.name!r} takes "
                               f"participants aged {protocol.age_range[0]}-{protocol.age_range[1]}")


def assign_group(protocol: Protocol, enrolled: list[Enrolled], gender: str, rng: np.random.Generator) -> str:
    """The group code for a new participant of ``gender`` (rule in the module docstring)."""
    counts = {g.code: sum(e.group == g.code for e in enrolled) for g in protocol.groups}
    open_groups = [g for g in protocol.groups if counts[g.code] < g.size]
    if not open_groups:
        raise ParticipantError(f"the study is full: {counts} participants in groups of "
                               f"{ {g.code: g.size for g in protocol.groups} }; withdraw someone to free a slot")

    def load(group) -> tuple[float, float]:
        same = sum(e.group == group.code and e.gender == gender for e in enrolled)
        return (same / group.size if protocol.balance == "gender" else 0.0, counts[group.code] / group.size)

    best = min(load(g) for g in open_groups)
    tied = [g.code for g in open_groups if load(g) == best]
    return tied[int(rng.integers(len(tied)))] if len(tied) > 1 else tied[0]


def balanced_latin_square(n: int) -> list[list[int]]:
    """Rows of a Williams design over ``n`` conditions (2n rows when n is odd)."""
    if n < 1:
        raise ValueError(f"balanced_latin_square(n = {n}): need at least one condition")
    first, low, high = [0], 1, n - 1
    while len(first) < n:
        first.append(low)
        low += 1
        if len(first) < n:
            first.append(high)
            high -= 1
    rows = [[(c + r) % n for c in first] for r in range(n)]
    return rows + [row[::-1] for row in rows] if n % 2 else rows


def assign_order(protocol: Protocol, group: str, *, enrolled: list[Enrolled], participant_id: str,
                 seed: int) -> tuple[int | None, tuple[str, ...]]:
    """(Latin-square row or None, object names in order) for a new participant of ``group``.

    Latin square: the least-used row among the group's enrolled participants (lowest on ties), so
    each group cycles through the rows and a withdrawal frees its row. Permutation: a permutation
    drawn from the study seed and the participant id, the same however often it is asked for.
    """
    names = [o.name for o in protocol.objects]
    if protocol.order == "permutation":
        rng = np.random.default_rng([seed, zlib.crc32(participant_id.encode())])
        return None, tuple(names[i] for i in rng.permutation(len(names)))
    rows = balanced_latin_square(len(names))
    used = [sum(e.group == group and e.order_row == r for e in enrolled) for r in range(len(rows))]
    row = int(np.argmin(used))
    return row, tuple(names[i] for i in rows[row])


PAPER_SAMPLE = {"n": 30, "male": 20, "female": 10, "age_min": 18, "age_max": 30, "age_mean": 23.63,
                "age_sd": 3.44, "left_handed": 3, "without_mr": 8}
"""The paper's sample (section 4.3)."""


def paper_sample(seed: int) -> list[Participant]:
    """30 participants with the paper's demographics: 20 male and 10 female, aged 18-30 with mean
    23.63 and SD 3.44 (both to two decimals), 3 left-handed, 8 without MR experience; ids P01-P30.
    Who gets which value is drawn from ``seed``."""
    s = PAPER_SAMPLE
    rng = np.random.default_rng(seed)
    ages = np.clip(np.rint(rng.normal(s["age_mean"], s["age_sd"], s["n"])), s["age_min"], s["age_max"]).astype(int)
    target_sum = round(s["age_mean"] * s["n"])
    while ages.sum() != target_sum:
        step = 1 if ages.sum() < target_sum else -1
        movable = np.flatnonzero((ages + step >= s["age_min"]) & (ages + step <= s["age_max"]))
        ages[rng.choice(movable)] += step
    while round(float(np.std(ages, ddof=1)), 2) != s["age_sd"]:
        wider = np.std(ages, ddof=1) < s["age_sd"]
        i, j = rng.choice(s["n"], 2, replace=False)
        hi, lo = (i, j) if ages[i] >= ages[j] else (j, i)
        if wider and ages[hi] < s["age_max"] and ages[lo] > s["age_min"]:
            ages[hi] += 1
            ages[lo] -= 1
        elif not wider and ages[hi] - ages[lo] >= 2:
            ages[hi] -= 1
            ages[lo] += 1
    genders = rng.permutation(["male"] * s["male"] + ["female"] * s["female"])
    left = set(rng.choice(s["n"], s["left_handed"], replace=False).tolist())
    novices = set(rng.choice(s["n"], s["without_mr"], replace=False).tolist())
    return [Participant(id=f"P{i + 1:02d}", gender=str(genders[i]), age=int(ages[i]),
                        handedness="left" if i in left else "right", mr_experience=i not in novices)
            for i in range(s["n"])]
