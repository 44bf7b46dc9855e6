"""Hand input from a headset's own hand tracking, read by the participant's page (WebXR Hand Input).

The page (``microg/view/page/xr.js``) reads the 25 joints of each tracked hand every XR frame,
converts them into the workspace (tracker) frame through the placement anchor, and sends them over
the participant display's WebSocket; the display's server thread hands each message to
``WebXRSource.receive``, and the session reads the frames through ``next_frame`` like any live
source, behind the same tracking guard and window filter as a Leap Motion.

Message (one per XR frame once the workspace is placed, also when no hand is tracked)::

    {"type": "hands", "t": 1718000000123.4,            # page clock (ms) when the joints were read
     "hands": [{"side": "right", "track": 3,            # a new number each time a hand (re)appears
                "joints": [[x, y, z], ...25],           # m, workspace frame, in XR_JOINTS order
                "radii": [...25]}]}                      # m, WebXR joint radii

Joint mapping onto the project's skeleton (``microg.skeleton``: digit-major, joint j of a digit is
where bone j begins, joint 4 the tip):

- index to pinky: joints 0..4 are WebXR's metacarpal, phalanx-proximal, -intermediate, -distal, tip.
- thumb: WebXR has no thumb intermediate phalanx; as in the Leap skeleton, the thumb's metacarpal
  has zero length: joints 0 and 1 are both WebXR's thumb-metacarpal (the carpometacarpal joint),
  then thumb-phalanx-proximal, thumb-phalanx-distal, thumb-tip.
- bone widths: a bone's width is the sum of the radii at its two ends (the mean of its two
  diameters); the thumb's zero-length metacarpal gets twice its joint's radius.
- palm position: the mean of the centres of the index to pinky metacarpals.
- palm orientation, in the Leap convention (``units.palm_quaternion``): direction from the wrist to
  the mean of the four knuckles (phalanx-proximal joints), normal perpendicular to the knuckle line
  (index to pinky) and the direction, out of the palm.

Timestamps: the page syncs its clock to the session's (``microg.view.display.now_ms``, wall time)
by ping/pong, a burst of 12 every 10 s: the mean offset of the 4 quickest of the last 48 round
trips (each is off by at most half its round trip), with their spread; the display logs each
measurement (``display_clock``). A frame's timestamp (s) is the page's
read time plus the latest measured offset, so frames are on the session's clock within the
offset's spread, counted from the source's first frame: the session's clock is Unix time (1.8e9 s,
where a double keeps a quarter of a microsecond and the physics loses a tenth of a millimetre on
the object's path over a task), and its differences are what the physics and the task use. Frames
before the first sync, malformed hands and hands no real hand could be (``Hand`` refuses them) are
refused and counted.

A live source serves the newest frames: frames more than ``backlog_s`` older than the newest one
waiting (the session fell behind: between tasks, while the researcher starts the next one, or
while the physics compiles for a new scene) are dropped and counted in ``frames_dropped`` (the
guard treats them as missing frames); so are frames beyond the newest ``WAITING_FRAMES`` (a page or
a script that sends faster than any headset tracks, or with a clock that stands still).
"""

from __future__ import annotations

import itertools
import math
import statistics
import threading
from collections import deque

import numpy as np

from microg.skeleton import N_BONES, SIDES, Hand, HandFrame, at_tracker_precision

from .units import palm_quaternion

XR_JOINTS = (
    "wrist",
    "thumb-metacarpal", "thumb-phalanx-proximal", "thumb-phalanx-distal", "thumb-tip",
    *(f"{finger}-finger-{joint}" for finger in ("index", "middle", "ring", "pinky")
      for joint in ("metacarpal", "phalanx-proximal", "phalanx-intermediate", "phalanx-distal", "tip")),
)
"""WebXR's hand joints in the order of the XRHandJoint enumeration (the page sends them so)."""

SKELETON = np.array([[1, 1, 2, 3, 4]] + [[5 + 5 * f + j for j in range(N_BONES + 1)] for f in range(4)])
"""(5, 5) index into ``XR_JOINTS`` of each joint of the project's skeleton."""
WAIT_SLICE_S = 0.5
"""``next_frame`` waits in slices this long, so Ctrl-C reaches a session waiting for the page."""
WAITING_FRAMES = 256
"""The most frames waiting for the session: a quarter of a second at 1 kHz."""


