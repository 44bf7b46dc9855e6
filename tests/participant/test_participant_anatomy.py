"""The kinematic hand: Leap-shaped, rigid bones, mirrored left hand, and faithful to real recordings."""

import numpy as np
import pytest
from scipy.optimize import least_squares

from microg.paths import LEAP_RECORDINGS
from microg.skeleton import Hand
from microg.participant import calibration
from microg.participant.noise import FrameTiming, TrackingNoiseLevels
from microg.participant.anatomy import (
    DIGIT_WIDTHS,
    KNUCKLES,
    LOWER,
    PHALANGES,
    REST,
    UPPER,
    local_joints,
    make_hand,
    to_world,
)


def random_posture(rng):
    return LOWER + rng.random(LOWER.shape) * (UPPER - LOWER)


def test_a_posed_hand_is_a_full_leap_skeleton_with_rigid_bones():
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.normal(size=4)
        hand = make_hand(random_posture(rng), rng.normal(size=3) * 0.1, q / np.linalg.norm(q))
        assert isinstance(hand, Hand)
        # Valid as the hand type checks it (make_hand skips the check: the hand is valid by construction).
        assert Hand(hand.side, hand.joints, hand.widths, hand.palm_position, hand.palm_orientation, 1) == hand
        assert not hand.joints.flags.writeable and not hand.palm_position.flags.writeable
        lengths = hand.bone_lengths
        assert lengths[0, 0] == 0.0  # the thumb's metacarpal, as Leap reports it
        np.testing.assert_allclose(lengths[:, 1:], PHALANGES, atol=1e-12)
        assert (lengths[1:, 0] > 0.05).all() and (lengths[1:, 0] < 0.07).all()
        assert hand.phalanx_mask.sum() == 19
        np.testing.assert_allclose(hand.widths, np.repeat(DIGIT_WIDTHS[:, None], 4, axis=1))


def test_palm_pose_moves_the_hand_rigidly():
    rng = np.random.default_rng(1)
    posture = random_posture(rng)
    q = np.array([np.cos(0.4), 0.0, np.sin(0.4), 0.0])  # 0.8 rad about y
    hand = make_hand(posture, np.array([0.1, 0.2, 0.3]), q)
    local = local_joints(posture)
    c, s = np.cos(0.8), np.sin(0.8)
    rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    np.testing.assert_allclose(hand.joints, local @ rotation.T + [0.1, 0.2, 0.3], atol=1e-12)


def test_a_made_hand_is_bit_for_bit_its_local_joints_taken_to_the_world():
    rng = np.random.default_rng(3)
    for side in ("left", "right"):
        posture, q = random_posture(rng), rng.normal(size=4)
        position, q = rng.normal(size=3) * 0.1, q / np.linalg.norm(q)
        expected = to_world(local_joints(posture), position, q, side)
        assert np.array_equal(make_hand(posture, position, q, side).joints, expected)


def test_the_left_hand_is_the_mirror_image_of_the_right():
    posture = random_posture(np.random.default_rng(2))
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    right = make_hand(posture, np.zeros(3), identity, "right")
    left = make_hand(posture, np.zeros(3), identity, "left")
    np.testing.assert_allclose(left.joints, right.joints * [-1.0, 1.0, 1.0])
    # The thumb is on the -x side of a right palm-down hand (LeapC basis), the +x side of a left one.
    assert right.joints[0, 4, 0] < right.joints[4, 4, 0] and left.joints[0, 4, 0] > left.joints[4, 4, 0]


def test_rest_posture_points_the_fingers_ahead_of_the_knuckles():
    joints = local_joints(REST)
    assert (joints[1:, 4, 2] < KNUCKLES[1:, 2] - 0.05).all()
    assert (np.abs(joints[1:, 4, 1]) < 0.05).all()


def test_constants_equal_what_the_recordings_measure():
    recordings = calibration.load_all(LEAP_RECORDINGS)
    skeleton = calibration.measure_skeleton(recordings)
    np.testing.assert_allclose(PHALANGES, skeleton["lengths"], atol=0.06e-3)
    np.testing.assert_allclose(DIGIT_WIDTHS, skeleton["widths"], atol=0.06e-3)
    np.testing.assert_allclose(KNUCKLES, skeleton["knuckles"], atol=0.06e-3)
    timing = calibration.measure_frame_intervals(recordings)
    default = FrameTiming()
    assert default.period == pytest.approx(timing["period"], abs=0.005e-3)
    assert default.jitter_sd == pytest.approx(timing["jitter_sd"], abs=0.005e-3)
    assert default.p_one_missing == pytest.approx(timing["p_two"], abs=1e-4)
    assert default.p_two_missing == pytest.approx(timing["p_three"], abs=1e-4)
    still = calibration.measure_still_noise(next(r for r in recordings if r.name == calibration.STILL_RECORDING))
    levels = TrackingNoiseLevels()
    assert levels.palm_position == pytest.approx(still["palm_position"], abs=0.1e-6)
    assert levels.palm_rotation == pytest.approx(still["palm_rotation"], abs=0.001e-3)
    assert levels.digit_angle == pytest.approx(still["flexion"], abs=0.001e-3)


def test_the_kinematic_model_reproduces_recorded_hands_within_a_few_millimetres():
    """Fit the joint angles to recorded frames: the measured skeleton must be able to pose them."""
    errors = []
    for recording in calibration.load_all(LEAP_RECORDINGS):
        for t in range(0, len(recording.time), 40):
            recorded = np.einsum("ij,dkj->dki", recording.basis[t], recording.joints[t] - recording.palm[t])

            def residual(x, recorded=recorded):
                return (local_joints(x.reshape(5, 4))[:, 2:] - recorded[:, 1:]).ravel() * 1e3

            fit = least_squares(residual, REST.ravel(), bounds=(LOWER.ravel() - 0.3, UPPER.ravel() + 0.3))
            errors.append(np.linalg.norm(fit.fun.reshape(5, 3, 3), axis=-1).max())
    assert np.median(errors) < 6.0
    assert np.percentile(errors, 90) < 12.0
