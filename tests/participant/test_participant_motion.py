"""Minimum-jerk movements, Fitts' law and slerp against their closed forms."""

import math

import numpy as np
import pytest

from microg.participant.motion import (
    minimum_jerk,
    movement_time,
    slerp,
)


def test_minimum_jerk_meets_its_boundary_conditions():
    tau = np.linspace(0.0, 1.0, 200_001)
    s = minimum_jerk(tau)
    h = tau[1] - tau[0]
    velocity = np.gradient(s, h)
    acceleration = np.gradient(velocity, h)
    assert s[0] == 0.0 and s[-1] == pytest.approx(1.0, abs=1e-15)
    assert abs(velocity[0]) < 1e-6 and abs(velocity[-1]) < 1e-6
    assert abs(acceleration[1]) < 1e-3 and abs(acceleration[-2]) < 1e-3
    # Symmetric about the middle: s(1 - tau) = 1 - s(tau).
    np.testing.assert_allclose(s[::-1], 1.0 - s, atol=1e-12)


def test_minimum_jerk_peak_speed_is_1_875_times_the_mean_at_mid_time():
    tau = np.linspace(0.0, 1.0, 100_001)
    speed = np.gradient(minimum_jerk(tau), tau)
    assert tau[np.argmax(speed)] == pytest.approx(0.5, abs=1e-4)
    assert speed.max() / np.mean(speed) == pytest.approx(1.875, rel=1e-4)


def test_minimum_jerk_is_the_quintic_that_flash_and_hogan_derived():
    # The unique quintic with s(0)=0, s(1)=1 and zero velocity and acceleration at both ends.
    rows = [[t ** k for k in range(6)] for t in (0.0, 1.0)]
    rows += [[k * t ** (k - 1) if k else 0.0 for k in range(6)] for t in (0.0, 1.0)]
    rows += [[k * (k - 1) * t ** (k - 2) if k > 1 else 0.0 for k in range(6)] for t in (0.0, 1.0)]
    coefficients = np.linalg.solve(np.array(rows), [0.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    tau = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(minimum_jerk(tau), np.polyval(coefficients[::-1], tau), atol=1e-12)


def test_fitts_law_adds_one_slope_per_doubling_of_difficulty():
    a, b = 0.3, 0.15
    assert movement_time(0.0, 0.01, a, b) == pytest.approx(a)
    # D / W + 1 = 4 and 8: two and three bits.
    assert movement_time(0.06, 0.01, a, b) == pytest.approx(a + 2 * b)
    assert movement_time(0.14, 0.01, a, b) == pytest.approx(a + 3 * b)


def test_slerp_keeps_unit_length_and_turns_at_constant_rate():
    half_turn_about_y = np.array([math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0])
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    for s in (0.0, 0.25, 0.5, 1.0):
        q = slerp(identity, half_turn_about_y, s)
        assert np.linalg.norm(q) == pytest.approx(1.0)
        # The rotation angle grows linearly: 2 acos(w) = s * pi / 2.
        assert 2 * math.acos(min(q[0], 1.0)) == pytest.approx(s * math.pi / 2, abs=1e-12)
    # The shortest way round: -q is the same rotation.
    np.testing.assert_allclose(slerp(identity, -half_turn_about_y, 1.0), half_turn_about_y, atol=1e-12)


def test_a_movement_lasts_at_least_what_the_fastest_point_of_a_hand_allows():
    """Issue 28: a movement's duration is its Fitts time or, when that is shorter, the time at which
    its farthest point (the translation plus the turn at HAND_LENGTH) peaks at MAX_POINT_SPEED
    (minimum jerk: peak speed 1.875 D / T)."""
    from microg.participant.actions import HAND_LENGTH, MAX_POINT_SPEED, STATE, _begin_movement

    states = np.zeros(1, STATE)
    states[0]["pose"]["orientation"] = [1.0, 0.0, 0.0, 0.0]
    states[0]["end"]["position"] = [0.2, 0.0, 0.0]
    states[0]["end"]["orientation"] = [0.0, 0.0, 0.0, 1.0]  # half a turn about z
    _begin_movement(states[0], 1.0, 0.01)
    assert states[0]["begin"] == 1.0
    assert states[0]["duration"] == pytest.approx(1.875 * (0.2 + math.pi * HAND_LENGTH) / MAX_POINT_SPEED, rel=1e-12)
    _begin_movement(states[0], 2.0, 5.0)  # a slower movement keeps its time
    assert states[0]["duration"] == 5.0
