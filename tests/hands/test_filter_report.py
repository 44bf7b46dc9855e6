"""Jitter and lag of the window filter, against what they must be analytically."""

import numpy as np
import pytest

from microg.skeleton import Hand, HandFrame
from microg.hands import load_recording
from microg.hands.filter_report import filter_report
from tests.hands.synthetic import WIDTHS

RATE = 110.0


def tips_frames(times, tips) -> list[HandFrame]:
    """Frames of a right hand whose fingertips are at ``tips`` (n, 5, 3) and knuckles 9 cm behind."""
    frames = []
    for t, tip in zip(times, tips):
        joints = np.repeat(tip[:, None, :], 5, axis=1) + np.array([0.0, 0.0, 0.09]) * np.linspace(1, 0, 5)[:, None]
        joints[0, 0] = joints[0, 1]
        frames.append(HandFrame(float(t), (Hand("right", joints, WIDTHS, tip.mean(axis=0), track_id=1),)))
    return frames


def swaying(times) -> np.ndarray:
    """Fingertips swaying smoothly (0.5 Hz, 4 cm): slow enough that a short average only delays it."""
    offsets = np.linspace(-0.04, 0.04, 5)[:, None] * np.array([1.0, 0.0, 0.0])
    path = 0.04 * np.sin(2 * np.pi * 0.5 * times)[:, None] * np.array([0.3, 1.0, -0.5])
    return path[:, None, :] + offsets[None] + np.array([0.0, 0.2, 0.0])


def test_at_a_steady_110_hz_the_lag_is_half_the_window_minus_one_periods():
    times = np.arange(330) / RATE
    table = filter_report(tips_frames(times, swaying(times)))
    lag_periods = table.set_index("window")["lag_frames"]
    assert lag_periods[3] == pytest.approx(1.0, abs=0.01)  # F = 3: one frame period, ~9.1 ms
    assert lag_periods.to_numpy() == pytest.approx((np.arange(1, 8) - 1) / 2, abs=0.02)
    assert table.set_index("window")["lag_ms"][3] == pytest.approx(1000 / RATE, rel=0.01)


def test_on_uneven_frames_with_gaps_the_lag_stays_the_nominal_one():
    """The alignment lag comes from the trajectories; Eq. 1 on arrived frames keeps (F - 1) / 2
    nominal periods of lag across dropped frames."""
    rng = np.random.default_rng(11)
    intervals = rng.uniform(0.0085, 0.0095, 400)
    intervals[rng.choice(400, 25, replace=False)] *= 3  # two frames missing, as in the recordings
    times = np.cumsum(intervals)
    table = filter_report(tips_frames(times, swaying(times)))
    assert table["lag_ms"].to_numpy() == pytest.approx(table["nominal_lag_ms"].to_numpy(), rel=0.05, abs=0.05)
    assert table.set_index("window")["lag_frames"][3] == pytest.approx(1.0, abs=0.05)


def test_jitter_of_white_noise_falls_as_the_window_predicts():
    """Static tips with noise sigma: the second difference of the raw has variance 6 sigma^2 per
    axis, that of an F-average (F >= 2) 4 sigma^2 / F^2; three axes."""
    sigma, n = 0.0005, 2000
    rng = np.random.default_rng(12)
    times = np.arange(n) / RATE
    tips = swaying(np.zeros(n)) + rng.normal(0, sigma, (n, 5, 3))
    table = filter_report(tips_frames(times, tips)).set_index("window")
    expected = [np.sqrt(18) * sigma] + [np.sqrt(12) * sigma / f for f in range(2, 8)]
    assert table["jitter_mm"].to_numpy() == pytest.approx(1e3 * np.array(expected), rel=0.03)
    assert table["jitter_ratio"][1] == 1.0


def test_on_the_grab_recording_f3_lags_about_one_frame_and_jitter_falls_with_f(recordings):
    recording = load_recording(recordings / "grab.json.gz")
    table = filter_report(recording.frames)
    assert list(table["window"]) == list(range(1, 8))
    assert (np.diff(table["jitter_mm"]) < 0).all()
    assert (np.diff(table["lag_ms"]) > 0).all()
    assert 0.8 < table.set_index("window")["lag_frames"][3] < 1.3
    assert table.attrs["frames"] == 374 and table.attrs["side"] == "right"


def test_too_little_tracking_is_refused():
    times = np.arange(2) / RATE
    with pytest.raises(ValueError, match="tracked in 2 frames"):
        filter_report(tips_frames(times, swaying(times)))

