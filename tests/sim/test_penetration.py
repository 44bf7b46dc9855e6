"""Penetration phase (Eqs. 16-20): spring direction and size, pinches, static and dynamic friction."""

import numpy as np
import pytest

from microg.skeleton import slot
from microg.sim import Material, ObjectSpec, PlacedObject, grasped
from microg.sim.probe import contact_forces
from tests.physics import drive, placed, world_of

GAMMA = 100.0
RADIUS = 0.008
HALF = 0.03  # the shipped cube is 6 cm
INDEX_TIP = slot("right", 1, 3)


def press_then_hold(depth, approach=0.1):
    """Index fingertip descends onto the cube's top at ``approach`` m/s and stops ``depth`` deep."""
    start = 0.2 + HALF + RADIUS + 0.005
    stop = 0.2 + HALF + RADIUS - depth
    return lambda t: {"index.distal": (0.0, max(stop, start - approach * t), 0.0)}


def forces_now(world):
    """The generalised force the contact kernels would apply at the world's current state."""
    data = world.data.copy()
    return contact_forces(world.model, data), data


def test_spring_pushes_object_away_from_finger_with_gamma_times_depth():
    heavy = ObjectSpec("block", "box", (0.06, 0.06, 0.06), 1e4)
    world = world_of([PlacedObject(heavy, (0.0, 0.2, 0.0))], interaction="penetration_only")
    world = drive(world, press_then_hold(0.006), t_end=0.2)
    wrench, data = forces_now(world)
    assert data.depth[INDEX_TIP, 0] == pytest.approx(0.006, abs=1e-6)
    assert wrench[0, :3] == pytest.approx([0.0, -GAMMA * data.depth[INDEX_TIP, 0], 0.0], abs=1e-12)
    assert wrench[0, 3:] == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)


def pinch(gap, offset=(0.0, 0.0, 0.0)):
    """Thumb and index fingertips on the cube's -x and +x faces, ``gap`` between sphere surfaces."""
    x = gap / 2 + RADIUS
    o = np.asarray(offset)
    return {"thumb.distal": o + (-x, 0.2, 0.0), "index.distal": o + (x, 0.2, 0.0)}


def closing_pinch(final_gap, t_close=0.3, then=None):
    """Open pinch closing to ``final_gap`` by t_close; afterwards ``then(t)`` gives an offset."""
    def path(t):
        gap = 0.08 + (final_gap - 0.08) * min(1.0, t / t_close)
        return pinch(gap, (0.0, 0.0, 0.0) if then is None or t <= t_close else then(t - t_close))
    return path


def test_two_finger_pinch_holds_free_cube_in_zero_g():
    world = world_of([placed("cube")], interaction="penetration_only")
    world = drive(world, closing_pinch(0.06 - 2 * 0.008), t_end=1.5)
    assert grasped(world)[0]
    assert np.linalg.norm(world.data.velocity[0]) < 1e-9
    assert world.data.position[0] == pytest.approx([0.0, 0.2, 0.0], abs=1e-9)
    wrench, _ = forces_now(world)
    assert np.abs(wrench[0]).max() < 1e-9  # net force and torque vanish


def test_moving_pinch_drags_cube_along_by_static_friction():
    carry = 0.10  # 10 cm along z in 1 s, minimum-jerk
    def offset(t):
        s = min(1.0, t)
        return (0.0, 0.0, carry * (10 * s**3 - 15 * s**4 + 6 * s**5))
    world = world_of([placed("cube")], interaction="penetration_only")
    world = drive(world, closing_pinch(0.06 - 2 * 0.008, then=offset), t_end=2.0)
    assert grasped(world)[0]
    assert not world.data.sliding.any()
    # the cube followed the hand; it trails by at most the spring stretch its inertia needs
    assert world.data.position[0, 2] == pytest.approx(carry, abs=0.003)


@pytest.mark.parametrize("fraction", [0.5, 0.99, 1.01, 3.0])
def test_tangential_pull_sticks_inside_the_cone_and_slips_outside(fraction):
    # A fingertip pressed delta deep into a heavy block is displaced sideways by d in one step.
    # Eq. 19: it sticks while d <= mu * delta (the anchor stays, the force is gamma * d);
    # Eq. 20: beyond, the anchor slides until the tangential force is phi * gamma * delta.
    mu, phi, delta = 0.8, 0.5, 0.006
    d = fraction * mu * delta
    block = ObjectSpec("block", "box", (0.06, 0.06, 0.06), 1e6, Material(0.4, mu, phi))
    world = world_of([PlacedObject(block, (0.0, 0.2, 0.0))], interaction="penetration_only")
    world = drive(world, press_then_hold(delta), t_end=0.2)
    world.data.hand_position[INDEX_TIP, 0] += d
    wrench, data = forces_now(world)
    sticks = fraction <= 1.0
    assert bool(data.sliding[INDEX_TIP, 0]) is not sticks
    assert data.anchor[INDEX_TIP, 0, 0] == pytest.approx(0.0 if sticks else d - phi * delta, abs=1e-7)
    # the object receives the reaction: dragged along +x, pressed down along -y
    assert wrench[0, 0] == pytest.approx(GAMMA * d if sticks else phi * GAMMA * delta, rel=1e-4)
    assert wrench[0, 1] == pytest.approx(-GAMMA * delta, rel=1e-4)


@pytest.mark.parametrize("margin, held", [(2.5, True), (0.5, False)])
def test_pinch_under_gravity_holds_exactly_when_friction_can_carry_the_weight(margin, held):
    # Two opposing contacts each press gamma * delta; static friction carries the weight m g
    # only if 2 mu gamma delta >= m g. Starting from rest the spring overshoots to twice the
    # static sag, so "held" means the cube never sags more than m g / gamma (the undamped
    # oscillation's bound) while slipping means kinetic friction 2 phi gamma delta < m g.
    cube = placed("cube")
    m, mu = cube.spec.mass, cube.spec.material.static_friction
    delta_needed = m * 9.81 / (2 * mu * GAMMA)
    delta = margin * delta_needed
    world = world_of([cube], interaction="penetration_only", gravity=(0.0, -9.81, 0.0))
    world = drive(world, closing_pinch(0.06 - 2 * delta, t_close=0.0001), t_end=1.0)
    drop = 0.2 - world.data.position[0, 1]
    if held:
        assert grasped(world)[0]
        assert drop <= m * 9.81 / GAMMA + 1e-3
    else:
        assert drop > 0.05


def test_frictionless_contact_only_pushes_along_the_normal():
    block = ObjectSpec("block", "box", (0.06, 0.06, 0.06), 1e6)
    world = world_of([PlacedObject(block, (0.0, 0.2, 0.0))], effects={"penetration"})
    world = drive(world, press_then_hold(0.005), t_end=0.2)
    top = 0.2 + HALF + RADIUS - 0.005
    world = drive(world, lambda t: {"index.distal": (0.02 * (t - 0.2) / 0.1, top, 0.0)},
                  t_start=0.2 + 1 / 110, t_end=0.3)
    wrench, data = forces_now(world)
    assert wrench[0, :3] == pytest.approx([0.0, -GAMMA * 0.005, 0.0], abs=1e-5)
    assert abs(wrench[0, 0]) < 1e-6 * abs(wrench[0, 1])
    # the god-object followed the finger along the face
    assert data.anchor[INDEX_TIP, 0, 0] == pytest.approx(0.02, abs=1e-7)
