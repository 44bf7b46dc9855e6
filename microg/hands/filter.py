"""The window filter on the tracked hand (paper, Eq. 1), defined on the frames that arrived.

    x_i = (1/F) sum_{f=0}^{F-1} x_{i-f}

The paper's sum runs to F with a 1/F in front; we average exactly F samples, which is what a
window of size F means. For evenly spaced frames the average lags the hand by (F - 1) / 2 frame
periods. The tracker's frames are not evenly spaced, and some are missing: averaged as they
arrive, the last F frames after a gap would race ahead of the hand, at (g + F) / F times its speed
for F - 1 frames after g missing frames, and the physics would take that for velocity.

So the filter is Eq. 1 written for uneven arrivals: the least-squares line through the last F
arrived samples, read at the constant lag (F - 1) / 2 nominal periods behind the newest sample.
On evenly spaced frames at the nominal rate that is exactly the plain average (a least-squares
line passes through the mean of its samples, at their mean time); after a gap the lag stays the
same and no frame is invented. A new track (first frame, a hand found again, a jump) empties the
window, so the filter never mixes two tracks.

``HandFilter`` runs it on a stream of hand frames, once per frame, between the tracking guard and
the physics: each side's joints go through their own window, and a hand that appears or comes
with a new track id (the guard numbers tracks) starts an empty one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from microg.sim.hand import N_BONES, N_DIGITS, SIDES, Hand, HandFrame


@dataclass(frozen=True, eq=False)
class WindowFilter:
    """The last ``count`` arrived samples (arrays of any shape) and their times, in a ring."""

    window: int
    period: float
    """Nominal frame period (s): the lag is (window - 1) / 2 of it."""
    samples: np.ndarray
    times: np.ndarray
    count: int = 0
    newest: int = -1

    @classmethod
    def empty(cls, window: int, period: float, shape: tuple[int, ...]) -> WindowFilter:
        return cls(window, period, np.zeros((window, *shape)), np.zeros(window))

    def push(self, sample: np.ndarray, time: float) -> WindowFilter:
        """The filter after ``sample`` arrived at ``time``."""
        newest = (self.newest + 1) % self.window
        samples, times = self.samples.copy(), self.times.copy()
        samples[newest], times[newest] = sample, time
        return WindowFilter(self.window, self.period, samples, times, min(self.count + 1, self.window), newest)

    def reset(self) -> WindowFilter:
        return WindowFilter(self.window, self.period, self.samples, self.times)

    @property
    def value(self) -> np.ndarray:
        """Eq. 1: the window's least-squares line at (count - 1) / 2 periods before the newest sample."""
        index = (self.newest - np.arange(self.count)) % self.window
        samples, times = self.samples[index], self.times[index]
        mean = samples.mean(axis=0)
        if self.count == 1:
            return mean
        spread = times - times.mean()
        slope = np.tensordot(spread, samples - mean, axes=1) / (spread @ spread)
        target = times[0] - 0.5 * (self.count - 1) * self.period
        return mean + slope * (target - times.mean())


def filter_series(values: np.ndarray, times: np.ndarray, window: int, period: float,
                  new_track: np.ndarray | None = None) -> np.ndarray:
    """Eq. 1 over a series of arrived samples (axis 0) at ``times``; ``new_track`` restarts it."""
    state = WindowFilter.empty(window, period, values.shape[1:])
    out = np.empty(values.shape, dtype=np.float64)
    for i, sample in enumerate(values):
        if new_track is not None and new_track[i]:
            state = state.reset()
        state = state.push(sample, times[i])
        out[i] = state.value
    return out


class HandFilter:
    """Eq. 1 on the joints of every frame that passes, per side (see the module docstring)."""

    def __init__(self, window: int, period: float):
        if not isinstance(window, int) or isinstance(window, bool) or window < 1:
            raise ValueError(f"filter window = {window!r}: must be a whole number of frames >= 1")
        self._windows = [WindowFilter.empty(window, period, (N_DIGITS, N_BONES + 1, 3)) for _ in SIDES]
        self._tracks: list[int | None] = [None for _ in SIDES]

    def __call__(self, frame: HandFrame) -> HandFrame:
        """The frame with each hand's joints filtered; everything else as it came."""
        hands = []
        for side, name in enumerate(SIDES):
            hand = frame.hand(name)
            if hand is None:
                self._tracks[side] = None
                continue
            window = self._windows[side] if self._tracks[side] == hand.track_id else self._windows[side].reset()
            self._windows[side] = window.push(hand.joints, frame.timestamp)
            self._tracks[side] = hand.track_id
            hands.append(Hand(hand.side, self._windows[side].value, hand.widths, hand.palm_position,
                              hand.palm_orientation, hand.track_id))
        return HandFrame(frame.timestamp, tuple(hands))
