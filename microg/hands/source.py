"""The one interface every hand source implements: live tracker, recording, simulated participant."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from microg.sim.hand import HandFrame
from microg.sim.world import World


@runtime_checkable
class HandSource(Protocol):
    """Delivers hand frames one at a time, in SI units, with timestamps in seconds.

    ``next_frame`` returns the next frame, or None once the source has ended. A closed-loop
    source (the simulated participant) looks at ``world`` to decide what the hand does next;
    open-loop sources (live tracker, replay) ignore it. Timestamps strictly increase.
    """

    description: str
    """What produces the frames, for the session's provenance: e.g. ``replay:grab.json.gz``."""

    def next_frame(self, world: World | None = None) -> HandFrame | None: ...

    def close(self) -> None: ...
