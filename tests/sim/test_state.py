"""The state and model buffers: Python's named views and the compiled kernels' views are the same
memory, and every parameter comes from its place in the scene."""

import numba
import numpy as np
import pytest

from microg.sim import Material, ObjectSpec, PlacedObject, TableParameters, compose_scene, make_world
from microg.sim.scene import SoftHandParameters
from microg.sim.state import FIELDS, PARAMETERS, empty_buffers, layout, unpack, unpack_params, view


@numba.njit
def field_sums(reals, flags, counts, n):
    s = unpack(reals, flags, counts, n)
    return np.array([
        s.clock.sum(), s.position.sum(), s.orientation.sum(), s.velocity.sum(), s.angular_velocity.sum(),
        s.hand_position.sum(), s.hand_previous.sum(), s.hand_from.sum(), s.hand_to.sum(), s.hand_velocity.sum(),
        s.radius.sum(), s.last_points.sum(), s.anchor.sum(), s.normal.sum(), s.depth.sum(), s.normal_velocity.sum(),
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


@numba.njit
def parameters_seen(reals, ints, n):
    p = unpack_params(reals, ints, n)
    return (p.angular_method, p.shape.copy(), p.half_size.copy(), p.mass.copy(), p.inertia.copy(),
            p.restitution.copy(), p.static_friction.copy(), p.dynamic_friction.copy(), p.gravity.copy(),
            np.array([p.penetration_stiffness, p.resting_tolerance, p.jump_distance, p.dt, p.soft_stiffness,
                      p.soft_damping, p.soft_slip_velocity, p.table_height, p.table_stiffness, p.table_damping,
                      p.table_slip_velocity]))


def test_every_parameter_comes_from_its_place_in_the_scene_to_the_kernels_and_the_model():
    box = ObjectSpec("box", "box", (0.06, 0.02, 0.04), 0.15, Material(0.4, 0.8, 0.5))
    ball = ObjectSpec("ball", "sphere", (0.07, 0.07, 0.07), 0.12, Material(0.6, 0.7, 0.3))
    scene = compose_scene([PlacedObject(box, (0.0, 0.2, 0.0)), PlacedObject(ball, (0.2, 0.2, 0.0))],
                          gravity=(0.0, -9.81, 0.0), table=TableParameters(0.11, 2100.0, 11.0, 0.002),
                          tracking_rate=90.0, substeps=3, penetration_stiffness=120.0, resting_tolerance=2e-3,
                          jump_distance=0.07,
                          angular_integrator="explicit_euler", soft_hand=SoftHandParameters(210.0, 2.5, 0.006))
    model = make_world(scene).model
    expected = {
        "angular_method": 2, "shape": [0, 1], "half_size": [[0.03, 0.01, 0.02], [0.035] * 3], "mass": [0.15, 0.12],
        "inertia": [box.principal_inertia, ball.principal_inertia], "restitution": [0.4, 0.6],
        "static_friction": [0.8, 0.7], "dynamic_friction": [0.5, 0.3], "gravity": [0.0, -9.81, 0.0],
        "penetration_stiffness": 120.0, "resting_tolerance": 2e-3, "jump_distance": 0.07, "dt": 1 / 270,
        "soft_stiffness": 210.0,
        "soft_damping": 2.5, "soft_slip_velocity": 0.006, "table_height": 0.11, "table_stiffness": 2100.0,
        "table_damping": 11.0, "table_slip_velocity": 0.002}
    assert [name for name, *_ in PARAMETERS] == list(expected)
    for name, value in expected.items():
        assert np.asarray(getattr(model, name)) == pytest.approx(np.asarray(value), rel=1e-15), name
    seen = parameters_seen(model.params, model.ints, model.n_objects)
    for value, name in zip(seen[:-1], expected):
        assert np.asarray(value) == pytest.approx(np.asarray(expected[name]), rel=1e-15), name
    assert seen[-1] == pytest.approx([expected[name] for name in list(expected)[9:]], rel=1e-15)
    assert model.params.size == 10 * 2 + 3 + 11 and model.ints.size == 2 + 2  # nothing else, nothing twice
