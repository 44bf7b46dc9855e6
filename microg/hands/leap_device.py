"""Live Leap Motion input through Ultraleap's Python bindings (the ``leap`` package over ``leapc-cffi``).

This is the only module that imports ``leap``. The bindings need Ultraleap's hand-tracking SDK:
without it ``import leap`` raises a plain ``Exception``, not ``ImportError``, so the import is
guarded broadly. The PyPI package named ``leap`` is an unrelated project; the module is accepted
only if it has Ultraleap's ``Connection``, ``Listener`` and ``HandType``.

Tracking events arrive on the bindings' polling thread; ``LeapSource`` converts each at once
(millimetres to metres, microseconds to seconds) and queues the frames for ``next_frame``.
"""

from __future__ import annotations

import importlib
import threading
from collections import deque
from typing import Callable

import numpy as np

from microg.skeleton import N_BONES, N_DIGITS, Hand, HandFrame
from .source import SourceError
from .units import metres, seconds

INSTALL_HELP = """\
Live Leap Motion input needs two things this machine does not have ready:
  1. Ultraleap's hand-tracking software (the tracking service and LeapSDK) for your OS:
     https://developer.leapmotion.com/tracking-software-download
     (on Linux it installs to /usr/lib/ultraleap-hand-tracking-service; elsewhere set
     LEAPSDK_INSTALL_LOCATION to the SDK folder).
  2. Ultraleap's Python bindings, built against that SDK:
     pip install ".[leap]"      (from the microg source folder; installs leapc-cffi and the
                                 'leap' package from github.com/ultraleap/leapc-python-bindings)
     Do not 'pip install leap': that PyPI package is an unrelated project.
Then plug in the Leap Motion controller and check that the tracking service sees it."""

ULTRALEAP_NAMES = ("Connection", "Listener", "HandType", "TrackingMode")


class LeapUnavailable(SourceError):
    """Live tracking cannot start or has stopped: the message says what is missing and how to fix it."""


def load_leap(importer: Callable[[str], object] = importlib.import_module):
    """Ultraleap's ``leap`` module, or ``LeapUnavailable`` saying what to install."""
    try:
        leap = importer("leap")
    except Exception as error:  # a missing SDK raises a plain Exception inside the bindings
        raise LeapUnavailable(f"cannot import Ultraleap's 'leap' bindings ({type(error).__name__}: "
                              f"{error})\n\n{INSTALL_HELP}") from None
    missing = [name for name in ULTRALEAP_NAMES if not hasattr(leap, name)]
    if missing:
        location = getattr(leap, "__file__", "?")
        raise LeapUnavailable(f"the module 'leap' found at {location} is not Ultraleap's bindings "
                              f"(it has no {', '.join(missing)}); it is probably the unrelated PyPI "
                              f"package 'leap': pip uninstall leap\n\n{INSTALL_HELP}")
    return leap


def _point(vector) -> np.ndarray:
    return metres([vector.x, vector.y, vector.z])


def hand_from_leap(hand) -> Hand:
    """One tracked hand of a ``leap`` tracking event as a ``Hand`` in SI units."""
    joints = np.empty((N_DIGITS, N_BONES + 1, 3))
    widths = np.empty((N_DIGITS, N_BONES))
    for d, digit in enumerate(hand.digits):
        bones = digit.bones
        for b, bone in enumerate(bones):
            joints[d, b] = _point(bone.prev_joint)
            widths[d, b] = bone.width
        joints[d, N_BONES] = _point(bones[-1].next_joint)
    widths = metres(widths)
    with np.errstate(invalid="ignore"):
        widths[~(widths > 0)] = np.nan
    q = hand.palm.orientation
    orientation = np.array([q.w, q.x, q.y, q.z], dtype=np.float64)
    if not np.isfinite(orientation).all():  # a rotation is known whole or not at all
        orientation[:] = np.nan
    return Hand(hand.type.name.lower(), joints, widths, _point(hand.palm.position), orientation, int(hand.id))


def frame_from_event(event) -> HandFrame:
    """A ``leap`` tracking event as a ``HandFrame``; a second hand claiming an already seen side is left out."""
    hands: dict[str, Hand] = {}
    for leap_hand in event.hands:
        hand = hand_from_leap(leap_hand)
        hands.setdefault(hand.side, hand)
    return HandFrame(seconds(event.timestamp), tuple(hands.values()))


class LeapSource:
    """Live frames from a Leap Motion controller, as a ``HandSource``.

    Opening connects to the tracking service and waits up to ``start_timeout`` seconds for the first
    tracking event; without the SDK, the service or a device it raises ``LeapUnavailable`` with
    instructions. Frames queue up to ``backlog``; when the reader falls that far behind, the oldest
    are dropped and counted in ``frames_dropped`` (the guard treats them as missing frames).
    """

    def __init__(self, *, start_timeout: float = 5.0, frame_timeout: float = 2.0, backlog: int = 1100,
                 leap=None):
        self.leap = leap or load_leap()
        self.description = "leap"
        self.device = "Ultraleap tracking device (model not reported)"
        self.frame_rate = float("nan")
        self.frames_dropped = 0
        self.frame_timeout = frame_timeout
        self._frames: deque[HandFrame] = deque()
        self._backlog = backlog
        self._arrived = threading.Condition()
        self._error: Exception | None = None
        self._connection = self.leap.Connection()
        self._connection.add_listener(self._make_listener())
        try:
            self._connection.connect(timeout=start_timeout)
        except Exception as error:
            raise LeapUnavailable(f"cannot connect to the Ultraleap tracking service ({type(error).__name__}: "
                                  f"{error}); is it installed and running?\n\n{INSTALL_HELP}") from None
        try:
            self._connection.set_tracking_mode(self.leap.TrackingMode.Desktop)
            with self._arrived:
                if not self._arrived.wait_for(lambda: self._frames or self._error, timeout=start_timeout):
                    raise LeapUnavailable(f"connected to the tracking service, but no Leap Motion device sent "
                                          f"a frame within {start_timeout} s: plug in the controller and check "
                                          f"that the tracking service lists it.\n\n{INSTALL_HELP}")
        except BaseException:
            self.close()
            raise

    def _make_listener(self):
        source = self

        class Listener(self.leap.Listener):
            def on_device_event(self, event):
                try:
                    with event.device.open():
                        info = event.device.get_info()
                        source.device = f"Ultraleap {info.pid.name} serial {info.serial}"
                except Exception:  # the name is provenance only; tracking works without it
                    pass

            def on_tracking_event(self, event):
                try:
                    frame = frame_from_event(event)
                except Exception as error:
                    frame, source._error = None, error
                with source._arrived:
                    if frame is not None:
                        if len(source._frames) >= source._backlog:
                            source._frames.popleft()
                            source.frames_dropped += 1
                        source._frames.append(frame)
                        source.frame_rate = float(event.framerate)
                    source._arrived.notify_all()

        return Listener()

    def next_frame(self, observation=None) -> HandFrame | None:
        with self._arrived:
            if not self._arrived.wait_for(lambda: self._frames or self._error, timeout=self.frame_timeout):
                raise LeapUnavailable(f"no frame from the Leap Motion device for {self.frame_timeout} s: "
                                      "was it unplugged, or did the tracking service stop?")
            if self._error is not None and not self._frames:
                raise LeapUnavailable(f"a tracking event could not be read: {self._error}")
            return self._frames.popleft()

    def close(self) -> None:
        connection, self._connection = self._connection, None
        if connection is not None:
            connection.disconnect()
