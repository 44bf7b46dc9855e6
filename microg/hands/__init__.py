"""Hand input: every source of hand frames behind one interface (see ``source.HandSource``).

    tracked = Tracking(open_source("replay:grab.json.gz"))   # or "leap"; the guard, then Eq. 1
    while (frame := tracked.next_frame()) is not None:
        world = step(world, frame.smoothed)

Sources: live Leap Motion (``leap_device``, optional), replay of recordings (``recording``: the
project's Arrow stream format, and LeapJS v2 JSON through ``leapjs``). The simulated participant
lives in ``microg.participant``. Every session takes its source's frames through hand tracking
(``tracking.Tracking``): the tracking guard (``guard``), then the window filter (``filter``, Eq. 1),
before the physics. ``filter_report`` measures the window filter's noise and lag on a recording.
"""

from __future__ import annotations

from .filter import HandFilter
from .guard import Guard, GuardConfig, GuardCounts
from .recording import (Recording, RecordingError, RecordingInfo, RecordingWriter, ReplaySource, load_recording,
                        read_recording, record, write_recording)
from .source import HandSource, SourceError
from .tracking import Tracking

SPECS = ("leap", "lsl:STREAM_NAME", "replay:PATH")


def open_source(spec: str, *, realtime: bool = False) -> HandSource:
    """The hand source named by ``spec``: ``leap`` (live device), ``lsl:STREAM_NAME`` (another
    tracker on the Lab Streaming Layer, ``lsl``) or ``replay:PATH`` (either recording format, told
    apart by content). Replay runs as fast as it is read unless ``realtime``."""
    if spec == "leap":
        from .leap_device import LeapSource

        return LeapSource()
    kind, _, path = spec.partition(":")
    if kind == "lsl" and path:
        from .lsl import LslSource

        return LslSource(path)
    if kind == "replay" and path:
        return ReplaySource.from_file(path, realtime=realtime)
    raise ValueError(f"hand input {spec!r}: expected one of {', '.join(SPECS)}")


__all__ = [
    "Guard", "GuardConfig", "GuardCounts", "HandFilter", "HandSource", "Recording", "RecordingError",
    "RecordingInfo", "RecordingWriter", "ReplaySource", "Tracking", "load_recording", "open_source",
    "read_recording", "record", "write_recording",
]
