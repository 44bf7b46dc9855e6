"""Impulse phase (Eqs. 9-15) against Newton's impact law worked by hand.

The head-on and off-centre hits run on the analytic box and on the same box read from a mesh
file: a box mesh is the box, so they must agree to rounding (1e-12 m/s, 1e-9 relative)."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from microg.sim import Material, ObjectSpec, PlacedObject, kinetic_energy, load_object
from microg.sim.contact import COLLIDING, RESTING, SEPARATING, classify
from microg.sim.probe import apply_impulses
from tests.meshes import mesh_object
from tests.physics import drive, placed, world_of

TOP = 0.2 + 0.03  # top face of a 6 cm cube centred at y = 0.2
RADIUS = 0.008


def tap_down(speed):
    """An index fingertip coming straight down onto the cube's top face at ``speed``."""
    return lambda t: {"index.distal": (0.0, TOP + RADIUS + 0.01 - speed * t, 0.0)}


def box_object(name, size, mass, material, kind, folder):
    """A box as the analytic shape (kind "box") or as a mesh file of its 12 triangles (kind "mesh")."""
    if kind == "box":
        return ObjectSpec(name, "box", size, mass, material)
    box = trimesh.creation.box(extents=size)
    e, mu, phi = material.restitution, material.static_friction, material.dynamic_friction
    return load_object(mesh_object(folder, f"{name}_{e:g}", box.vertices, box.faces, (e, mu, phi), mass=mass))


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("box_meshes")


@pytest.mark.parametrize("kind", ["box", "mesh"])
@pytest.mark.parametrize("speed", [0.2, 1.0, 3.0])
@pytest.mark.parametrize("restitution", [0.1, 0.4, 0.9])
def test_head_on_hit_leaves_at_one_plus_e_times_hand_speed(speed, restitution, kind, folder):
    cube = box_object("cube", (0.06, 0.06, 0.06), 0.15, Material(restitution, 0.8, 0.5), kind, folder)
    world = world_of([PlacedObject(cube, (0.0, 0.2, 0.0))], effects={"impulse"})
    world = drive(world, tap_down(speed), t_end=0.02 / speed + 0.03)
    assert world.data.velocity[0] == pytest.approx([0.0, -(1 + restitution) * speed, 0.0], abs=1e-12)
    assert world.data.angular_velocity[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)


@pytest.mark.parametrize("kind", ["box", "mesh"])
def test_off_centre_hit_matches_hand_computed_collision_matrix(kind, folder):
    # A 20 x 4 x 2.5 cm bar hit on its top face at x = d, straight down at u.
    # r = (d, h, 0), n = (0, 1, 0): r x n = (0, 0, d), so n^T K n = 1/m + d^2 / I_zz and
    # j = (1 + e) u / (1/m + d^2/I_zz); the bar gets v_y = -j/m and omega_z = -j d / I_zz.
    m, e, u, d = 0.14, 0.4, 0.5, 0.07
    bar = box_object("bar", (0.20, 0.04, 0.025), m, Material(e, 0.8, 0.5), kind, folder)
    i_zz = m / 12 * (0.20 ** 2 + 0.04 ** 2)
    world = world_of([PlacedObject(bar, (0.0, 0.2, 0.0))], effects={"impulse"})
    top = 0.2 + 0.02
    world = drive(world, lambda t: {"index.distal": (d, top + RADIUS + 0.005 - u * t, 0.0)}, t_end=0.02)
    j = (1 + e) * u / (1 / m + d * d / i_zz)
    assert world.data.velocity[0] == pytest.approx([0.0, -j / m, 0.0], rel=1e-9, abs=1e-12)
    assert world.data.angular_velocity[0] == pytest.approx([0.0, 0.0, -j * d / i_zz], rel=1e-9, abs=1e-12)


