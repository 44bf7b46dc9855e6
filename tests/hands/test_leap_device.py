"""The live Leap adapter, fed fake events shaped like Ultraleap's ``leap`` package (leapc-python-api).

The fakes mirror ``leap.datatypes`` and ``leap.events`` of github.com/ultraleap/leapc-python-bindings:
``TrackingEvent`` (``timestamp`` in microseconds, ``tracking_frame_id``, ``hands``, ``framerate``,
``info.frame_id``), ``Hand`` (``id``, ``type`` a ``HandType`` enum member ``Left``/``Right``,
``palm``, ``digits``), ``Palm`` (``position``, ``orientation`` ...), ``Digit`` (``bones`` =
metacarpal, proximal, intermediate, distal), ``Bone`` (``prev_joint``, ``next_joint``, ``width``),
``Vector`` (``x``, ``y``, ``z``) and ``Quaternion`` (``x``, ``y``, ``z``, ``w``), in millimetres.
"""

import enum
import threading
import time
import types
from dataclasses import dataclass, field

import numpy as np
import pytest

from microg.hands.leap_device import (INSTALL_HELP, LeapSource, LeapUnavailable, frame_from_event,
                                             load_leap)
from microg.hands.source import HandSource
from tests.waiting import joined

HandType = enum.Enum("HandType", [("Left", 0), ("Right", 1)])
TrackingMode = enum.Enum("TrackingMode", [("Desktop", 0), ("HMD", 1), ("ScreenTop", 2)])


@dataclass
class Vector:
    x: float
    y: float
    z: float

    def __iter__(self):
        return iter((self.x, self.y, self.z))


@dataclass
class Quaternion:
    x: float
    y: float
    z: float
    w: float


@dataclass
class Bone:
    prev_joint: Vector
    next_joint: Vector
    width: float
    rotation: Quaternion = field(default_factory=lambda: Quaternion(0, 0, 0, 1))


@dataclass
class Digit:
    finger_id: int
    metacarpal: Bone
    proximal: Bone
    intermediate: Bone
    distal: Bone
    is_extended: bool = True

    @property
    def bones(self):
        return [self.metacarpal, self.proximal, self.intermediate, self.distal]


@dataclass
class Palm:
    position: Vector
    stabilized_position: Vector
    velocity: Vector
    normal: Vector
    width: float
    direction: Vector
    orientation: Quaternion


@dataclass
class LeapHand:
    id: int
    type: HandType
    palm: Palm
    digits: list
    flags: int = 0
    confidence: float = 1.0
    visible_time: int = 1_000_000
    pinch_distance: float = 50.0
    grab_angle: float = 0.0
    pinch_strength: float = 0.0
    grab_strength: float = 0.0


@dataclass
class FrameHeader:
    frame_id: int
    timestamp: int


@dataclass
class TrackingEvent:
    info: FrameHeader
    tracking_frame_id: int
    hands: list
    framerate: float

    @property
    def timestamp(self):
        return self.info.timestamp


def leap_hand(side: HandType, hand_id: int, origin_mm, rng) -> tuple[LeapHand, dict]:
    """A fake Leap hand with distinct values everywhere, and those values as arrays (mm)."""
    joints = np.asarray(origin_mm) + rng.uniform(-80, 80, (5, 5, 3))
    widths = rng.uniform(14, 21, (5, 4))
    palm = np.asarray(origin_mm) + rng.uniform(-5, 5, 3)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)  # x, y, z, w
    digits = [Digit(d, *[Bone(Vector(*joints[d, b]), Vector(*joints[d, b + 1]), widths[d, b]) for b in range(4)])
              for d in range(5)]
    hand = LeapHand(hand_id, side, Palm(Vector(*palm), Vector(*palm), Vector(0, 0, 0), Vector(0, -1, 0), 85.0,
                                        Vector(0, 0, -1), Quaternion(*q)), digits)
    return hand, {"joints": joints, "widths": widths, "palm": palm, "quaternion_xyzw": q}


def event(timestamp_us: int, hands) -> TrackingEvent:
    return TrackingEvent(FrameHeader(7, timestamp_us), 7, list(hands), 114.9)


def test_a_tracking_event_becomes_a_frame_with_its_values_in_si_units():
    rng = np.random.default_rng(5)
    right, r = leap_hand(HandType.Right, 41, (30, 200, -10), rng)
    left, lv = leap_hand(HandType.Left, 42, (-120, 180, 20), rng)
    frame = frame_from_event(event(12_439_534_551, [right, left]))
    assert frame.timestamp == 12_439.534551
    assert [h.side for h in frame.hands] == ["left", "right"]  # frames keep hands left first
    def metres(millimetres):  # at the tracker's precision, 32-bit floats
        return (millimetres / 1000).astype(np.float32).astype(np.float64)

    for hand, values in ((frame.hand("right"), r), (frame.hand("left"), lv)):
        assert np.array_equal(hand.joints, metres(values["joints"]))
        assert np.array_equal(hand.widths, metres(values["widths"]))
        assert np.array_equal(hand.palm_position, metres(values["palm"]))
        x, y, z, w = values["quaternion_xyzw"]
        assert hand.palm_orientation == pytest.approx([w, x, y, z])
    assert frame.hand("right").track_id == 41 and frame.hand("left").track_id == 42


