"""The state buffers: Python's named views and the compiled kernels' views are the same memory."""

import numba
import numpy as np
import pytest

from microg.sim.state import FIELDS, empty_buffers, layout, unpack, view


@numba.njit
def field_sums(reals, flags, counts, n):
    s = unpack(reals, flags, counts, n)
    return np.array([
        s.clock.sum(), s.position.sum(), s.orientation.sum(), s.velocity.sum(), s.angular_velocity.sum(),
        s.hand_position.sum(), s.hand_previous.sum(), s.hand_from.sum(), s.hand_to.sum(), s.hand_velocity.sum(),
        s.radius.sum(), s.anchor.sum(), s.normal.sum(), s.depth.sum(), s.normal_velocity.sum(),
        s.impulse.sum(), s.valid.sum(), s.fresh.sum(), s.present.sum(), s.active.sum(), s.ghost.sum(),
        s.onset.sum(), s.sliding.sum(), s.counter.sum(), s.track_id.sum()], dtype=np.float64)


def test_python_and_compiled_code_see_each_field_at_the_same_place():
    n = 3
    buffers = empty_buffers(n)
    expected = []
    for i, (name, buffer, _) in enumerate(FIELDS):
        field = view(buffers, n, name)
        if field.dtype == np.bool_:
            field[...] = np.arange(field.size).reshape(field.shape) % (i + 2) == 0
        else:
            field[...] = (i + 1) * (1 + np.arange(field.size).reshape(field.shape))
        expected.append(float(field.sum()))
    assert [name for name, _, _ in FIELDS] == [f for f in layout(n)[0]]
    assert field_sums(*buffers, n) == pytest.approx(expected)
    assert sum(b.size for b in buffers) == sum(layout(n)[1])
