"""Latin-square balance, gender balance under withdrawals, reproducible orders, the paper's sample."""

from __future__ import annotations

import re
from collections import Counter
from itertools import permutations

import numpy as np
import pytest

from microg.paths import PROTOCOLS
from microg.study.assignment import (Participant, ParticipantError, balanced_latin_square, paper_sample)
from microg.study.protocol import load_protocol
from microg.study.store import create_study


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6, 7])
def test_balanced_latin_square_puts_each_object_once_per_position_and_balances_carryover(n):
    rows = balanced_latin_square(n)
    assert len(rows) == (2 * n if n % 2 else n)
    assert all(sorted(row) == list(range(n)) for row in rows)
    per_position = [Counter(row[i] for row in rows) for i in range(n)]
    assert all(set(c.values()) == {len(rows) // n} and len(c) == n for c in per_position)
    follows = Counter((row[i], row[i + 1]) for row in rows for i in range(n - 1))
    pairs = [(a, b) for a in range(n) for b in range(n) if a != b]
    assert {follows[p] for p in pairs} == {len(rows) * (n - 1) // len(pairs)}


def test_three_objects_use_all_six_orders():
    assert sorted(map(tuple, balanced_latin_square(3))) == sorted(permutations(range(3)))


def new_study(tmp_path, protocol="paper.toml", seed=11):
    return create_study(tmp_path / "study", load_protocol(PROTOCOLS / protocol), seed)


def group_genders(store):
    active = [p for p in store.participants() if p.status == "active"]
    return Counter((p.group, p.participant.gender) for p in active)


def test_the_papers_sample_ends_gender_balanced_in_two_groups_of_fifteen(tmp_path):
    with new_study(tmp_path) as store:
        for person in paper_sample(seed=5):
            store.add_participant(person)
        assert group_genders(store) == {("V", "male"): 10, ("V", "female"): 5, ("B", "male"): 10, ("B", "female"): 5}
        with pytest.raises(ParticipantError, match="the study is full"):
            store.add_participant(Participant("P31", "female", 22, "right", True))


def test_withdrawals_free_their_slot_and_the_groups_stay_balanced(tmp_path):
    rng = np.random.default_rng(3)
    with new_study(tmp_path) as store:
        sample = paper_sample(seed=9)
        for person in sample[:20]:
            store.add_participant(person)
        withdrawn = [p.id for p in store.participants() if p.participant.gender == "female"][:3]
        withdrawn += [p.id for p in store.participants() if p.group == "V" and p.participant.gender == "male"][:2]
        for pid in withdrawn:
            store.withdraw(pid, "left the study")
        replacements = [Participant(f"R{i}", g, int(rng.integers(18, 31)), "right", True)
                        for i, g in enumerate(["female"] * 3 + ["male"] * 2)]
        for person in sample[20:] + replacements:
            store.add_participant(person)
        counts = group_genders(store)
        assert counts == {("V", "male"): 10, ("V", "female"): 5, ("B", "male"): 10, ("B", "female"): 5}
        assert sum(p.status == "withdrawn" for p in store.participants()) == 5


def test_latin_square_rows_cycle_within_each_group_and_a_withdrawal_frees_its_row(tmp_path):
    with new_study(tmp_path) as store:
        for person in paper_sample(seed=2):
            store.add_participant(person)
        for group in ("V", "B"):
            rows = Counter(p.order_row for p in store.participants() if p.group == group)
            assert sorted(rows) == list(range(6)) and max(rows.values()) - min(rows.values()) <= 1
        # free a row that is used three times in its group: the next participant there takes it
        people = store.participants()
        v_rows = Counter(p.order_row for p in people if p.group == "V")
        full_row = next(r for r, n in v_rows.items() if n == 3)
        leaver = next(p for p in people if p.group == "V" and p.order_row == full_row)
        store.withdraw(leaver.id, "withdrew consent")
        newcomer = store.add_participant(Participant("N1", leaver.participant.gender, 25, "right", False))
        assert newcomer.group == "V"
        assert (newcomer.order_row, newcomer.object_order) == (leaver.order_row, leaver.object_order)


def test_assignment_is_reproducible_from_the_seed(tmp_path):
    def assign(folder, seed):
        with create_study(folder, load_protocol(PROTOCOLS / "paper.toml"), seed) as store:
            for person in paper_sample(seed=4):
                store.add_participant(person)
            return [(p.id, p.group, p.object_order) for p in store.participants()]

    first, again = assign(tmp_path / "a", 21), assign(tmp_path / "b", 21)
    assert first == again
    other = assign(tmp_path / "c", 22)
    assert [g for _, g, _ in other] != [g for _, g, _ in first]


def test_seeded_permutations_are_fixed_per_participant_and_vary_between_them(tmp_path):
    folder = tmp_path / "protocols"
    folder.mkdir()
    (folder / "perm.toml").write_text(f'extends = "{PROTOCOLS / "paper.toml"}"\nname = "perm"\n'
                                      '[objects]\norder = "permutation"\n')
    protocol = load_protocol(folder / "perm.toml")
    orders = {}
    for seed, name in ((5, "a"), (5, "b")):
        with create_study(tmp_path / name, protocol, seed) as store:
            for person in paper_sample(seed=1):
                store.add_participant(person)
            orders[name] = {p.id: p.object_order for p in store.participants()}
    assert orders["a"] == orders["b"]
    assert len(set(orders["a"].values())) > 1
    assert all(p.order_row is None for p in store_participants(tmp_path / "a"))


def store_participants(folder):
    from microg.study.store import open_study
    with open_study(folder) as store:
        return store.participants()


def test_the_paper_sample_has_the_papers_demographics():
    people = paper_sample(seed=123)
    ages = np.array([p.age for p in people])
    assert len(people) == 30 and len({p.id for p in people}) == 30
    assert Counter(p.gender for p in people) == {"male": 20, "female": 10}
    assert ages.min() >= 18 and ages.max() <= 30
    assert round(ages.mean(), 2) == 23.63 and round(ages.std(ddof=1), 2) == 3.44
    assert sum(p.handedness == "left" for p in people) == 3
    assert sum(not p.mr_experience for p in people) == 8


@pytest.mark.parametrize("field, value, expected", [
    ("gender", "f", "gender = 'f'"), ("handedness", "both", "handedness = 'both'"),
    ("age", 17, "age = 17: the protocol 'paper' takes participants aged 18-30"),
    ("age", 24.5, "age = 24.5"), ("id", "P 1", "participant id = 'P 1'"),
])
def test_bad_demographics_are_rejected_by_field_and_value(tmp_path, field, value, expected):
    fields = {**dict(id="P1", gender="female", age=24, handedness="right", mr_experience=True), field: value}
    with new_study(tmp_path) as store:
        with pytest.raises(ParticipantError, match=re.escape(expected)):
            store.add_participant(Participant(**fields))
        assert store.participants() == []
