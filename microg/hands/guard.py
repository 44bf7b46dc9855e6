"""The tracking guard: bad tracking is handled here, never passed on to the physics.

Every session's hand tracking (``microg.hands.tracking``) passes its source's frames through the
guard, then the window filter. The logic is pure: ``admit(config, state, frame)`` returns the next
state and the frames to pass on (none, one, or several), ``finish`` releases what is still waiting
when the source ends; ``Guard`` holds the state between frames. What it does:

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
- **Jump** (some point of the hand, palm or joint, is ``jump_distance`` or more from where it was
  in the last frame): the frames wait, for at most ``confirm_frames - 1`` frames. If the hand
  comes back near where it was, it was a glitch: the waiting frames get the hand bridged linearly
  from before the glitch to after it. If it stays at the new place for ``confirm_frames`` frames in
  a row, it is a new track there, from the frame it arrived. If it keeps jumping for more than
  ``max_hold`` frames, it is lost. Nothing jumps, nothing freezes and catches up.
- **Track ids**: the guard numbers tracks itself (1, 2, 3, ...): a new number whenever the source's
  id changes, a hand reappears, a jump is accepted or the clock is re-anchored. The world starts a
  new track (filter reset, zero velocity) exactly then.

Output timestamps strictly increase. While a jump is being decided every output waits (at most
``confirm_frames - 1`` frames, about 18 ms at the defaults); otherwise each frame passes at once.
``GuardCounts`` counts everything the guard did.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np
from numba import njit

from microg.skeleton import N_BONES, N_DIGITS, SIDES, Hand, HandFrame, hand_jumped

RECENT_INTERVALS = 31


@dataclass(frozen=True)
class GuardConfig:
    jump_distance: float = 0.10
    """m: a hand that moved this far between two frames jumped (``microg.skeleton.is_jump``); the
    physics learns of an accepted jump by the new track id the guard gives it."""
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

    def add(self, **increments: int) -> GuardCounts:
        """The counts with ``increments`` added: a copy of the fields, not ``dataclasses.replace``
        (a tenth of its cost, and the guard counts every frame)."""
        if not any(increments.values()):
            return self
        counts = object.__new__(GuardCounts)
        counts.__dict__.update(self.__dict__)
        for name, increment in increments.items():
            counts.__dict__[name] += increment
        return counts


@dataclass(frozen=True, eq=False)
class Pending:
    """One output frame in the making: per side, the decided hand (None: absent) or, while
    undecided, the raw hand seen there."""

    time: float
    hands: tuple[Hand | None, Hand | None]
    decided: tuple[bool, bool]

    def decide(self, side: int, hand: Hand | None) -> Pending:
        hands, decided = list(self.hands), list(self.decided)
        hands[side], decided[side] = hand, True
        return Pending(self.time, tuple(hands), tuple(decided))


NOTHING_DELIVERED = np.zeros((N_DIGITS, N_BONES + 1), dtype=bool)
NOTHING_DELIVERED.setflags(write=False)


class SideState(NamedTuple):
    """The guard's memory of one hand side. The guard's states are named tuples: immutable, and
    made every frame at a third of a frozen dataclass's cost."""

    last: Hand | None = None
    """The last decided hand on this side (guard track id); None when it was absent."""
    last_time: float = float("nan")
    source_id: int | None = None
    """The source's track id behind ``last``."""
    holding: bool = False
    """A jump is waiting for a decision."""
    delivered: np.ndarray = NOTHING_DELIVERED
    """(5, 5) joints this side has delivered before."""


class GuardState(NamedTuple):
    last_time: float | None = None
    """Output timestamp of the latest frame."""
    offset: float = 0.0
    """Added to source timestamps; changes only when the clock is re-anchored."""
    stale_run: int = 0
    stale_raw: float = float("-inf")
    intervals: tuple[float, ...] = ()
    """The most recent intervals between arrived frames (s), for the typical period."""
    next_track: int = 1
    sides: tuple[SideState, SideState] = (SideState(), SideState())
    pending: tuple[Pending, ...] = ()
    """Frames waiting for a side's decision, oldest first."""
    counts: GuardCounts = GuardCounts()

    def period(self, config: GuardConfig) -> float:
        """The typical frame period: the median recent interval."""
        return period(config, self.intervals)


def period(config: GuardConfig, intervals: tuple[float, ...]) -> float:
    """The median of ``intervals`` (``statistics.median``: a few floats, every frame, where numpy's
    call overhead would dominate), or the nominal period before any."""
    return float(statistics.median(intervals)) if intervals else 1.0 / config.nominal_rate


def completeness(hand: Hand, delivered: np.ndarray) -> tuple[bool, np.ndarray]:
    """Whether the palm and every joint the tracker normally delivers (``delivered``, (5, 5)) are
    known in ``hand``, and the joints delivered so far with this hand's."""
    return _completeness(hand.joints, hand.palm_position, delivered)


