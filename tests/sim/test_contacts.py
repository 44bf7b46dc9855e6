"""Contacts (Eqs. 2-8), god-object proxies, ghosts, continuous collision and the grasp rule."""

import numpy as np
import pytest

from microg.skeleton import slot
from microg.sim import ObjectSpec, PlacedObject, grasped, highlighted, rendered_phalanges, touching
from microg.sim.rotation import quat_to_matrix
from microg.sim.probe import detect_contacts
from tests.physics import drive, placed, world_of

RADIUS = 0.008
INDEX_TIP = slot("right", 1, 3)
THUMB_TIP = slot("right", 0, 3)


def test_rendered_hand_is_the_tracked_hand_out_of_contact_and_on_the_surface_in_contact():
    heavy = PlacedObject(ObjectSpec("block", "box", (0.06, 0.06, 0.06), 1e6), (0.0, 0.2, 0.0))
    world = world_of([heavy], interaction="penetration_only")
    world = drive(world, lambda t: {"index.distal": (0.01, 0.26, 0.0)}, t_end=0.05)
    assert not highlighted(world).any()
    assert rendered_phalanges(world)[INDEX_TIP] == pytest.approx([0.01, 0.26, 0.0])
    # press 7 mm into the top face (at y = 0.23): the tracked tip sinks, the rendered one rests on it
    world = drive(world, lambda t: {"index.distal": (0.01, max(0.23 + RADIUS - 0.007, 0.26 - (t - 0.05)), 0.0)},
                  t_start=0.06, t_end=0.2)
    assert highlighted(world)[INDEX_TIP] and touching(world)[INDEX_TIP, 0]
    assert world.data.hand_position[INDEX_TIP, 1] == pytest.approx(0.23 + RADIUS - 0.007)
    assert rendered_phalanges(world)[INDEX_TIP] == pytest.approx([0.01, 0.23 + RADIUS, 0.0], abs=1e-6)
    assert np.isnan(rendered_phalanges(world)[THUMB_TIP]).all()  # untracked stays unknown


def test_anchor_is_fixed_in_the_body_frame_while_the_object_turns():
    heavy = PlacedObject(ObjectSpec("block", "box", (0.06, 0.06, 0.06), 1e4), (0.0, 0.2, 0.0))
    world = world_of([heavy], effects={"penetration", "friction", "gyroscopic"})
    world = drive(world, lambda t: {"index.distal": (0.0, max(0.23 + RADIUS - 0.004, 0.25 - t), 0.0)}, t_end=0.05)
    anchor = world.data.anchor[INDEX_TIP, 0].copy()
    world.data.angular_velocity[0] = (0.0, 0.0, 0.4)  # spin the cube about z under the finger
    world = drive(world, lambda t: {"index.distal": (0.0, 0.23 + RADIUS - 0.004, 0.0)}, t_start=0.06, t_end=0.1)
    assert world.data.active[INDEX_TIP, 0] and not world.data.sliding[INDEX_TIP, 0]
    assert world.data.anchor[INDEX_TIP, 0] == pytest.approx(anchor, abs=1e-12)
    rot = quat_to_matrix(world.data.orientation[0])
    assert not np.allclose(rot, np.eye(3))


def test_contact_velocity_includes_the_objects_rotation():
    # Eq. 7: a fingertip descending at 0.1 m/s meets the top face of a cube spinning about z at w.
    # At the contact point r = (x, h, 0) the face moves with w x r = (-w h, w x, 0), so
    # v = n . (c_hand_dot - w x r) = -0.1 - w x (Eq. 8): colliding.
    w, x = 2.0, 0.02
    world = world_of([placed("cube", angular_velocity=(0.0, 0.0, w))], effects={"impulse"})
    data = world.data.copy()
    data.valid[INDEX_TIP], data.radius[INDEX_TIP] = True, RADIUS
    data.hand_position[INDEX_TIP] = (x, 0.23 + RADIUS - 1e-4, 0.0)
    data.hand_velocity[INDEX_TIP] = (0.0, -0.1, 0.0)
    detect_contacts(world.model, data)
    assert data.onset[INDEX_TIP, 0]
    assert data.normal_velocity[INDEX_TIP, 0] == pytest.approx(-0.1 - w * x, abs=1e-12)


