"""What makes simulated frames look measured: frame timing, physiological tremor, tracking noise.

Frame timing (measured on the shared recordings, 1076 intervals): frames come every
``period`` = 8.72 ms (median; 115 Hz, one recording 110 Hz) with a jitter of SD 0.18 ms; an
interval spans two periods (one frame missing) with probability 0.0019 and three periods (two
missing, about 26-27 ms) with probability 0.0074.

Physiological tremor: a narrow-band oscillation of the whole hand at 8-12 Hz, modelled as a
sinusoid per axis with slowly wandering frequency and amplitude (the modulated-sinusoid model of
tremor cancelling, Riviere et al. 1998). Its RMS amplitude per axis is a skill parameter; the
literature gives about 50-100 um RMS per axis for a hand held still (Becker et al. 2008: 96.6 +-
84.5 um RMS under microsurgical conditions, 45-63 um per axis for a braced hand).

Tracking noise: the Leap reports a still hand with a smooth wander whose spectrum rolls off as
f^-3 to f^-5 above a few hertz (the device filters internally). It is modelled per pose
parameter (palm position, palm rotation, digit base angles) as white noise through two
first-order low-pass stages with a 5 Hz corner (an f^-4 roll-off), scaled so that its RMS above
5 Hz equals what the still hand of ``pinch.json.gz`` shows: 65.7 um (palm position), 0.875 mrad
(palm rotation), 0.967 mrad (digit angles). That puts 18 % of the variance above 5 Hz, so the
stationary SDs are 154 um, 2.05 mrad and 2.27 mrad. All of the still hand's motion above 5 Hz is
counted as noise, so these are upper bounds; they lie within the static precision reported for
the device (Weichert et al. 2013: < 0.2 mm; Guna et al. 2014: SD < 0.5 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass(frozen=True)
class FrameTiming:
    """The frame-interval distribution: whole periods (frames missing) plus jitter, in seconds."""

    period: float = 8.72e-3
    jitter_sd: float = 0.18e-3
    p_one_missing: float = 0.0019
    p_two_missing: float = 0.0074


@njit(cache=True)
def frame_interval(period, jitter_sd, p_one_missing, p_two_missing, rng):
    """One frame interval (s) of a ``FrameTiming``, drawn from ``rng``."""
    u = rng.random()
    periods = 3 if u < p_two_missing else 2 if u < p_two_missing + p_one_missing else 1
    return periods * period + jitter_sd * rng.standard_normal()


def band_fraction(corner: float, band: float) -> float:
    """Fraction of the variance above ``band`` Hz of noise with PSD 1 / (1 + (f/corner)^2)^2."""
    u = band / corner
    return 1.0 - (u / (1.0 + u * u) + math.atan(u)) / (math.pi / 2)


@dataclass(frozen=True)
class TrackingNoiseLevels:
    """RMS above ``band`` Hz of a still tracked hand, measured on the recordings (see module doc)."""

    palm_position: float = 65.7e-6
    palm_rotation: float = 0.875e-3
    digit_angle: float = 0.967e-3
    corner: float = 5.0
    band: float = 5.0

    def stationary_sd(self) -> np.ndarray:
        """(3,) SDs of the whole process: palm position (m), palm rotation (rad), digit angle (rad)."""
        scale = 1.0 / math.sqrt(band_fraction(self.corner, self.band))
        return scale * np.array([self.palm_position, self.palm_rotation, self.digit_angle])


NOISE_SIZE = 16
"""Tracking noise parameters: palm offset (3, m), palm rotation vector (3, rad), digit base angles (5 x 2, rad)."""


def noise_start(levels: TrackingNoiseLevels, rng: np.random.Generator) -> tuple[float, np.ndarray, np.ndarray]:
    """Tracking noise at its start: the stages' time constant (s), each parameter's stationary SD
    (16,) and both stages (2, 16) drawn from their stationary distributions. The second stage is
    the noise's value: the offsets on the intended hand."""
    sd = np.repeat(levels.stationary_sd(), [3, 3, 10])
    # Two equal first-order stages: the output's variance is half the first stage's.
    first = math.sqrt(2.0) * sd * rng.standard_normal(NOISE_SIZE)
    return 1.0 / (2.0 * math.pi * levels.corner), sd, np.stack([first, sd * rng.standard_normal(NOISE_SIZE)])


