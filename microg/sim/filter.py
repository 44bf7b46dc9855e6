"""The window filter on the tracked hand (paper, Eq. 1).

    x_i = (1/F) sum_{f=0}^{F-1} x_{i-f}

The paper's sum runs to F with a 1/F in front; we average exactly F samples, which is what a
window of size F means. The window holds the last F frames that *arrived*: a missing frame is
not invented, so after a gap the average spans a longer time. A new track (first frame, a hand
that was lost, a jump) empties the window, so the average never mixes two tracks. Its lag for a
steady motion is the mean age of the samples, (F - 1) / 2 frame periods.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class WindowFilter:
    """The last ``count`` arrived samples of an array of any shape, in a ring of ``window``."""

    window: int
    samples: np.ndarray
    count: int = 0
    newest: int = -1

    @classmethod
    def empty(cls, window: int, shape: tuple[int, ...]) -> WindowFilter:
        return cls(window, np.zeros((window, *shape)))

    def push(self, sample: np.ndarray) -> WindowFilter:
        """The filter after ``sample`` arrived."""
        samples = self.samples.copy()
        newest = (self.newest + 1) % self.window
        samples[newest] = sample
        return WindowFilter(self.window, samples, min(self.count + 1, self.window), newest)

    def reset(self) -> WindowFilter:
        return WindowFilter(self.window, self.samples)

    @property
    def value(self) -> np.ndarray:
        """The mean of the samples in the window (Eq. 1)."""
        if self.count == self.window:
            return self.samples.mean(axis=0)
        return self.samples[(self.newest - np.arange(self.count)) % self.window].mean(axis=0)


def filter_series(values: np.ndarray, window: int, new_track: np.ndarray | None = None) -> np.ndarray:
    """Eq. 1 over a series of arrived samples (axis 0); ``new_track`` marks samples that restart it."""
    state = WindowFilter.empty(window, values.shape[1:])
    out = np.empty_like(values, dtype=np.float64)
    for i, sample in enumerate(values):
        if new_track is not None and new_track[i]:
            state = state.reset()
        state = state.push(sample)
        out[i] = state.value
    return out