def test_impulse_keeps_angular_momentum_about_the_contact_point():
    # An impulse through a point exerts no torque about it: independent of Eq. 12's algebra.
    from microg.sim.rotation import quat_from_euler_deg, quat_to_matrix
    q = quat_from_euler_deg(20, -35, 50)
    bar = placed("long_cuboid", orientation=tuple(q), velocity=(0.05, 0.0, -0.02), angular_velocity=(0.3, -0.2, 0.5))
    world = world_of([bar], effects={"impulse"})
    data = world.data.copy()
    data.onset[7, 0] = True
    data.anchor[7, 0] = (0.06, 0.02, 0.004)
    data.normal[7, 0] = (0.0, 1.0, 0.0)
    data.hand_velocity[7] = (0.1, -1.2, 0.3)
    rot = quat_to_matrix(q)
    point = data.position[0] + rot @ data.anchor[7, 0]

    def momentum_about_point(d):
        world_inertia = rot @ np.diag(world.model.inertia[0]) @ rot.T
        return world_inertia @ d.angular_velocity[0] + np.cross(d.position[0] - point, world.model.mass[0] * d.velocity[0])

    before = momentum_about_point(data)
    apply_impulses(world.model, data)
    assert data.impulse[7, 0] > 0
    assert momentum_about_point(data) == pytest.approx(before, abs=1e-12)
    # and the linear momentum changed by exactly -j n
    assert world.model.mass[0] * data.velocity[0] == pytest.approx(
        world.model.mass[0] * np.array([0.05, 0.0, -0.02]) - data.impulse[7, 0] * (rot @ [0.0, 1.0, 0.0]), abs=1e-12)


def test_classification_of_normal_velocity():
    assert classify(0.01, 1e-3) == SEPARATING
    assert classify(-0.01, 1e-3) == COLLIDING
    assert classify(5e-4, 1e-3) == RESTING and classify(-5e-4, 1e-3) == RESTING


@pytest.mark.parametrize("normal_speed", [0.0, 5e-4, 0.2])
def test_resting_and_separating_onsets_get_no_impulse(normal_speed):
    world = world_of([placed("cube")], effects={"impulse"})
    data = world.data.copy()
    data.onset[25, 0] = True
    data.anchor[25, 0] = (0.0, 0.03, 0.0)
    data.normal[25, 0] = (0.0, 1.0, 0.0)
    data.hand_velocity[25] = (0.7, normal_speed, -0.3)  # sliding along the face, not into it
    apply_impulses(world.model, data)
    assert data.impulse[25, 0] == 0.0
    assert not data.velocity.any() and not data.angular_velocity.any()


@settings(max_examples=200, deadline=None)
@given(
    size=st.tuples(*[st.floats(0.01, 0.3)] * 3),
    mass=st.floats(0.001, 10.0),
    restitution=st.floats(0.01, 0.99),
    face=st.integers(0, 5),
    spot=st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    hand=st.tuples(*[st.floats(-5, 5)] * 3),
    velocity=st.tuples(*[st.floats(-2, 2)] * 3),
    spin=st.tuples(*[st.floats(-20, 20)] * 3),
)
def test_energy_in_the_hands_frame_never_grows(size, mass, restitution, face, spot, hand, velocity, spin):
    spec = ObjectSpec("box", "box", size, mass, Material(restitution, 0.8, 0.5))
    world = world_of([PlacedObject(spec, (0.0, 0.0, 0.0), velocity=velocity, angular_velocity=spin)],
                     effects={"impulse"})
    half = np.asarray(size) / 2
    axis, sign = divmod(face, 2)
    normal = np.zeros(3)
    normal[axis] = 1.0 if sign else -1.0
    anchor = normal * half
    others = [i for i in range(3) if i != axis]
    anchor[others] = np.asarray(spot) * half[others]
    data = world.data.copy()
    data.onset[3, 0] = True
    data.anchor[3, 0], data.normal[3, 0], data.hand_velocity[3] = anchor, normal, hand

    def energy_seen_from_hand(d):
        shifted = d.copy()
        shifted.velocity = d.velocity - np.asarray(hand)
        return kinetic_energy(world.__class__(world.model, shifted))[0]

    before = energy_seen_from_hand(data)
    apply_impulses(world.model, data)
    assert energy_seen_from_hand(data) <= before * (1 + 1e-12) + 1e-15
    if data.impulse[3, 0] > 0:
        # Newton's law held: the normal relative velocity reversed and shrank by e
        r, n = anchor, normal
        after = n @ (np.asarray(hand) - (data.velocity[0] + np.cross(data.angular_velocity[0], r)))
        before_n = n @ (np.asarray(hand) - (np.asarray(velocity) + np.cross(spin, r)))
        assert after == pytest.approx(-restitution * before_n, rel=1e-7, abs=1e-9)