@njit(cache=True)
def _completeness(joints, palm, delivered):
    """``completeness`` compiled: the guard checks every frame, and numpy's reductions on a few
    numbers cost more than the check."""
    complete = math.isfinite(palm[0]) and math.isfinite(palm[1]) and math.isfinite(palm[2])
    now = delivered.copy()
    for d in range(joints.shape[0]):
        for j in range(joints.shape[1]):
            known = math.isfinite(joints[d, j, 0]) and math.isfinite(joints[d, j, 1]) and math.isfinite(joints[d, j, 2])
            complete = complete and (known or not delivered[d, j])
            now[d, j] = delivered[d, j] or known
    return complete, now


def bridge(a: Hand, t_a: float, b: Hand, t_b: float, t: float) -> Hand:
    """The hand on the straight line from ``a`` (at ``t_a``) to ``b`` (at ``t_b``) at time ``t``; ``b``'s id."""
    s = (t - t_a) / (t_b - t_a)
    qa, qb = a.palm_orientation, b.palm_orientation
    qb = qb if np.dot(qa, qb) >= 0 else -qb
    q = (1 - s) * qa + s * qb
    return Hand(b.side, (1 - s) * a.joints + s * b.joints, b.widths,
                (1 - s) * a.palm_position + s * b.palm_position, q / np.linalg.norm(q), b.track_id)


def _time(config: GuardConfig, state: GuardState, raw: float) -> tuple[GuardState, float | None, bool]:
    """The output time of a frame stamped ``raw``, or None to drop it; and whether time was re-anchored."""
    t = raw + state.offset
    if state.last_time is None:
        return state, t, False
    if t <= state.last_time:
        run = state.stale_run + 1 if (state.stale_run and raw > state.stale_raw) else 1
        if run < config.resync_after:
            counts = state.counts.add(**{"duplicate_timestamps" if t == state.last_time else "out_of_order": 1})
            return state._replace(stale_run=run, stale_raw=raw, counts=counts), None, False
    if t <= state.last_time or t - state.last_time > config.max_gap:
        t = state.last_time + state.period(config)
        state = state._replace(offset=t - raw, stale_run=0, counts=state.counts.add(clock_resyncs=1))
        return state, t, True
    intervals = (state.intervals + (t - state.last_time,))[-RECENT_INTERVALS:]
    return state._replace(stale_run=0, intervals=intervals), t, False


def _count_gap(config: GuardConfig, state: GuardState, t: float) -> GuardState:
    """Count the interval before ``t`` as a gap when frames are missing in it."""
    if state.last_time is None or t - state.last_time <= config.gap_factor * state.period(config):
        return state
    return state._replace(counts=state.counts.add(gaps=1))


def _decide(config: GuardConfig, state: GuardState, side: int, restart: bool) -> GuardState:
    """Decide this side's undecided pending frames, given the raw hand in the newest one."""
    pending = list(state.pending)
    memory = state.sides[side]
    undecided = [i for i, frame in enumerate(pending) if not frame.decided[side]]
    current, earlier = undecided[-1], undecided[:-1]
    now, hand = pending[current].time, pending[current].hands[side]
    counts, next_track = state.counts, state.next_track

    def settle(decisions: dict[int, Hand | None], memory: SideState) -> GuardState:
        for i, decided in decisions.items():
            pending[i] = pending[i].decide(side, decided)
        sides = tuple(memory if s == side else state.sides[s] for s in range(len(SIDES)))
        return state._replace(pending=tuple(pending), sides=sides, counts=counts, next_track=next_track)

    complete, delivered = (False, None) if hand is None else completeness(hand, memory.delivered)
    if hand is not None and not complete:
        counts, hand = counts.add(hands_incomplete=1), None
    if hand is None:
        return settle(dict.fromkeys(undecided), SideState(delivered=memory.delivered))
    last = memory.last

    def new_track(starts: list[int], **increments: int) -> GuardState:
        nonlocal counts, next_track
        counts = counts.add(new_tracks=1, **increments)
        track, next_track = next_track, next_track + 1
        decisions = dict.fromkeys(undecided)
        decisions.update({i: pending[i].hands[side].renumbered(track) for i in starts})
        return settle(decisions, SideState(decisions[current], now, hand.track_id, False, delivered))

    if restart or last is None or hand.track_id != memory.source_id:
        return new_track([current])
    if not hand_jumped(hand, last, config.jump_distance):
        out = hand.renumbered(last.track_id)
        counts = counts.add(bridged_hands=len(earlier), jumps_rejected=int(memory.holding))
        decisions = {i: bridge(last, memory.last_time, out, now, pending[i].time) for i in earlier}
        return settle(decisions | {current: out}, SideState(out, now, hand.track_id, False, delivered))
    raw = [pending[i].hands[side] for i in undecided]
    streak = 1
    while streak < len(raw) and raw[-streak - 1] is not None and \
            not hand_jumped(raw[-streak], raw[-streak - 1], config.jump_distance):
        streak += 1
    if streak >= config.confirm_frames:
        return new_track(undecided[-streak:], jumps_accepted=1)
    counts = counts.add(jumps=int(not memory.holding))
    if len(undecided) > config.max_hold:
        counts = counts.add(jumps_lost=1)
        return settle(dict.fromkeys(undecided), SideState(delivered=memory.delivered))
    return settle({}, memory._replace(holding=True, delivered=delivered))