@njit(cache=True)
def advance_noise(stages, tau, sd, dt, draws, out):
    """The noise's two stages ``dt`` later, driven by 16 standard normal ``draws``, into ``out``."""
    decay = math.exp(-dt / tau)
    gain = math.sqrt(2.0 * (1.0 - decay * decay))
    for i in range(stages.shape[1]):
        first = decay * stages[0, i] + gain * sd[i] * draws[i]
        out[0, i] = first
        out[1, i] = decay * stages[1, i] + (1.0 - decay) * first


@njit(cache=True)
def _ou(value, dt, tau, sd, noise):
    """An Ornstein-Uhlenbeck process of time constant ``tau`` and stationary SD ``sd``, ``dt`` later."""
    decay = math.exp(-dt / tau)
    return decay * value + sd * math.sqrt(1.0 - decay * decay) * noise


# The tremor's constants, at module level for its compiled kernels.
TREMOR_LOW, TREMOR_HIGH = 8.0, 12.0
"""Hz: the band of physiological tremor."""
FREQUENCY_SD, FREQUENCY_TAU = 0.5, 1.0
"""Hz and s: the frequency wanders around the participant's own as an Ornstein-Uhlenbeck process."""
AMPLITUDE_LOG_SD, AMPLITUDE_TAU = 0.3, 0.5
"""The log-amplitude's stationary SD and time constant (s), an Ornstein-Uhlenbeck process too."""


def tremor_start(rms: float, rng: np.random.Generator) -> tuple[float, float, np.ndarray]:
    """Whole-hand physiological tremor of ``rms`` metres per axis at its start: the participant's
    own frequency (Hz), the amplitude at log-amplitude 0 (m) and the oscillators' state (7,): how
    far the frequency has wandered from its own (Hz), the phase of each axis (3, rad), the
    log-amplitude of each axis (3). Per axis a sinusoid of wandering frequency (8-12 Hz) and
    amplitude (``advance_tremor``, ``tremor_value``)."""
    centre = rng.uniform(TREMOR_LOW + 1.0, TREMOR_HIGH - 1.0)
    phase = rng.uniform(0.0, 2.0 * math.pi, 3)
    log_amplitude = AMPLITUDE_LOG_SD * rng.standard_normal(3)
    # E[(A sin)^2] = E[A^2] / 2 with A = A0 exp(z), z ~ N(0, s^2): A0 = rms sqrt(2) exp(-s^2).
    base = rms * math.sqrt(2.0) * math.exp(-AMPLITUDE_LOG_SD ** 2)
    return centre, base, np.concatenate([[0.0], phase, log_amplitude])


@njit(cache=True)
def advance_tremor(state, centre, dt, draws, out):
    """The tremor's state ``dt`` later, driven by 4 standard normal ``draws``, into ``out``."""
    offset = _ou(state[0], dt, FREQUENCY_TAU, FREQUENCY_SD, draws[0])
    frequency = min(max(centre + offset, TREMOR_LOW), TREMOR_HIGH)
    out[0] = offset
    turn = 2.0 * math.pi * frequency * dt
    for i in range(3):
        out[1 + i] = state[1 + i] + turn
        out[4 + i] = _ou(state[4 + i], dt, AMPLITUDE_TAU, AMPLITUDE_LOG_SD, draws[1 + i])


@njit(cache=True)
def tremor_value(state, base, out):
    """The tremor's displacement (3,) in metres, into ``out``."""
    for i in range(3):
        out[i] = base * math.exp(state[4 + i]) * math.sin(state[1 + i])