def test_unknown_values_stay_unknown_not_zero():
    rng = np.random.default_rng(6)
    hand, _ = leap_hand(HandType.Right, 1, (0, 200, 0), rng)
    hand.digits[1].distal.next_joint = Vector(float("nan"), 1.0, 2.0)
    hand.digits[2].proximal.width = 0.0
    hand.palm.orientation = Quaternion(float("inf"), 0, 0, 1)
    converted = frame_from_event(event(1, [hand])).hands[0]
    assert np.isnan(converted.joints[1, 4, 0]) and converted.joints[1, 4, 1] == pytest.approx(0.001)
    assert np.isnan(converted.widths[2, 1])
    assert np.isnan(converted.palm_orientation).all()  # one unknown component: the rotation is unknown


def test_an_event_without_hands_is_a_frame_without_hands():
    frame = frame_from_event(event(2_000_000, []))
    assert frame.timestamp == 2.0 and frame.hands == ()


def test_a_missing_sdk_says_how_to_install_it():
    def importer(name):  # what ``import leap`` raises when the SDK is absent
        raise Exception("Error: Unable to find leapc_cffi dir within directory /usr/lib/ultraleap-hand-tracking")

    with pytest.raises(LeapUnavailable) as caught:
        load_leap(importer)
    message = str(caught.value)
    assert "Unable to find leapc_cffi" in message and INSTALL_HELP in message
    assert 'pip install ".[leap]"' in message


def test_the_unrelated_pypi_leap_package_is_recognised():
    impostor = types.ModuleType("leap")
    impostor.__file__ = "/site-packages/leap/__init__.py"
    with pytest.raises(LeapUnavailable, match="not Ultraleap's bindings.*unrelated PyPI package"):
        load_leap(lambda name: impostor)


class FakeConnection:
    """Delivers events to listeners on its own thread, as ``leap.Connection`` does once connected."""

    events: list = []
    refuse: Exception | None = None

    def __init__(self):
        self.listeners = []
        self.mode = None
        self.thread = None

    def add_listener(self, listener):
        self.listeners.append(listener)

    def connect(self, timeout=10):
        if self.refuse is not None:
            raise self.refuse
        self.thread = threading.Thread(target=self._run)
        self.thread.start()

    def _run(self):
        for item in self.events:
            time.sleep(0.001)
            for listener in self.listeners:
                listener.on_tracking_event(item)

    def set_tracking_mode(self, mode):
        self.mode = mode

    def disconnect(self):
        if self.thread is not None:
            joined(self.thread, "the fake device")


class FakeListener:
    def on_tracking_event(self, event):
        pass

    def on_device_event(self, event):
        pass


def fake_leap(events, refuse=None):
    connection = type("Connection", (FakeConnection,), {"events": events, "refuse": refuse})
    return types.SimpleNamespace(Connection=connection, Listener=FakeListener, HandType=HandType,
                                 TrackingMode=TrackingMode)


STARTED = 600.0
"""Seconds the source may wait for the fake device's first frame: it returns as soon as the frame
arrives, so the limit only ends a test whose fake device never starts."""


def test_the_live_source_delivers_the_devices_frames_in_order():
    rng = np.random.default_rng(7)
    events = [event(1_000_000 + 9_000 * i, [leap_hand(HandType.Right, 3, (0, 200, 0), rng)[0]]) for i in range(20)]
    source = LeapSource(leap=fake_leap(events), start_timeout=STARTED, frame_timeout=0.5)
    assert isinstance(source, HandSource) and source.description == "leap"
    joined(source._connection.thread, "the fake device")  # every frame has arrived: reading them waits on nothing
    frames = [source.next_frame() for _ in range(20)]
    assert [f.timestamp for f in frames] == pytest.approx([1.0 + 0.009 * i for i in range(20)])
    assert frames[4] == frame_from_event(events[4])
    assert source.frame_rate == 114.9 and source.frames_dropped == 0
    with pytest.raises(LeapUnavailable, match="no frame from the Leap Motion device"):
        source.next_frame()
    source.close()


def test_a_reader_that_falls_behind_loses_the_oldest_frames_and_counts_them():
    events = [event(1_000 + i, []) for i in range(30)]
    source = LeapSource(leap=fake_leap(events), backlog=10, start_timeout=STARTED, frame_timeout=0.5)
    joined(source._connection.thread, "the fake device")
    frames = [source.next_frame() for _ in range(10)]
    assert [f.timestamp for f in frames] == pytest.approx([(1_000 + i) * 1e-6 for i in range(20, 30)])
    assert source.frames_dropped == 20
    source.close()


def test_without_a_device_the_source_says_what_is_missing():
    with pytest.raises(LeapUnavailable, match="no Leap Motion device sent a frame within 0.2 s"):
        LeapSource(leap=fake_leap([]), start_timeout=0.2)


def test_without_the_tracking_service_the_source_says_so():
    with pytest.raises(LeapUnavailable, match="cannot connect to the Ultraleap tracking service"):
        LeapSource(leap=fake_leap([], refuse=TimeoutError("Did not received expected event in time")))


def test_the_real_device_when_there_is_one():
    """Runs only where Ultraleap's SDK, bindings and a controller are present."""
    try:
        source = LeapSource(start_timeout=3.0)
    except LeapUnavailable as missing:
        pytest.skip(f"no live Leap Motion here: {str(missing).splitlines()[0]}")
    try:
        frames = [source.next_frame() for _ in range(30)]
    finally:
        source.close()
    times = np.array([f.timestamp for f in frames])
    assert (np.diff(times) > 0).all()
    assert 50 < 1 / np.median(np.diff(times)) < 200