def _release(state: GuardState) -> tuple[GuardState, tuple[HandFrame, ...]]:
    """Pass on the oldest pending frames that every side has decided."""
    ready = 0
    while ready < len(state.pending) and all(state.pending[ready].decided):
        ready += 1
    frames = tuple(HandFrame(frame.time, tuple(h for h in frame.hands if h is not None))
                   for frame in state.pending[:ready])
    return state._replace(pending=state.pending[ready:], counts=state.counts.add(frames_out=ready)), frames


def admit(config: GuardConfig, state: GuardState, frame: HandFrame) -> tuple[GuardState, tuple[HandFrame, ...]]:
    """The guard's step: the next state, and the frames now ready for the world, oldest first."""
    return steady(config, state, frame) or decided(config, state, frame)


def steady(config: GuardConfig, state: GuardState, frame: HandFrame):
    """``decided``'s outcome for the usual frame, computed directly: nothing waiting, the clock
    moving on by less than ``max_gap``, each side absent as before or the same complete track
    moving less than a jump. None for any other frame (``decided`` handles it)."""
    if state.pending or state.last_time is None:
        return None
    t = frame.timestamp + state.offset
    interval = t - state.last_time
    if not 0 < interval <= config.max_gap:
        return None
    sides, hands = [], []
    for side, name in enumerate(SIDES):
        hand, memory = frame.hand(name), state.sides[side]
        if hand is None:
            if memory.last is not None:
                return None
            sides.append(memory)
            continue
        if memory.last is None or memory.holding or hand.track_id != memory.source_id:
            return None
        complete, delivered = completeness(hand, memory.delivered)
        if not complete or hand_jumped(hand, memory.last, config.jump_distance):
            return None
        out = hand.renumbered(memory.last.track_id)
        sides.append(SideState(out, t, hand.track_id, False, delivered))
        hands.append(out)
    intervals = (state.intervals + (interval,))[-RECENT_INTERVALS:]
    gap = int(interval > config.gap_factor * period(config, intervals))
    counts = state.counts.add(frames_in=1, frames_out=1, gaps=gap)
    state = GuardState(last_time=t, offset=state.offset, stale_run=0, stale_raw=state.stale_raw, intervals=intervals,
                       next_track=state.next_track, sides=tuple(sides), pending=(), counts=counts)
    return state, (HandFrame.made(t, tuple(hands)),)


def decided(config: GuardConfig, state: GuardState, frame: HandFrame) -> tuple[GuardState, tuple[HandFrame, ...]]:
    """The guard's step for any frame, through the pending that wait for each side's decision."""
    state = state._replace(counts=state.counts.add(frames_in=1))
    state, t, restart = _time(config, state, frame.timestamp)
    if t is None:
        return state, ()
    if not restart:
        state = _count_gap(config, state, t)
    waiting = Pending(t, tuple(frame.hand(name) for name in SIDES), (False, False))
    state = state._replace(last_time=t, pending=state.pending + (waiting,))
    for side in range(len(SIDES)):
        state = _decide(config, state, side, restart)
    return _release(state)


def finish(state: GuardState) -> tuple[GuardState, tuple[HandFrame, ...]]:
    """The source has ended: hands still waiting for a decision are marked lost; pass the rest."""
    pending = tuple(Pending(s.time, tuple(h if d else None for h, d in zip(s.hands, s.decided)), (True, True))
                    for s in state.pending)
    return _release(state._replace(pending=pending))


class Guard:
    """The guard as a stage of hand tracking: ``admit`` each frame and get the frames now ready,
    ``finish`` when the source has ended."""

    def __init__(self, config: GuardConfig = GuardConfig()):
        self.config = config
        self.state = GuardState()

    @property
    def counts(self) -> GuardCounts:
        return self.state.counts

    def admit(self, frame: HandFrame) -> tuple[HandFrame, ...]:
        self.state, ready = admit(self.config, self.state, frame)
        return ready

    def finish(self) -> tuple[HandFrame, ...]:
        self.state, ready = finish(self.state)
        return ready