def hand_from_webxr(side: str, joints, radii, track_id: int = 0) -> Hand:
    """One WebXR hand (25 joint positions and radii, m, in ``XR_JOINTS`` order) as a ``Hand``."""
    joints = np.asarray(joints, dtype=np.float64)
    radii = np.asarray(radii, dtype=np.float64)
    if joints.shape != (len(XR_JOINTS), 3) or radii.shape != (len(XR_JOINTS),):
        raise ValueError(f"a WebXR hand has {len(XR_JOINTS)} joints with a radius each; got joints "
                         f"{joints.shape}, radii {radii.shape}")
    if not (np.isfinite(joints).all() and np.isfinite(radii).all() and (radii > 0).all()):
        raise ValueError("a WebXR hand's joints must be finite and its radii positive")
    skeleton = joints[SKELETON]
    at = radii[SKELETON]
    widths = at[:, :-1] + at[:, 1:]
    fingers = skeleton[1:]
    palm = 0.5 * (fingers[:, 0] + fingers[:, 1]).mean(axis=0)
    knuckles = fingers[:, 1]
    direction = knuckles.mean(axis=0) - joints[0]
    normal = np.cross(knuckles[0] - knuckles[-1], direction)
    normal *= 1.0 if side == "right" else -1.0
    with np.errstate(invalid="ignore", divide="ignore"):
        orientation = palm_quaternion(normal / np.linalg.norm(normal), direction / np.linalg.norm(direction))
    return Hand(side, *map(at_tracker_precision, (skeleton, widths, palm, orientation)), int(track_id))


class WebXRSource:
    """Hand frames streamed by the participant's page in a headset, as a ``HandSource`` (see the
    module docstring). ``rate`` is the tracking rate the session's scene assumes (Hz); the
    headset's own rate is measured (``frame_rate``)."""

    def __init__(self, rate: float, *, backlog_s: float = 0.25):
        if not rate > 0:
            raise ValueError(f"WebXRSource rate = {rate!r}: must be positive")
        self.rate = float(rate)
        self.description = "webxr"
        self.device = "WebXR hand tracking (the participant's page)"
        self.frames_dropped = 0
        self.refused = 0
        """Messages or hands refused: before the clock was synced, malformed, or implausible."""
        self.clock: dict | None = None
        """The clock offset and spread the latest frame was stamped with."""
        self.last_read: float | None = None
        """The page's read time (ms, page clock) of the frame ``next_frame`` handed out last: the
        participant display sends it back with the frame computed from it, so the page measures
        the round trip on its own clock."""
        self._frames: deque[tuple[HandFrame, float]] = deque()
        self._backlog_s = backlog_s
        self._origin: tuple[float, float] | None = None
        """The first frame's read time and clock offset (ms): the frames' clock starts there."""
        self._times: deque[float] = deque(maxlen=64)
        self._arrived = threading.Condition()
        self._closed = False

    @property
    def frame_rate(self) -> float:
        """The headset's frame rate (Hz), measured from the page's read times; ``rate`` until then."""
        if len(self._times) < 2:
            return self.rate
        intervals = [b - a for a, b in itertools.pairwise(self._times) if b > a]
        return 1e3 / statistics.median(intervals) if intervals else self.rate

    def receive(self, message: dict, clock: dict | None) -> None:
        """One ``hands`` message from the page, with the page's measured clock (``offset_ms``,
        ``spread_ms``); called on the display's server thread."""
        try:
            t = float(message["t"])
            offset = float(clock["offset_ms"])
            if not (math.isfinite(t) and math.isfinite(offset)):
                raise ValueError("time is not finite")
            entries = message["hands"]
            if not isinstance(entries, list):
                raise TypeError("hands is not a list")
        except (KeyError, TypeError, ValueError):
            self.refused += 1
            return
        hands: dict[str, Hand] = {}
        for entry in entries:
            try:
                side = entry["side"]
                if side not in SIDES:
                    raise ValueError(f"side {side!r}")
                hand = hand_from_webxr(side, entry["joints"], entry["radii"], int(entry.get("track", 0)))
            except (KeyError, TypeError, ValueError):
                self.refused += 1
                continue
            hands.setdefault(side, hand)
        if self._origin is None:
            self._origin = (t, offset)
        frame = HandFrame(((t - self._origin[0]) + (offset - self._origin[1])) / 1e3, tuple(hands.values()))
        with self._arrived:
            self.clock = clock
            self._times.append(t)
            self._frames.append((frame, t))
            while (len(self._frames) > WAITING_FRAMES
                   or frame.timestamp - self._frames[0][0].timestamp > self._backlog_s):
                self._frames.popleft()
                self.frames_dropped += 1
            self._arrived.notify_all()

    def next_frame(self, observation=None) -> HandFrame | None:
        """The next frame, waiting for the page to send one; None once closed."""
        with self._arrived:
            while not self._frames and not self._closed:
                self._arrived.wait(WAIT_SLICE_S)
            if not self._frames:
                return None
            frame, self.last_read = self._frames.popleft()
            return frame

    def close(self) -> None:
        with self._arrived:
            self._closed = True
            self._arrived.notify_all()

