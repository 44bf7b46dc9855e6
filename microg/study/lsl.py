"""The session on the Lab Streaming Layer (optional: ``pip install microg[lsl]``), with ``--lsl``.

Other recordings (EEG, eye tracking, ...) running in LabRecorder get the session on the same
clock, in the same XDF file: a ``Markers`` stream of the task and stage events (each marker one
JSON string: ``{"kind": "place_lit", "place": 0, ...}``), and a ``MoCap`` stream of every frame at
the tracking rate: the tracked and the rendered (god-object) hands and the object's pose
(``MOCAP_CHANNELS``, metres and unit quaternions in the tracker's frame; NaN where a hand is not
tracked). Both streams name the session they come from in their description (``session_tags``:
``<desc><microg><participant>P01</participant>...``), and the markers line an XDF recording up with
the study's log (``microg.study.xdf``). LSL opens
network ports to do that (``NETWORK_NOTICE`` says which, and how to keep them on this machine).
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from microg.skeleton import BONES, DIGITS, SIDES

NETWORK_NOTICE = (
    "--lsl: the session's LSL streams are open to the network, as LSL does by default: announced on UDP port 16571 "
    "(multicast and broadcast) and served on TCP/UDP ports from 16572 up, to every machine that can reach this "
    "one. To keep it on this machine, give LSL a configuration file with\n"
    "    [multicast]\n    ResolveScope = machine\n    ListenAddress = 127.0.0.1\n"
    "as ./lsl_api.cfg, ~/lsl_api/lsl_api.cfg, or any file named by the environment variable LSLAPICFG (see LSL's "
    "documentation, 'LSL configuration files'). Without --lsl nothing is opened.")
"""What ``--lsl`` says on the terminal before it opens the stream."""


MARKERS_NAME, MOCAP_NAME = "microg", "microg-mocap"
"""The names of the session's two streams (types ``Markers`` and ``MoCap``)."""


def session_tags(store, session_id: int) -> dict[str, str]:
    """What names a session in its streams' descriptions: the study, the participant, the session
    and when it was created (a study made again reuses participant ids and session numbers)."""
    row = store.db.execute("SELECT participant_id, created_at FROM sessions WHERE id = ?", (session_id,)).fetchone()
    return {"study": store.name, "participant": row["participant_id"], "session": str(session_id),
            "session_created": row["created_at"]}


def _describe(info, tags: dict[str, str]) -> None:
    microg = info.desc().append_child("microg")
    for key, value in tags.items():
        microg.append_child_value(key, value)


class MarkerOutlet:
    """An LSL outlet of type ``Markers`` (the session's ``Markers``): each event the session logs,
    stamped with the event's own time on LSL's clock, so the stamp carries neither the commit's
    delay (it is sent once committed) nor a thread switch's. A wall clock's time is a
    ``time.monotonic`` reading (``WallClock.monotonic``), and LSL's clock runs at a fixed offset
    from that, measured once here; a simulation clock has no wall time, so its events are stamped
    when sent."""

    def __init__(self, tags: dict[str, str], clock, name: str = MARKERS_NAME, source_id: str = "microg-markers"):
        try:
            import pylsl
        except ImportError:
            raise ImportError("LSL markers need pylsl: pip install 'microg[lsl]'") from None
        info = pylsl.StreamInfo(name, "Markers", 1, pylsl.IRREGULAR_RATE, "string", source_id)
        _describe(info, tags)
        self._outlet, self._local_clock, self.clock = pylsl.StreamOutlet(info), pylsl.local_clock, clock
        self._lsl_minus_monotonic = _offset(pylsl.local_clock)

    def mark(self, event) -> None:
        if hasattr(self.clock, "monotonic"):
            stamp = self.clock.monotonic(event.t) + self._lsl_minus_monotonic
        else:
            stamp = self._local_clock()
        self._outlet.push_sample([json.dumps({"kind": event.kind, **event.data}, sort_keys=True)], stamp)


def _offset(local_clock, reads: int = 20) -> float:
    """LSL's clock minus ``time.monotonic``: the reading bracketed most tightly by two monotonic
    readings, of ``reads`` tries (a thread switch between two readings only widens a bracket)."""
    best = (math.inf, 0.0)
    for _ in range(reads):
        before = time.monotonic()
        lsl = local_clock()
        after = time.monotonic()
        best = min(best, (after - before, lsl - (before + after) / 2))
    return best[1]


JOINTS = ("metacarpal_base", "proximal_base", "intermediate_base", "distal_base", "tip")
MOCAP_CHANNELS = tuple(
    [(f"{side}_tracked", "", "Tracked") for side in SIDES]
    + [(f"{side}_{d}_{j}_{a}", "meters", f"Position{a.upper()}") for side in SIDES for d in DIGITS for j in JOINTS
       for a in "xyz"]
    + [(f"{side}_palm_{a}", "meters", f"Position{a.upper()}") for side in SIDES for a in "xyz"]
    + [(f"{side}_palm_q{c}", "normalized", f"Orientation{c.upper()}") for side in SIDES for c in "wxyz"]
    + [(f"rendered_{side}_{d}_{b}_{a}", "meters", f"Position{a.upper()}") for side in SIDES for d in DIGITS
       for b in BONES for a in "xyz"]
    + [(f"object_{a}", "meters", f"Position{a.upper()}") for a in "xyz"]
    + [(f"object_q{c}", "normalized", f"Orientation{c.upper()}") for c in "wxyz"])
"""(label, unit, type) of each MoCap channel, as XDF's channel meta-data describes them."""


def mocap_samples(moments) -> np.ndarray:
    """The MoCap samples (``MOCAP_CHANNELS``) of a task's frames (``microg.task.Moments``), one row each."""
    records = moments.records
    hands, after, n = records["hands"], records["after"], len(records)
    tracked = hands["present"].astype(np.float64)
    points = np.where(tracked[:, :, None, None] > 0, hands["points"], np.nan)
    orientation = np.where(tracked[:, :, None] > 0, hands["orientation"], np.nan)
    return np.hstack([tracked, points[:, 0, 1:].reshape(n, -1), points[:, 1, 1:].reshape(n, -1), points[:, 0, 0],
                      points[:, 1, 0], orientation[:, 0], orientation[:, 1], after["rendered"].reshape(n, -1),
                      after["position"], after["orientation"]])


class MocapOutlet:
    """An LSL outlet of type ``MoCap`` at the tracking rate: a ``FrameSink`` of the session, one
    sample per frame (``microg.task.Moments``)."""

    def __init__(self, rate: float, tags: dict[str, str], name: str = MOCAP_NAME, source_id: str = "microg-mocap"):
        try:
            import pylsl
        except ImportError:
            raise ImportError("the LSL MoCap stream needs pylsl: pip install 'microg[lsl]'") from None
        info = pylsl.StreamInfo(name, "MoCap", len(MOCAP_CHANNELS), rate, "float32", source_id)
        channels = info.desc().append_child("channels")
        for label, unit, kind in MOCAP_CHANNELS:
            channel = channels.append_child("channel")
            channel.append_child_value("label", label)
            channel.append_child_value("unit", unit)
            channel.append_child_value("type", kind)
        info.desc().append_child("acquisition").append_child_value("manufacturer", "microg")
        _describe(info, tags)
        self._outlet = pylsl.StreamOutlet(info)

    def take(self, moments) -> None:
        self._outlet.push_chunk(mocap_samples(moments).tolist())
