"""Frame timing, tracking noise and tremor against the documented distributions and spectra."""

import numpy as np
import pytest
from scipy import signal, stats

from microg.participant.noise import (NOISE_SIZE, FrameTiming, TrackingNoiseLevels, advance_noise, advance_tremor,
                                     band_fraction, frame_interval, noise_start, tremor_start, tremor_value)

RNG_SEED = 2024


def test_frame_intervals_follow_the_measured_distribution():
    timing = FrameTiming()
    rng = np.random.default_rng(RNG_SEED)
    n = 60_000
    intervals = np.array([frame_interval(timing.period, timing.jitter_sd, timing.p_one_missing, timing.p_two_missing,
                                         rng) for _ in range(n)])
    periods = np.rint(intervals / timing.period).astype(int)
    assert set(np.unique(periods)) <= {1, 2, 3}
    single = intervals[periods == 1]
    assert np.median(single) == pytest.approx(timing.period, abs=0.01e-3)
    assert np.std(single) == pytest.approx(timing.jitter_sd, rel=0.05)
    # Missing frames: counts within the binomial 99.9 % interval of the documented probabilities.
    for k, p in ((2, timing.p_one_missing), (3, timing.p_two_missing)):
        low, high = stats.binom.interval(0.999, n, p)
        assert low <= np.sum(periods == k) <= high
    # Two frames missing look like the recordings' 26.0-27.2 ms gaps (give or take the jitter).
    assert np.all((intervals[periods == 3] > 25.0e-3) & (intervals[periods == 3] < 27.5e-3))


def test_band_fraction_matches_numerical_integration_of_the_spectrum():
    f = np.linspace(0.0, 2000.0, 2_000_001)
    psd = 1.0 / (1.0 + (f / 5.0) ** 2) ** 2
    above = np.trapezoid(psd[f >= 5.0], f[f >= 5.0]) / np.trapezoid(psd, f)
    assert band_fraction(5.0, 5.0) == pytest.approx(above, rel=1e-3)
    assert band_fraction(5.0, 5.0) == pytest.approx(0.5 - 1.0 / np.pi, rel=1e-9)


def _noise_series(levels, rng, duration, dt):
    """The tracking noise's value (16,) every ``dt`` seconds for ``duration``, through the kernels a
    simulated participant's frame runs."""
    tau, sd, stages = noise_start(levels, rng)
    values = []
    for _ in range(int(duration / dt)):
        after = np.empty_like(stages)
        advance_noise(stages, tau, sd, dt, rng.standard_normal(NOISE_SIZE), after)
        stages = after
        values.append(stages[1].copy())
    return np.array(values)


def _tremor_series(rms, rng, duration, dt):
    """The tremor's displacement (3,) every ``dt`` seconds for ``duration``, through the same kernels."""
    centre, base, state = tremor_start(rms, rng)
    values = []
    for _ in range(int(duration / dt)):
        after, value = np.empty(7), np.empty(3)
        advance_tremor(state, centre, dt, rng.standard_normal(4), after)
        state = after
        tremor_value(state, base, value)
        values.append(value)
    return np.array(values)


def _high_pass_rms(values, dt, cutoff):
    b, a = signal.butter(4, cutoff, "highpass", fs=1.0 / dt)
    return np.sqrt(np.mean(signal.filtfilt(b, a, values, axis=0)[200:-200] ** 2, axis=0))


def test_tracking_noise_has_the_measured_size_above_5_hz_and_the_stationary_sd():
    levels = TrackingNoiseLevels()
    dt = 1.0 / 115
    series = _noise_series(levels, np.random.default_rng(RNG_SEED), 400.0, dt)
    palm, rotation, digits = series[:, :3], series[:, 3:6], series[:, 6:]
    assert np.mean(_high_pass_rms(palm, dt, 5.0)) == pytest.approx(levels.palm_position, rel=0.15)
    assert np.mean(_high_pass_rms(rotation, dt, 5.0)) == pytest.approx(levels.palm_rotation, rel=0.15)
    assert np.mean(_high_pass_rms(digits, dt, 5.0)) == pytest.approx(levels.digit_angle, rel=0.15)
    np.testing.assert_allclose(series.std(axis=0).reshape(-1)[:3], levels.stationary_sd()[0], rtol=0.2)


def test_tremor_is_a_narrow_band_oscillation_between_8_and_12_hz_of_the_stated_rms():
    for seed in range(5):
        dt = 1.0 / 115
        series = _tremor_series(100e-6, np.random.default_rng(seed), 120.0, dt)
        f, psd = signal.welch(series, fs=1.0 / dt, nperseg=1024, axis=0)
        peak = f[np.argmax(psd.sum(axis=1))]
        assert 8.0 <= peak <= 12.0
        band = (f >= 8.0) & (f <= 12.0)
        assert psd[band].sum() / psd.sum() > 0.9
        assert np.sqrt(np.mean(series ** 2)) == pytest.approx(100e-6, rel=0.15)
