"""The table the objects rest on under gravity, and the compliant soft-hand baseline."""

import numpy as np
import pytest

from microg.skeleton import slot
from microg.sim import TableParameters
from microg.sim.probe import contact_forces, detect_contacts
from tests.physics import coast, placed, world_of

G = 9.81
TABLE = TableParameters(height=0.17)


def cube_sink():
    """How far the cube sinks into the table: its four bottom corners share the weight."""
    return placed("cube").spec.mass * G / (4 * TABLE.stiffness)


def test_dropped_cube_comes_to_rest_on_the_table():
    cube = placed("cube", position=(0.0, 0.25, 0.0))
    world = coast(world_of([cube], gravity=(0.0, -G, 0.0), table=TABLE), 2.0, rate=50)
    assert world.data.position[0, 1] == pytest.approx(0.17 + 0.03 - cube_sink(), abs=2e-5)
    assert np.abs(world.data.velocity[0]).max() < 1e-6


def test_sliding_cube_stops_after_coulomb_distance():
    # Kinetic friction decelerates at mu g: it stops after v0^2 / (2 mu g).
    v0 = 0.5
    cube = placed("cube", position=(0.0, 0.2 - cube_sink(), 0.0), velocity=(v0, 0.0, 0.0))
    world = coast(world_of([cube], gravity=(0.0, -G, 0.0), table=TABLE), 1.0, rate=50)
    mu = cube.spec.material.static_friction
    assert world.data.position[0, 0] == pytest.approx(v0 ** 2 / (2 * mu * G), rel=0.05)
    assert abs(world.data.velocity[0, 0]) < 1e-6


def test_table_needs_its_effect_and_its_settings():
    from microg.sim import Scene, SceneError, make_world
    with pytest.raises(SceneError, match="effects names 'table' but table = None"):
        make_world(Scene(objects=(placed("cube"),), effects=frozenset({"table"})))


INDEX_TIP = slot("right", 1, 3)


@pytest.mark.parametrize("approach", [0.0, 0.3])
def test_soft_hand_presses_with_spring_and_damper(approach):
    # f_n = k delta + c v for a fingertip delta deep, moving into the surface at v; the step
    # integrates the spring over the hand's motion too, so the force is that at the step's end,
    # k (delta + h v) + c v, before the object's own motion (implicit) is taken off.
    world = world_of([placed("cube", velocity=(0.0, 0.0, 0.0))], interaction="soft_hand")
    params = world.model.scene.soft_hand
    data = world.data.copy()
    data.valid[INDEX_TIP], data.radius[INDEX_TIP] = True, 0.008
    data.hand_position[INDEX_TIP] = (0.0, 0.23 + 0.008 - 0.004, 0.0)
    data.hand_velocity[INDEX_TIP] = (0.0, -approach, 0.0)
    detect_contacts(world.model, data)
    wrench = contact_forces(world.model, data)
    h = world.model.dt
    press = params.stiffness * (0.004 + h * approach) + params.damping * approach
    assert wrench[0, 1] == pytest.approx(-press, rel=1e-9)
    assert not data.impulse.any()
