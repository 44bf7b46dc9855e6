"""The window filter's noise-versus-lag trade-off (paper, section 3.2), measured on a recording.

The frames first pass the tracking guard, as in a session, then the fingertips of one hand go
through Eq. 1 (``filter_series``) for each window size F, on the frames that arrived, with the
recording's median frame interval as the nominal period.

Jitter: RMS length of the second difference x[i+1] - 2 x[i] + x[i-1] of the five fingertip
positions (mm), over triples of consecutive frames of one track without a gap between them. It
holds tracking noise plus true acceleration times the period squared; the filter can only shrink
the noise part, so it falls toward the motion's own floor as F grows.

Lag: the time shift tau that best aligns the filtered fingertips with the raw ones, i.e. that
minimises the RMS of y(t_i) - x(t_i - tau), with x the raw trajectory interpolated linearly between
the actual timestamps. It is measured from the data, so it is the delay a user sees on the real
motion, uneven frame spacing and dropped frames included. For comparison the table also gives the
nominal lag, (F - 1) / 2 median periods: the filter's delay on a motion of constant velocity. ``residual_mm`` is the RMS misfit left at the best shift: how much the
filter changes the shape of the motion beyond delaying it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar

from .filter import filter_series
from microg.skeleton import DIGITS, SIDES, HandFrame
from .guard import Guard, GuardConfig

WINDOWS = tuple(range(1, 8))
MAX_LAG = 0.1
"""s: the longest shift searched for the best alignment."""
LAG_STEP = 5e-4
"""s: grid step of the search, refined by a bounded scalar minimisation around the best point."""


@dataclass(frozen=True)
class Fingertips:
    """The fingertip trajectory of one hand, on the frames where it was tracked."""

    side: str
    times: np.ndarray
    """(n,) s."""
    tips: np.ndarray
    """(n, 5, 3) m."""
    track: np.ndarray
    """(n,) track number: the filter restarts where it changes."""

    @property
    def period(self) -> float:
        """The median interval between consecutive frames of a track (s)."""
        return float(np.median(self._intervals()))

    def _intervals(self) -> np.ndarray:
        same = self.track[1:] == self.track[:-1]
        return np.diff(self.times)[same]


def fingertips(frames, side: str | None = None, config: GuardConfig = GuardConfig()) -> Fingertips:
    """The guarded fingertip trajectory of ``side`` (default: the side tracked in most frames)."""
    guard = Guard(config)
    passed = [ready for frame in frames for ready in guard.admit(frame)] + list(guard.finish())
    if side is None:
        seen = [sum(f.hand(s) is not None for f in passed) for s in SIDES]
        side = SIDES[int(np.argmax(seen))]
    times, tips, track, previous = [], [], [], None
    number = 0
    for frame in passed:
        hand = frame.hand(side)
        if hand is None:
            previous = None
            continue
        if previous is None or hand.track_id != previous:
            number += 1
        previous = hand.track_id
        times.append(frame.timestamp)
        tips.append(hand.joints[:, -1])
        track.append(number)
    if len(times) < 3:
        raise ValueError(f"the {side} hand is tracked in {len(times)} frames; the report needs at least 3")
    return Fingertips(side, np.array(times), np.array(tips), np.array(track))


def _new_track(data: Fingertips) -> np.ndarray:
    """(n,) True at the first frame of each track."""
    return np.r_[True, data.track[1:] != data.track[:-1]]


def _position_in_track(data: Fingertips) -> np.ndarray:
    """(n,) how many frames of its track come before each frame."""
    index = np.arange(len(data.track))
    return index - np.maximum.accumulate(np.where(_new_track(data), index, 0))


def jitter(data: Fingertips, filtered: np.ndarray, window: int, gap_factor: float = 1.5) -> float:
    """RMS second difference (m) of the filtered tips over triples whose every input sample (the
    window before each of the three) lies in one track, evenly spaced: no gap feeds the measure."""
    steady = (data.track[1:] == data.track[:-1]) & (np.diff(data.times) <= gap_factor * data.period)
    span = window + 1  # the intervals from frame m - window to m + 1 feed the triple centred on m
    runs = np.convolve(steady.astype(int), np.ones(span, dtype=int), mode="valid") == span
    middle = np.flatnonzero(runs) + window
    second = filtered[middle + 1] - 2 * filtered[middle] + filtered[middle - 1]
    return float(np.sqrt(np.mean(np.sum(second ** 2, axis=-1))))


def _misfit(data: Fingertips, filtered: np.ndarray, rows: np.ndarray, tau: float) -> float:
    """RMS distance (m) between the filtered tips and the raw tips ``tau`` seconds earlier."""
    squared = 0.0
    for number in np.unique(data.track[rows]):
        times, tips = data.times[data.track == number], data.tips[data.track == number]
        mine = rows[data.track[rows] == number]
        query = data.times[mine] - tau
        after = np.clip(np.searchsorted(times, query, side="right"), 1, len(times) - 1)
        weight = ((query - times[after - 1]) / (times[after] - times[after - 1]))[:, None, None]
        raw = (1 - weight) * tips[after - 1] + weight * tips[after]
        squared += np.sum((filtered[mine] - raw) ** 2)
    return float(np.sqrt(squared / (len(rows) * data.tips.shape[1])))


def alignment_lag(data: Fingertips, filtered: np.ndarray, usable: np.ndarray) -> tuple[float, float]:
    """The shift (s) that best aligns filtered with raw tips, and the RMS misfit (m) left there."""
    starts = {n: data.times[data.track == n][0] for n in np.unique(data.track)}
    start = np.array([starts[n] for n in data.track])
    rows = np.flatnonzero(usable & (data.times - MAX_LAG >= start))
    if rows.size == 0:
        raise ValueError(f"no frame is more than {MAX_LAG} s into a track: too short to measure lag")
    grid = np.arange(0.0, MAX_LAG + LAG_STEP / 2, LAG_STEP)
    misfits = np.array([_misfit(data, filtered, rows, tau) for tau in grid])
    best = grid[int(np.argmin(misfits))]
    refined = minimize_scalar(lambda tau: _misfit(data, filtered, rows, tau), method="bounded",
                              bounds=(max(0.0, best - LAG_STEP), min(MAX_LAG, best + LAG_STEP)),
                              options={"xatol": 1e-8})
    return float(refined.x), float(refined.fun)


def filter_report(frames: list[HandFrame] | tuple[HandFrame, ...], windows=WINDOWS, side: str | None = None,
                  config: GuardConfig = GuardConfig()) -> pd.DataFrame:
    """One row per window size F: jitter, lag measured by alignment, nominal lag, residual misfit."""
    data = fingertips(frames, side, config)
    period = data.period
    rows = []
    for window in windows:
        filtered = filter_series(data.tips, data.times, window, period, _new_track(data))
        usable = _position_in_track(data) >= window - 1
        lag, residual = alignment_lag(data, filtered, usable)
        rows.append({"window": window, "jitter_mm": 1e3 * jitter(data, filtered, window),
                     "lag_ms": 1e3 * lag, "lag_frames": lag / period,
                     "nominal_lag_ms": 1e3 * (window - 1) / 2 * period, "residual_mm": 1e3 * residual})
    table = pd.DataFrame(rows)
    raw = 1e3 * jitter(data, data.tips, 1)
    table.insert(2, "jitter_ratio", table["jitter_mm"] / raw)
    table.attrs.update(side=data.side, frames=len(data.times), period_ms=1e3 * period,
                       raw_jitter_mm=raw, tracks=int(data.track.max()))
    return table


def plot_filter_report(table: pd.DataFrame, frames, path: str | Path, title: str = "",
                       config: GuardConfig = GuardConfig()) -> Path:
    """Save the trade-off (jitter against lag, one point per F) and a fingertip trace beside it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = fingertips(frames, table.attrs.get("side"), config)
    fig, (tradeoff, trace) = plt.subplots(1, 2, figsize=(11, 4.2))
    tradeoff.plot(table["lag_ms"], table["jitter_mm"], "o-", color="tab:blue")
    for row in table.itertuples():
        tradeoff.annotate(f"F={row.window}", (row.lag_ms, row.jitter_mm), textcoords="offset points",
                          xytext=(6, 4), fontsize=9)
    if (paper := table[table["window"] == 3]).size:
        tradeoff.plot(paper["lag_ms"], paper["jitter_mm"], "o", ms=12, mfc="none", mec="tab:red",
                      label="F = 3 (paper)")
        tradeoff.legend()
    tradeoff.set_xlabel("lag (ms): shift that best aligns filtered with raw")
    tradeoff.set_ylabel("jitter (mm): RMS second difference of fingertips")
    tradeoff.set_title("noise versus lag, F = 1..7")
    tradeoff.grid(alpha=0.3)

    speed = np.linalg.norm(np.diff(data.tips, axis=0), axis=-1).sum(axis=1) / np.diff(data.times)
    centre = data.times[int(np.argmax(speed))]
    shown = np.abs(data.times - centre) <= 0.25
    digit, axis = np.unravel_index(np.argmax(np.ptp(data.tips[shown], axis=0)), data.tips.shape[1:])
    t0 = data.times[shown][0]
    trace.plot(1e3 * (data.times[shown] - t0), 1e3 * data.tips[shown, digit, axis], "k.-", lw=1, ms=4,
               label="raw (F = 1)")
    for window, colour in ((3, "tab:red"), (7, "tab:green")):
        filtered = filter_series(data.tips, data.times, window, data.period, _new_track(data))
        trace.plot(1e3 * (data.times[shown] - t0), 1e3 * filtered[shown, digit, axis], ".-", color=colour,
                   lw=1, ms=3, label=f"F = {window}")
    trace.set_xlabel("time (ms), around the fastest motion")
    trace.set_ylabel(f"{DIGITS[digit]} tip {'xyz'[axis]} (mm)")
    trace.set_title(f"{data.side} {DIGITS[digit]} fingertip, raw and filtered")
    trace.legend()
    trace.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
