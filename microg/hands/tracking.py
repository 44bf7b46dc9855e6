"""Hand tracking as every session runs it (paper, Fig. 2(a)): a source's frames through the tracking
guard, then the window filter (Eq. 1), one frame at a time.

    tracked = Tracking(source, GuardConfig(nominal_rate=110.0), window=3)
    while (frame := tracked.next_frame(observation)) is not None:
        world = step(world, frame.smoothed)        # frame.admitted: the tracked hand, as logged

The two stages are plugged the same way: ``Tracking`` hands each of them frames in order and takes
what it gives back. The guard (``guard.Guard``) may hold a frame back while it decides a jump, and
releases what is ready, none, one or several; the filter (``filter.HandFilter``) smooths each
admitted frame. Each ``TrackedFrame`` carries both: what the guard admitted (the session logs it,
so a re-simulation can filter it again) and what the filter made of it (what the physics takes).
"""

from __future__ import annotations

from microg.skeleton import TrackedFrame

from .filter import FILTER_WINDOW, HandFilter
from .guard import Guard, GuardConfig, GuardCounts
from .source import HandSource


class Tracking:
    """``source`` through the guard (``guard``'s rules) and the window filter over ``window``
    frames at the guard's nominal period. A closed-loop source gets each observation passed on."""

    def __init__(self, source: HandSource, guard: GuardConfig = GuardConfig(), window: int = FILTER_WINDOW):
        self.source = source
        self.description = source.description
        self.guard = Guard(guard)
        self.filter = HandFilter(window, 1.0 / guard.nominal_rate)
        self._ready: list[TrackedFrame] = []
        self._ended = False

    @property
    def counts(self) -> GuardCounts:
        """What the guard did so far (for the session log)."""
        return self.guard.counts

    def next_frame(self, observation=None) -> TrackedFrame | None:
        """The next tracked frame, or None once the source has ended and nothing waits."""
        while not self._ready and not self._ended:
            frame = self.source.next_frame(observation)
            self._ended = frame is None
            admitted = self.guard.finish() if frame is None else self.guard.admit(frame)
            self._ready.extend(TrackedFrame(a, self.filter.smooth(a)) for a in admitted)
        return self._ready.pop(0) if self._ready else None

    def close(self) -> None:
        self.source.close()