def test_phalanx_that_appears_inside_an_object_exerts_nothing_until_it_leaves():
    world = world_of([placed("cube")], interaction="impulse_penetration")
    inside = {"index.distal": (0.0, 0.215, 0.0)}
    world = drive(world, lambda t: inside, t_end=0.5)
    assert world.data.ghost[INDEX_TIP, 0] and not world.data.active.any()
    assert not world.data.velocity.any()
    # leave, then come back: now it is a real contact that pushes
    world = drive(world, lambda t: {"index.distal": (0.0, 0.215 + 0.1 * min(1.0, (t - 0.5) / 0.3), 0.0)},
                  t_start=0.51, t_end=0.9)
    assert not world.data.ghost.any()
    world = drive(world, lambda t: {"index.distal": (0.0, 0.315 - 0.5 * (t - 0.9), 0.0)}, t_start=0.91, t_end=1.1)
    assert world.data.velocity[0, 1] < -0.3


@pytest.mark.parametrize("continuous, tunnels", [(True, False), (False, True)])
def test_fast_slap_on_thin_plate_needs_continuous_collision(continuous, tunnels):
    # A fingertip at 5 m/s, 90 Hz tracking, one physics step a frame: it moves 5.6 cm a frame,
    # more than plate (5 mm) plus sphere (16 mm): without the swept test it passes through.
    plate = PlacedObject(ObjectSpec("plate", "box", (0.1, 0.005, 0.1), 0.05), (0.0, 0.2, 0.0))
    effects = {"impulse", "penetration", "friction"} | ({"continuous_collision"} if continuous else set())
    world = world_of([plate], effects=effects, tracking_rate=90.0, substeps=1)
    phase = 0.0314  # puts the tip 1.3 cm above the plate's top one frame before it would overlap
    world = drive(world, lambda t: {"index.distal": (0.0, 0.2 + 0.0025 + RADIUS + 0.25 - 5.0 * (t + phase), 0.0)},
                  t_end=0.1, rate=90.0)
    moved = world.data.velocity[0, 1] < -1.0
    assert moved is not tunnels


def pressed_into(face, depth=0.004, shift=(0.0, 0.0, 0.0)):
    """A path for a fingertip that comes in along ``face``'s normal and ends ``depth`` inside it."""
    n = np.asarray(face, dtype=float)
    end = np.array([0.0, 0.2, 0.0]) + n * (0.03 + RADIUS - depth) + shift
    return lambda t: end + n * 0.02 * (1.0 - min(1.0, t / 0.2))


@pytest.mark.parametrize("thumb_face, index_face, shift, is_grasp", [
    ((-1, 0, 0), (1, 0, 0), (0, 0, 0), True),        # opposite faces: a pinch
    ((0, 1, 0), (0, 1, 0), (0.015, 0, 0), False),    # both on top: a push
    ((0, 1, 0), (1, 0, 0), (0, 0, 0), False),        # perpendicular faces: not opposing
])
def test_grasp_needs_thumb_and_an_opposing_digit(thumb_face, index_face, shift, is_grasp):
    thumb, index = pressed_into(thumb_face), pressed_into(index_face, shift=shift)
    heavy = PlacedObject(ObjectSpec("block", "box", (0.06, 0.06, 0.06), 1e4), (0.0, 0.2, 0.0))
    world = world_of([heavy], effects={"penetration", "friction"})
    world = drive(world, lambda t: {"thumb.distal": thumb(t), "index.distal": index(t)}, t_end=0.25)
    assert touching(world)[[THUMB_TIP, INDEX_TIP], 0].all()
    assert grasped(world)[0] is np.bool_(is_grasp)
