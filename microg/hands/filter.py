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

``HandFilter`` runs it on a stream of hand frames, once per frame, after the tracking guard
(``microg.hands.tracking``): each side's joints go through their own window, and a hand that
appears or comes with a new track id (the guard numbers tracks) starts an empty one.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from microg.skeleton import HANDS, N_BONES, N_DIGITS, HandFrame, hand_frame, hands_record

FILTER_WINDOW = 3
"""F in Eq. 1, the frames the window filter averages: the paper found 3 best. A protocol may set
another (``scene.filter_window``)."""


@njit(cache=True)
def window_mean(samples, times, count, newest, period):
    """Eq. 1 over the ``count`` newest samples of a ring (``samples`` (F, ...), ``times`` (F,), the
    newest at ``newest``): the least-squares line through them, read (count - 1) / 2 periods
    before the newest. Its weights sum to 1; for evenly spaced times at the nominal period each is
    1 / count (the plain average). Compiled: the filter runs on every frame."""
    window = samples.shape[0]
    flat = samples.reshape((window, -1))
    value = flat[newest] * 1.0
    if count == 1:
        return value.reshape(samples.shape[1:])
    mean = 0.0
    for k in range(count):
        mean += times[(newest - k) % window]
    mean /= count
    spread = 0.0
    for k in range(count):
        d = times[(newest - k) % window] - mean
        spread += d * d
    lever = (times[newest] - 0.5 * (count - 1) * period - mean) / spread
    for k in range(count):
        i = (newest - k) % window
        weight = 1.0 / count + lever * (times[i] - mean)
        if k == 0:
            for j in range(value.size):
                value[j] = weight * flat[i, j]
        else:
            for j in range(value.size):
                value[j] += weight * flat[i, j]
    return value.reshape(samples.shape[1:])


class WindowFilter:
    """The last ``window`` arrived samples (arrays of one shape) and their times, in a ring."""

    def __init__(self, window: int, period: float, shape: tuple[int, ...]):
        self.window, self.period = window, period
        """``period``: the nominal frame period (s); the lag is (window - 1) / 2 of it."""
        self.samples = np.zeros((window, *shape))
        self.times = np.zeros(window)
        self.count, self.newest = 0, -1

    def push(self, sample: np.ndarray, time: float) -> None:
        self.newest = (self.newest + 1) % self.window
        self.samples[self.newest], self.times[self.newest] = sample, time
        self.count = min(self.count + 1, self.window)

    def reset(self) -> None:
        """Empty the window: a new track starts."""
        self.count, self.newest = 0, -1

    @property
    def value(self) -> np.ndarray:
        """Eq. 1 on the samples in the window."""
        return window_mean(self.samples, self.times, self.count, self.newest, self.period)


def filter_series(values: np.ndarray, times: np.ndarray, window: int, period: float,
                  new_track: np.ndarray | None = None) -> np.ndarray:
    """Eq. 1 over a series of arrived samples (axis 0) at ``times``; ``new_track`` restarts it."""
    state = WindowFilter(window, period, values.shape[1:])
    out = np.empty(values.shape, dtype=np.float64)
    for i, sample in enumerate(values):
        if new_track is not None and new_track[i]:
            state.reset()
        state.push(sample, times[i])
        out[i] = state.value
    return out


JOINTS = N_DIGITS * (N_BONES + 1)


@lru_cache(maxsize=None)
def filter_dtype(window: int) -> np.dtype:
    """The window filter's state for ``window`` frames (a record): per side the ring of the last
    joints and their times, how many it holds, the newest's place, and the track it belongs to
    (``tracked`` 0: none)."""
    return np.dtype([("samples", "f8", (2, window, JOINTS, 3)), ("times", "f8", (2, window)), ("count", "i8", (2,)),
                     ("newest", "i8", (2,)), ("track", "i8", (2,)), ("tracked", "u1", (2,))], align=True)


@njit(cache=True)
def smooth(state, period, frame, out):
    """Eq. 1 on one admitted ``HANDS`` record ``frame``: ``out`` is the frame with each hand's joints
    filtered over its side's window (the palm and everything else as it came). A hand that
    appears or comes with a new track id starts an empty window."""
    out.t = frame.t
    for side in range(2):
        out.present[side], out.track_id[side] = frame.present[side], frame.track_id[side]
        out.points[side] = frame.points[side]
        out.widths[side] = frame.widths[side]
        out.orientation[side] = frame.orientation[side]
        if not frame.present[side]:
            state.tracked[side] = 0
            continue
        if not state.tracked[side] or state.track[side] != frame.track_id[side]:
            state.count[side], state.newest[side] = 0, -1
        window = state.times.shape[1]
        newest = (state.newest[side] + 1) % window
        state.newest[side], state.count[side] = newest, min(state.count[side] + 1, window)
        state.samples[side, newest] = frame.points[side, 1:]
        state.times[side, newest] = frame.t
        out.points[side, 1:] = window_mean(state.samples[side], state.times[side], state.count[side], newest, period)
        state.tracked[side], state.track[side] = 1, frame.track_id[side]


class HandFilter:
    """Eq. 1 on the joints of every frame that passes, per side (see the module docstring), for
    Python: its state is the record ``smooth`` steps."""

    def __init__(self, window: int, period: float):
        if not isinstance(window, int) or isinstance(window, bool) or window < 1:
            raise ValueError(f"filter window = {window!r}: must be a whole number of frames >= 1")
        self.period = period
        self.state = np.zeros(1, filter_dtype(window))[0]
        self._out = np.zeros(1, HANDS)[0]

    def smooth(self, frame: HandFrame) -> HandFrame:
        """The frame with each hand's joints filtered; everything else as it came."""
        smooth(self.state, self.period, hands_record(frame), self._out)
        return hand_frame(self._out)
