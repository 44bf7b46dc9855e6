"""The guard's shortcut for the usual frame gives exactly what its general path gives."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from microg.hands.guard import GuardConfig, GuardState, decided, steady

from .test_guard import _corrupt
from .synthetic import sweep


def same_state(a: GuardState, b: GuardState) -> bool:
    sides = all(x.last == y.last and x.source_id == y.source_id and x.holding == y.holding
                and np.array_equal(x.delivered, y.delivered)
                and (x.last_time == y.last_time or (np.isnan(x.last_time) and np.isnan(y.last_time)))
                for x, y in zip(a.sides, b.sides))
    return (sides and a.last_time == b.last_time and a.offset == b.offset and a.intervals == b.intervals
            and a.stale_run == b.stale_run and a.next_track == b.next_track and a.pending == b.pending
            and a.counts.as_dict() == b.counts.as_dict())


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["keep"] * 6 + ["drop", "duplicate", "swap", "nan", "glitch", "relocate"]),
                min_size=5, max_size=60), st.integers(0, 2 ** 32 - 1))
def test_the_steady_shortcut_agrees_with_the_general_path_on_every_frame_it_takes(actions, seed):
    stream = _corrupt(sweep((0, 0.2, 0), (0.2, 0, 0), len(actions)), actions, np.random.default_rng(seed))
    config, state = GuardConfig(), GuardState()
    for frame in stream:
        general = decided(config, state, frame)
        short = steady(config, state, frame)
        if short is not None:
            assert same_state(short[0], general[0]) and short[1] == general[1]
        state = general[0]


def test_a_clean_stream_takes_the_shortcut_after_its_first_frame():
    config, state, taken = GuardConfig(), GuardState(), []
    for frame in sweep((0, 0.2, 0), (0.2, 0, 0), 20):
        taken.append(steady(config, state, frame) is not None)
        state = decided(config, state, frame)[0]
    assert taken == [False] + [True] * 19
