"""The one interface every hand source implements: live tracker, recording, simulated participant."""

from __future__ import annotations

import time
from typing import Callable, Protocol, runtime_checkable

from microg.skeleton import HandFrame


class SourceError(RuntimeError):
    """A live hand source cannot start or has stopped (a tracker unplugged, a stream that sends
    nothing); the message says which and what to check."""


@runtime_checkable
class HandSource(Protocol):
    """Delivers hand frames one at a time, in SI units, with timestamps in seconds.

    ``next_frame`` returns the next frame, or None once the source has ended. A closed-loop
    source (the simulated participant) looks at ``observation``, what the last frame showed of
    the task's object and what the task displays (``microg.task.Observation``), to decide what
    the hand does next; open-loop sources (live tracker, replay) ignore it. Timestamps strictly
    increase.
    """

    description: str
    """What produces the frames, for the session's provenance: e.g. ``replay:grab.json.gz``."""

    def next_frame(self, observation=None) -> HandFrame | None: ...

    def close(self) -> None: ...


class Borrowed:
    """A view of a source that stays open when the view is closed: a live tracker serves every task
    of a session, each task closing its own view."""

    def __init__(self, source: HandSource):
        self._source = source
        self.description = source.description

    def next_frame(self, observation=None) -> HandFrame | None:
        return self._source.next_frame(observation)

    def close(self) -> None:
        pass


class Paced:
    """``source`` with its frames handed out no faster than their timestamps say: ``speed`` times
    real time from the first frame on (a recording or a simulated participant, watched live)."""

    def __init__(self, source: HandSource, speed: float = 1.0, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        if not speed > 0:
            raise ValueError(f"pace speed = {speed!r}: must be positive")
        self.source, self.speed, self._clock, self._sleep = source, speed, clock, sleep
        self.description = source.description
        self._origin: tuple[float, float] | None = None

    def next_frame(self, observation=None) -> HandFrame | None:
        frame = self.source.next_frame(observation)
        if frame is None:
            return None
        if self._origin is None:
            self._origin = (self._clock(), frame.timestamp)
        due = self._origin[0] + (frame.timestamp - self._origin[1]) / self.speed
        wait = due - self._clock()
        if wait > 0:
            self._sleep(wait)
        return frame

    def close(self) -> None:
        self.source.close()
