"""The tracking guard: bad tracking is handled here, never passed on to the physics.

Every session's hand tracking passes its source's frames through the guard, then the window
filter. The guard is compiled code over plain records: ``admit(config, guard, pending, decided,
frame, out)`` takes one ``HANDS`` record and writes the frames now ready for the world into
``out`` (none, one, or several), ``finish`` releases what is still waiting when the source ends.
A ``GUARD`` record is the guard's memory, ``pending`` the frames waiting for a decision; ``Guard``
holds them for Python. What it does:

- **Incomplete hand** (NaN in the palm position, or in a joint the tracker normally delivers): the
  hand is left out of the frame, as if lost. "Normally delivers" is learned: every joint this
  side has delivered before. So a recording without metacarpal bases, or a scripted hand that
  tracks two fingertips, passes whole, while a Leap hand that loses a fingertip is dropped.
- **Missing hand**: passes as absent. When it is seen again it starts a new track.
- **Stale timestamp** (equal to or before the last frame's): the frame is dropped and counted as a
  duplicate or as out of order. If ``resync_after`` frames in a row are stale but advance among
  themselves, the tracker's clock went back (a restart): the guard re-anchors its time offset so
  frames continue one period after the last one, and every hand starts a new track.
- **Clock jump** (more than ``max_gap`` seconds ahead): re-anchored the same way, so the physics
  never integrates an invented pause.
- **Dropped frames** (an interval over ``gap_factor`` typical periods): counted and passed on as
  they arrived. The window filter (Eq. 1, ``microg.hands.filter``) is defined on arrived frames and
  keeps its lag constant across a gap, so no frame is invented here.
- **Jump** (the jump rule, ``microg.skeleton.is_jump``: some point of the hand is ``jump_distance``
  or more from where it was in the last frame): the frames wait, for at most ``confirm_frames - 1``
  frames. If the hand comes back near where it was, it was a glitch: the waiting frames get the
  hand bridged linearly from before the glitch to after it. If it stays at the new place for
  ``confirm_frames`` frames in a row, it is a new track there, from the frame it arrived. If it
  keeps jumping for more than ``max_hold`` frames, it is lost. Nothing jumps, nothing freezes and
  catches up.
- **Track ids**: the guard numbers tracks itself (1, 2, 3, ...): a new number whenever the source's
  id changes, a hand reappears, a jump is accepted or the clock is re-anchored. The world starts a
  new track (filter reset, zero velocity) exactly then.

Output timestamps strictly increase. While a jump is being decided every output waits (at most
``confirm_frames - 1`` frames, about 18 ms at the defaults); otherwise each frame passes at once.
``GuardCounts`` counts everything the guard did.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import lru_cache

import numpy as np
from numba import njit

from microg.skeleton import HANDS, JUMP_DISTANCE, N_BONES, N_DIGITS, POINTS, HandFrame, hand_frame, hands_record, is_jump

RECENT_INTERVALS = 31
"""Intervals between arrived frames the typical period is the median of."""


@dataclass(frozen=True)
class GuardConfig:
    jump_distance: float = JUMP_DISTANCE
    """m: a hand that moved this far between two frames jumped (``microg.skeleton.is_jump``); the
    physics learns of an accepted jump by the new track id the guard gives it (and applies the
    rule itself too, with the scene's ``jump_distance``: ``microg.sim.hand_path``)."""
    confirm_frames: int = 3
    """Frames in a row at a jumped-to place before it is accepted as a new track."""
    max_hold: int = 10
    """Frames a hand may keep jumping around before it is marked lost."""
    resync_after: int = 5
    """Stale frames in a row, advancing among themselves, that mean the tracker's clock went back."""
    max_gap: float = 5.0
    """s: a frame further ahead than this is a clock jump, not a pause."""
    nominal_rate: float = 110.0
    """Hz: the frame period assumed until enough intervals have been seen."""
    gap_factor: float = 1.5
    """An interval longer than this many typical periods is a gap (frames missing)."""

    def __post_init__(self) -> None:
        for name in ("jump_distance", "max_gap", "nominal_rate", "gap_factor"):
            if not getattr(self, name) > 0:
                raise ValueError(f"GuardConfig.{name} = {getattr(self, name)!r}: must be positive")
        for name in ("confirm_frames", "max_hold", "resync_after"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise ValueError(f"GuardConfig.{name} = {getattr(self, name)!r}: must be a positive integer")

    def record(self):
        """The settings as a ``CONFIG`` record (what the compiled guard reads)."""
        out = np.zeros(1, CONFIG)[0]
        for f in fields(self):
            out[f.name] = getattr(self, f.name)
        return out

    @property
    def pending_frames(self) -> int:
        """The most frames that can wait for a decision: each side holds at most ``max_hold`` + 1."""
        return 2 * (self.max_hold + 1)


CONFIG = np.dtype([(f.name, "i8" if f.type in ("int", int) else "f8") for f in fields(GuardConfig)], align=True)
"""``GuardConfig`` as a record."""


@dataclass(frozen=True)
class GuardCounts:
    """Everything the guard did, for the session log."""

    frames_in: int = 0
    frames_out: int = 0
    duplicate_timestamps: int = 0
    """Frames dropped because their timestamp equals the last one."""
    out_of_order: int = 0
    """Frames dropped because their timestamp is before the last one."""
    clock_resyncs: int = 0
    """Times time was re-anchored (clock went back, or jumped ahead by more than max_gap)."""
    hands_incomplete: int = 0
    """Hands left out for NaN in the palm or in a joint the tracker normally delivers."""
    gaps: int = 0
    """Intervals longer than gap_factor typical periods (frames the tracker dropped)."""
    jumps: int = 0
    """Jumps detected (each makes the frames wait for a decision)."""
    jumps_rejected: int = 0
    """Jumps where the hand came back: glitches bridged over, never seen by the physics."""
    jumps_accepted: int = 0
    """Jumps where the hand stayed at the new place: a new track there."""
    jumps_lost: int = 0
    """Jumps where the hand kept jumping for max_hold frames: marked lost."""
    bridged_hands: int = 0
    """Hands placed on the line between two good hands, over glitches."""
    new_tracks: int = 0

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def of(cls, counts) -> GuardCounts:
        """The counts a ``GUARD`` record's ``counts`` hold."""
        return cls(*(int(c) for c in counts))


COUNTS = tuple(f.name for f in fields(GuardCounts))
(_IN, _OUT, _DUPLICATE, _OUT_OF_ORDER, _RESYNC, _INCOMPLETE, _GAP, _JUMP, _REJECTED, _ACCEPTED, _LOST, _BRIDGED,
 _NEW_TRACK) = range(len(COUNTS))

GUARD = np.dtype([
    ("last_time", "f8"), ("offset", "f8"), ("stale_run", "i8"), ("stale_raw", "f8"),
    ("intervals", "f8", (RECENT_INTERVALS,)), ("n_intervals", "i8"), ("next_track", "i8"),
    ("last", HANDS), ("side_time", "f8", (2,)), ("source_id", "i8", (2,)), ("holding", "u1", (2,)),
    ("delivered", "u1", (2, N_DIGITS, N_BONES + 1)), ("n_pending", "i8"), ("counts", "i8", (len(COUNTS),)),
], align=True)
"""The guard's memory: the last output time (NaN before any), the time offset, the stale run, the
recent intervals (oldest first), the next track number; per side the last decided hand (``last``,
its track the guard's), when it came, the source's id behind it, whether a jump waits for a
decision, the joints the side has delivered; how many frames wait (``pending``); the counts
(``COUNTS``)."""


def new_guard():
    """A guard before its first frame."""
    guard = np.zeros(1, GUARD)[0]
    guard["last_time"], guard["stale_raw"], guard["next_track"] = math.nan, -math.inf, 1
    guard["last"]["points"], guard["last"]["widths"], guard["last"]["orientation"] = math.nan, math.nan, math.nan
    guard["side_time"] = math.nan
    return guard


@njit(cache=True)
def period(config, guard):
    """The typical frame period: the median recent interval, or the nominal period before any."""
    n = guard.n_intervals
    if n == 0:
        return 1.0 / config.nominal_rate
    ordered = np.sort(guard.intervals[RECENT_INTERVALS - n:])
    middle = n // 2
    return ordered[middle] if n % 2 else (ordered[middle - 1] + ordered[middle]) / 2


@njit(cache=True)
def _time(config, guard, raw):
    """The output time of a frame stamped ``raw`` (NaN to drop it) and whether time was re-anchored."""
    t = raw + guard.offset
    if math.isnan(guard.last_time):
        return t, False
    if t <= guard.last_time:
        run = guard.stale_run + 1 if (guard.stale_run and raw > guard.stale_raw) else 1
        if run < config.resync_after:
            guard.counts[_DUPLICATE if t == guard.last_time else _OUT_OF_ORDER] += 1
            guard.stale_run, guard.stale_raw = run, raw
            return math.nan, False
    if t <= guard.last_time or t - guard.last_time > config.max_gap:
        t = guard.last_time + period(config, guard)
        guard.offset, guard.stale_run = t - raw, 0
        guard.counts[_RESYNC] += 1
        return t, True
    guard.intervals[:-1] = guard.intervals[1:].copy()
    guard.intervals[-1] = t - guard.last_time
    guard.n_intervals = min(guard.n_intervals + 1, RECENT_INTERVALS)
    guard.stale_run = 0
    return t, False


@njit(cache=True)
def _complete(hand, side, delivered):
    """Whether the palm and every joint the side normally delivers are known in frame ``hand``'s
    ``side``; the joints delivered so far, with this hand's, into ``delivered``."""
    points = hand.points[side]
    complete = math.isfinite(points[0, 0]) and math.isfinite(points[0, 1]) and math.isfinite(points[0, 2])
    for d in range(N_DIGITS):
        for j in range(N_BONES + 1):
            i = 1 + d * (N_BONES + 1) + j
            known = math.isfinite(points[i, 0]) and math.isfinite(points[i, 1]) and math.isfinite(points[i, 2])
            complete = complete and (known or not delivered[d, j])
            delivered[d, j] = delivered[d, j] or known
    return complete


@njit(cache=True)
def _copy_side(source, target, side):
    target.present[side], target.track_id[side] = source.present[side], source.track_id[side]
    target.points[side] = source.points[side]
    target.widths[side] = source.widths[side]
    target.orientation[side] = source.orientation[side]


@njit(cache=True)
def _absent(frame, side):
    frame.present[side], frame.track_id[side] = False, 0
    frame.points[side] = math.nan
    frame.widths[side] = math.nan
    frame.orientation[side] = math.nan


@njit(cache=True)
def _bridge(a, t_a, b, t_b, out, side):
    """Side ``side`` of ``out`` at its time on the straight line from ``a`` (at ``t_a``) to ``b`` (at
    ``t_b``): joints and palm linear, the palm's turn the short way; ``b``'s widths and track."""
    s = (out.t - t_a) / (t_b - t_a)
    qa, qb = a.orientation[side], b.orientation[side]
    sign = 1.0 if qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3] >= 0 else -1.0
    length = 0.0
    for i in range(4):
        out.orientation[side, i] = (1 - s) * qa[i] + s * sign * qb[i]
        length += out.orientation[side, i] ** 2
    for i in range(4):
        out.orientation[side, i] /= math.sqrt(length)
    for i in range(POINTS):
        for k in range(3):
            out.points[side, i, k] = (1 - s) * a.points[side, i, k] + s * b.points[side, i, k]
    out.widths[side] = b.widths[side]
    out.present[side], out.track_id[side] = True, b.track_id[side]


@njit(cache=True)
def _jumped(a, b, side, config):
    return is_jump(a.points[side], b.points[side], config.jump_distance)


@njit(cache=True)
def _remember(guard, pending, current, side, source_id, holding, delivered):
    """The side's memory after a decision: frame ``current``'s hand (absent when it is not there)."""
    _copy_side(pending[current], guard.last, side)
    guard.side_time[side] = pending[current].t if pending[current].present[side] else math.nan
    guard.source_id[side], guard.holding[side] = source_id, holding
    guard.delivered[side] = delivered


@njit(cache=True)
def _new_track(guard, pending, decided, first, starts, side, source_id, delivered):
    """A new track from frame ``starts`` on (the undecided frames before it: absent)."""
    guard.counts[_NEW_TRACK] += 1
    track = guard.next_track
    guard.next_track += 1
    for i in range(first, guard.n_pending):
        if i < starts:
            _absent(pending[i], side)
        else:
            pending[i].track_id[side] = track
        decided[i, side] = True
    _remember(guard, pending, guard.n_pending - 1, side, source_id, False, delivered)


@njit(cache=True)
def _decide(config, guard, pending, decided, side, restart):
    """Decide this side's undecided pending frames (always the newest ones), given the raw hand in
    the newest."""
    current = guard.n_pending - 1
    first = current
    while first > 0 and not decided[first - 1, side]:
        first -= 1
    frame = pending[current]
    delivered = guard.delivered[side].copy()
    present = frame.present[side]
    if present and not _complete(frame, side, delivered):
        guard.counts[_INCOMPLETE] += 1
        present = False
    if not present:
        for i in range(first, current + 1):
            _absent(pending[i], side)
            decided[i, side] = True
        _remember(guard, pending, current, side, 0, False, guard.delivered[side].copy())
        return
    source_id = frame.track_id[side]
    if restart or not guard.last.present[side] or source_id != guard.source_id[side]:
        _new_track(guard, pending, decided, first, current, side, source_id, delivered)
        return
    if not _jumped(frame, guard.last, side, config):
        frame.track_id[side] = guard.last.track_id[side]
        guard.counts[_BRIDGED] += current - first
        guard.counts[_REJECTED] += int(guard.holding[side])
        for i in range(first, current):
            _bridge(guard.last, guard.side_time[side], frame, frame.t, pending[i], side)
        for i in range(first, current + 1):
            decided[i, side] = True
        _remember(guard, pending, current, side, source_id, False, delivered)
        return
    streak = 1
    while streak < current - first + 1 and pending[current - streak].present[side] and \
            not _jumped(pending[current - streak + 1], pending[current - streak], side, config):
        streak += 1
    if streak >= config.confirm_frames:
        guard.counts[_ACCEPTED] += 1
        _new_track(guard, pending, decided, first, current - streak + 1, side, source_id, delivered)
        return
    guard.counts[_JUMP] += int(not guard.holding[side])
    if current - first + 1 > config.max_hold:
        guard.counts[_LOST] += 1
        for i in range(first, current + 1):
            _absent(pending[i], side)
            decided[i, side] = True
        _remember(guard, pending, current, side, 0, False, guard.delivered[side].copy())
        return
    guard.holding[side] = True
    guard.delivered[side] = delivered


@njit(cache=True)
def _release(guard, pending, decided, out):
    """Pass on the oldest pending frames every side has decided, into ``out``; how many."""
    ready = 0
    while ready < guard.n_pending and decided[ready, 0] and decided[ready, 1]:
        out[ready] = pending[ready]
        ready += 1
    for i in range(ready, guard.n_pending):
        pending[i - ready] = pending[i]
        decided[i - ready] = decided[i]
    guard.n_pending -= ready
    guard.counts[_OUT] += ready
    return ready


@njit(cache=True)
def admit(config, guard, pending, decided, frame, out):
    """The guard's step for one ``HANDS`` record ``frame``: the frames now ready for the world into
    ``out``, oldest first; returns how many."""
    guard.counts[_IN] += 1
    t, restart = _time(config, guard, frame.t)
    if math.isnan(t):
        return 0
    if not restart and not math.isnan(guard.last_time) and t - guard.last_time > config.gap_factor * period(config,
                                                                                                            guard):
        guard.counts[_GAP] += 1
    guard.last_time = t
    waiting = guard.n_pending
    pending[waiting] = frame
    pending[waiting].t = t
    decided[waiting, 0] = decided[waiting, 1] = False
    guard.n_pending += 1
    for side in range(2):
        _decide(config, guard, pending, decided, side, restart)
    return _release(guard, pending, decided, out)


@njit(cache=True)
def finish(guard, pending, decided, out):
    """The source has ended: hands still waiting for a decision are marked lost; the rest into ``out``."""
    for i in range(guard.n_pending):
        for side in range(2):
            if not decided[i, side]:
                _absent(pending[i], side)
                decided[i, side] = True
    return _release(guard, pending, decided, out)


@lru_cache(maxsize=None)
def _config_record(config: GuardConfig):
    return config.record()


class Guard:
    """The guard for Python: ``admit`` each ``HandFrame`` and get the frames now ready, ``finish``
    when the source has ended. Its records (``guard``, ``pending``) are what compiled code steps."""

    def __init__(self, config: GuardConfig = GuardConfig()):
        self.config = config
        self.record = _config_record(config)
        self.guard = new_guard()
        self.pending = np.zeros(config.pending_frames, HANDS)
        self.decided = np.zeros((config.pending_frames, 2), dtype=np.bool_)
        self._out = np.zeros(config.pending_frames, HANDS)

    @property
    def counts(self) -> GuardCounts:
        return GuardCounts.of(self.guard["counts"])

    @property
    def waiting(self) -> int:
        """Frames waiting for a decision."""
        return int(self.guard["n_pending"])

    def admit(self, frame: HandFrame) -> tuple[HandFrame, ...]:
        ready = admit(self.record, self.guard, self.pending, self.decided, hands_record(frame), self._out)
        return tuple(hand_frame(self._out[i]) for i in range(ready))

    def finish(self) -> tuple[HandFrame, ...]:
        ready = finish(self.guard, self.pending, self.decided, self._out)
        return tuple(hand_frame(self._out[i]) for i in range(ready))
