"""Hands from another tracker over the Lab Streaming Layer: ``--input lsl:STREAM_NAME``.

A tracker (or a bridge from one) publishes an LSL stream of type ``MoCap`` with ``CHANNELS``,
float32, one sample per tracking frame, stamped with LSL's clock. The layout, per side (left
then right), is the project's hand skeleton (``microg.skeleton``) in metres, in the workspace's
frame (x right, y up, z toward the participant)::

    {side}_tracked                      1 when the hand is tracked in this sample, else 0
    {side}_palm_x, _y, _z               palm centre
    {side}_palm_qw, _qx, _qy, _qz       palm orientation (unit quaternion)
    {side}_{digit}_{joint}_x, _y, _z    25 joints: digits thumb..pinky, joints metacarpal_base,
                                        proximal_base, intermediate_base, distal_base, tip
    {side}_{digit}_{bone}_width         20 bone widths (diameters)

206 channels in all; unknown values are NaN. The source checks the stream's channel labels
against this layout when they are given. Its frames go through the same tracking guard, window
filter and physics as a Leap Motion's.
"""

from __future__ import annotations

import time

import numpy as np

from microg.skeleton import BONES, DIGITS, N_BONES, N_DIGITS, SIDES, Hand, HandFrame

from .source import SourceError

JOINTS = ("metacarpal_base", "proximal_base", "intermediate_base", "distal_base", "tip")
PER_SIDE = 1 + 3 + 4 + N_DIGITS * (N_BONES + 1) * 3 + N_DIGITS * N_BONES
CHANNELS = tuple(
    name for side in SIDES for name in (
        [f"{side}_tracked"] + [f"{side}_palm_{a}" for a in "xyz"] + [f"{side}_palm_q{c}" for c in "wxyz"]
        + [f"{side}_{d}_{j}_{a}" for d in DIGITS for j in JOINTS for a in "xyz"]
        + [f"{side}_{d}_{b}_width" for d in DIGITS for b in BONES]))
STREAM_TYPE = "MoCap"
RESOLVE_S = 10.0
"""How long to look for the stream on the network before giving up."""
FRAME_TIMEOUT_S = 2.0
"""A hand stream sends a sample every tracking frame, hands or none: this long without one, it has
stopped (as a Leap Motion's frames, ``leap_device``)."""
PULL_S = 0.25
"""How long one wait for a sample lasts, so that closing the source ends a wait soon."""


class LslInputError(SourceError):
    """The LSL stream cannot be used; the message says what is missing."""


def sample_of(frame: HandFrame) -> list[float]:
    """One LSL sample (``CHANNELS``) of ``frame``: what a bridge publishes per tracking frame."""
    values = np.full(len(CHANNELS), np.nan)
    for s, side in enumerate(SIDES):
        hand, base = frame.hand(side), s * PER_SIDE
        values[base] = 0.0 if hand is None else 1.0
        if hand is not None:
            values[base + 1:base + PER_SIDE] = np.concatenate([hand.palm_position, hand.palm_orientation,
                                                               hand.joints.ravel(), hand.widths.ravel()])
    return values.tolist()


def frame_of(sample, timestamp: float) -> HandFrame:
    """The hand frame an LSL sample (``CHANNELS``) carries, at ``timestamp`` (s)."""
    values = np.asarray(sample, dtype=np.float64)
    hands = []
    for s, side in enumerate(SIDES):
        part = values[s * PER_SIDE:(s + 1) * PER_SIDE]
        if part[0] != 1.0:
            continue
        joints_end = 8 + N_DIGITS * (N_BONES + 1) * 3
        hands.append(Hand(side, part[8:joints_end].reshape(N_DIGITS, N_BONES + 1, 3),
                          part[joints_end:].reshape(N_DIGITS, N_BONES), part[1:4], part[4:8]))
    return HandFrame(float(timestamp), tuple(hands))


class LslSource:
    """A ``HandSource`` reading the LSL stream called ``name`` (``CHANNELS``, see the module)."""

    def __init__(self, name: str, resolve_s: float = RESOLVE_S, frame_timeout: float = FRAME_TIMEOUT_S,
                 start_timeout: float = RESOLVE_S):
        try:
            import pylsl
        except ImportError:
            raise LslInputError("--input lsl:... needs pylsl: pip install 'microg[lsl]'") from None
        found = pylsl.resolve_byprop("name", name, minimum=1, timeout=resolve_s)
        if not found:
            raise LslInputError(f"no LSL stream named {name!r} found within {resolve_s:g} s "
                                "(is the tracker publishing on this network?)")
        info = found[0]
        if info.channel_count() != len(CHANNELS):
            raise LslInputError(f"LSL stream {name!r} has {info.channel_count()} channels; a hand stream has "
                                f"{len(CHANNELS)} (microg.hands.lsl.CHANNELS)")
        self._inlet = pylsl.StreamInlet(info, processing_flags=pylsl.proc_clocksync)
        labels = self._labels(self._inlet.info())
        if labels and labels != list(CHANNELS):
            wrong = next(i for i, (a, b) in enumerate(zip(labels, CHANNELS)) if a != b)
            raise LslInputError(f"LSL stream {name!r}: channel {wrong} is labelled {labels[wrong]!r}, "
                                f"expected {CHANNELS[wrong]!r} (microg.hands.lsl.CHANNELS)")
        self.name, self.description = name, f"lsl:{name}"
        self.frame_timeout, self.start_timeout = frame_timeout, start_timeout
        self._received = False
        self._closed = False

    @staticmethod
    def _labels(info) -> list[str]:
        channel = info.desc().child("channels").child("channel")
        labels = []
        while not channel.empty():
            labels.append(channel.child_value("label"))
            channel = channel.next_sibling()
        return labels

    def next_frame(self, observation=None) -> HandFrame | None:
        """The next sample as a frame; ``LslInputError`` when none came for ``frame_timeout`` s (the
        first, while the connection is made, for ``start_timeout``)."""
        limit = self.frame_timeout if self._received else self.start_timeout
        deadline = time.monotonic() + limit
        while not self._closed:
            sample, timestamp = self._inlet.pull_sample(timeout=PULL_S)
            if sample is not None:
                self._received = True
                return frame_of(sample, timestamp)
            if time.monotonic() > deadline:
                raise LslInputError(f"no sample from LSL stream {self.name!r} for {limit:g} s"
                                    + (": did the tracker or its bridge stop publishing?" if self._received else
                                       " since it was found: is its tracker publishing frames?"))
        return None

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._inlet.close_stream()


def describe_channels(info) -> None:
    """Write ``CHANNELS`` with their units into an LSL ``StreamInfo``'s description (XDF's
    channel meta-data convention: label, type, unit)."""
    channels = info.desc().append_child("channels")
    for name in CHANNELS:
        channel = channels.append_child("channel")
        channel.append_child_value("label", name)
        unit = "meters" if name.endswith(("_x", "_y", "_z", "_width")) else "normalized"
        channel.append_child_value("unit", "" if name.endswith("_tracked") else unit)
