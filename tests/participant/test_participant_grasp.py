"""Grasp templates: the planned hand touches the faces it should, and only those, for every object.

Distances are measured with the physics' own closest-point routine (``contact.closest_surface_point``),
not with the planner's obstacle model.
"""

import numpy as np
import pytest

from microg.paths import object_file
from microg.sim import load_object
from microg.sim.bodies import SHAPES
from microg.sim.contact import closest_surface_point
from microg.participant.grasp import plan_grasp
from microg.skeleton import bone_centres
from microg.participant.anatomy import RADII, local_joints
from microg.sim.rotation import quat_from_euler_deg

OBJECTS = ("cube", "flat_cuboid", "long_cuboid", "ball")


def surface(spec, centres, template):
    """Signed distance of each phalanx sphere from the object (negative: overlap) and the face normal
    it is nearest, both in the hand frame, with the object where the template holds it."""
    half = spec.half_extents
    rotation = template.hand_in_object  # hand axes in the object frame
    gaps, normals = np.empty(centres.shape[:2]), np.empty(centres.shape)
    for d in range(5):
        for b in range(4):
            p = rotation @ (centres[d, b] - template.object_in_hand)
            _, normal, distance = closest_surface_point(SHAPES.index(spec.shape), half, p)
            gaps[d, b] = distance - RADII[d]
            normals[d, b] = rotation.T @ normal
    return gaps, normals


@pytest.mark.parametrize("name", OBJECTS)
def test_thumb_and_fingers_press_opposite_faces_and_nothing_else_hits(name):
    spec = load_object(object_file(name))
    template = plan_grasp(spec.shape, spec.half_extents, np.array([1.0, 0.0, 0.0, 0.0]))

    open_gaps, _ = surface(spec, bone_centres(local_joints(template.posture(-0.010))), template)
    open_gaps[0, 0] = np.inf  # the thumb's zero-length metacarpal is no phalanx
    assert open_gaps.min() > 0.0, "the pre-shaped hand must not touch the object"

    gaps, normals = surface(spec, bone_centres(local_joints(template.posture(0.010))), template)
    gaps[0, 0] = np.inf
    thumb = [normals[0, b] for b in range(4) if gaps[0, b] < -0.004]
    fingers = [normals[d, b] for d in template.digits[1:] for b in range(4) if gaps[d, b] < -0.004]
    assert thumb and fingers, "the thumb and at least one finger press 4 mm into the object"
    # The physics' grasp rule: a thumb contact and a finger contact whose normals oppose (dot < -0.5).
    assert min(t @ f for t in thumb for f in fingers) < -0.5
    # Every phalanx that overlaps squeezes against the other side: no push on a third face.
    for d in range(5):
        for b in range(4):
            if gaps[d, b] < -0.001:
                other_side = fingers if d == 0 else thumb
                assert max(n @ normals[d, b] for n in other_side) < -0.5, f"digit {d} bone {b} pushes sideways"
    # Closing further presses the thumb deeper.
    deeper, _ = surface(spec, bone_centres(local_joints(template.posture(0.018))), template)
    assert min(deeper[0, 1:]) < min(gaps[0, 1:]) - 0.003


def test_side_grasp_puts_the_palm_over_the_object_and_the_flat_clamp_under_it():
    cube = load_object(object_file("cube"))
    plate = load_object(object_file("flat_cuboid"))
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    side = plan_grasp(cube.shape, cube.half_extents, identity)
    flat = plan_grasp(plate.shape, plate.half_extents, identity)
    assert (side.kind, flat.kind) == ("side", "flat")
    # The hand's y axis (out of its back) points up over the cube, down under the plate.
    assert side.hand_pose(np.zeros(3), np.eye(3))[1][:, 1] @ [0.0, 1.0, 0.0] == pytest.approx(1.0)
    assert flat.hand_pose(np.zeros(3), np.eye(3))[1][:, 1] @ [0.0, 1.0, 0.0] == pytest.approx(-1.0)
    # Fingers point away from the user (-z) in both.
    for template in (side, flat):
        assert template.hand_pose(np.zeros(3), np.eye(3))[1][:, 2] @ [0.0, 0.0, 1.0] == pytest.approx(1.0)


def test_a_turned_bar_is_squeezed_across_its_narrow_horizontal_side():
    bar = load_object(object_file("long_cuboid"))
    turned = quat_from_euler_deg(0.0, 90.0, 0.0)  # the 20 cm axis now along world z
    template = plan_grasp(bar.shape, bar.half_extents, turned)
    from microg.sim.rotation import quat_to_matrix
    squeeze_axis = quat_to_matrix(turned) @ template.hand_in_object[:, 2]
    extent = np.abs(template.hand_in_object.T @ bar.half_extents)
    assert extent[2] == pytest.approx(0.0125)
    assert abs(squeeze_axis @ [0.0, 1.0, 0.0]) < 1e-9


@pytest.mark.parametrize("round_object", [False, True])
@pytest.mark.parametrize("drops", [0, 2])
def test_the_grip_is_sized_for_the_weight_through_the_friction_its_contacts_can_use(round_object, drops):
    """The squeeze holds safety x m g with the believed stiffness: a box's faces give friction mu,
    a ball pressed at latitude theta only mu cos(theta) - sin(theta) (the rest of each press pushes it
    out of the grip), so the same ball-weight load takes a deeper squeeze; each drop in the task
    raises the grip by ``drop_grip_gain`` of itself (closed form)."""
    from microg.participant.actions import BELIEVED_STIFFNESS, KEEP_IT, PLAYER, SEEN, STATE, _squeeze_depth
    from microg.participant.grasp import ROUND_LATITUDE

    p, s, seen = np.zeros(1, PLAYER)[0], np.zeros(1, STATE)[0], np.zeros(1, SEEN)[0]
    p["then"], p["round_object"], p["mass"], p["static_friction"] = KEEP_IT, round_object, 0.126, 0.8
    p["gravity"], p["grip_safety"], p["stiffness_belief_sd"], p["drop_grip_gain"] = (0.0, -9.81, 0.0), 1.4, 0.0, 0.5
    s["attempts"] = drops
    seen["touching"][[3, 7, 11]] = 1  # the thumb's and two fingers' distal phalanges
    mu = 0.8 * np.cos(ROUND_LATITUDE) - np.sin(ROUND_LATITUDE) if round_object else 0.8
    force = 1.4 * (1 + 0.5 * drops) * 0.126 * 9.81 / (2 * mu)  # per side
    expected = force * 3 / (2 * BELIEVED_STIFFNESS * 1 * 2)  # one thumb phalanx against two, in series
    assert _squeeze_depth(p, s, seen, np.random.default_rng(0)) == pytest.approx(expected, rel=1e-12)
