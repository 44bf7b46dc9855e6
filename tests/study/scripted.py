"""A scripted participant for the study tests: a thumb and an index phalanx that pinch the task's
object from both sides along x, carry it through the places and let go, on a fixed timetable (and
two such pinches, one per hand, that hand the object over)."""

from __future__ import annotations

import threading
import time

import numpy as np

from microg.participant.scripted import probe_hand
from microg.skeleton import HandFrame
from microg.sim.rotation import quat_to_matrix

RATE = 110.0
RADIUS = 0.008
"""Phalanx radius (probe width 0.016 m)."""


def pinch_keyframes(plan, *, squeeze=0.006, travel=0.4, dwell=None, drop_at_place=None, open_s=0.5,
                    skip_place=None):
    """(t, centre, gap) keyframes: approach and close at the start, carry to each place and dwell,
    open after the last place. ``drop_at_place=k`` opens the hand at place k for ``open_s`` and
    closes it again; ``skip_place=k`` leaves place k after half the dwell."""
    half = float(np.abs(quat_to_matrix(plan.rules.start_orientation)[0]) @ plan.object.half_extents)  # along x
    open_gap, closed = half + RADIUS + 0.02, half + RADIUS - squeeze
    dwell = plan.rules.hold_s + 0.3 if dwell is None else dwell
    start = np.asarray(plan.start)
    keys = [(0.0, start, open_gap), (0.3, start, closed), (0.5, start, closed)]
    t, here = 0.5, start
    for k, place in enumerate(plan.rules.places):
        place = np.asarray(place)
        t += travel
        keys.append((t, place, closed))
        if drop_at_place == k:
            keys += [(t + 0.1, place, closed), (t + 0.2, place, open_gap), (t + 0.2 + open_s, place, open_gap),
                     (t + 0.4 + open_s, place, closed)]
            t += 0.4 + open_s
        t += dwell if skip_place != k else dwell * 0.5
        keys.append((t, place, closed))
        here = place
    keys += [(t + 0.1, here, open_gap), (t + 0.6, here, open_gap)]
    return keys


class ScriptedPinch:
    """A HandSource playing ``keyframes``; ends (returns None) after the last keyframe.
    ``pace`` > 0 sleeps that many seconds per frame (to give a test time to act on a real process)."""

    def __init__(self, keyframes, t0=0.0, pace=0.0, description="scripted pinch"):
        self.keys, self.t0, self.pace, self.description = keyframes, t0, pace, description
        self.index = 0

    def position(self, t):
        times = [k[0] for k in self.keys]
        centre = np.array([np.interp(t, times, [k[1][i] for k in self.keys]) for i in range(3)])
        return centre, float(np.interp(t, times, [k[2] for k in self.keys]))

    def next_frame(self, observation=None):
        t = self.index / RATE
        if t > self.keys[-1][0]:
            return None
        self.index += 1
        if self.pace:
            time.sleep(self.pace)
        centre, gap = self.position(t)
        hand = probe_hand({"thumb.proximal": centre + [gap, 0, 0], "index.proximal": centre - [gap, 0, 0]},
                          width=2 * RADIUS)
        return HandFrame(self.t0 + t, (hand,))

    def close(self):
        pass


class TwoPinches:
    """A right pinch (thumb and index along x) that takes the cube at its start, a left one (along z)
    that takes it too, the right opening, and the left carrying it into ``place`` and holding it
    there; a HandSource of both hands, ending after 5 s."""

    description = "scripted handover"
    END_S = 5.0

    def __init__(self, start, place, half):
        opened, closed = half + RADIUS + 0.02, half + RADIUS - 0.006
        self.right = ScriptedPinch([(0.0, start, opened), (0.3, start, closed), (1.6, start, closed),
                                    (1.7, start, opened), (self.END_S, start, opened)])
        self.left = ScriptedPinch([(0.0, start, opened + 0.03), (0.8, start, opened), (1.1, start, closed),
                                   (1.9, start, closed), (2.9, place, closed), (self.END_S, place, closed)])
        self.index = 0

    def next_frame(self, observation=None):
        t = self.index / RATE
        if t > self.END_S:
            return None
        self.index += 1
        (right, gap), (left, left_gap) = self.right.position(t), self.left.position(t)
        hands = (probe_hand({"thumb.proximal": left + [0, 0, left_gap], "index.proximal": left - [0, 0, left_gap]},
                            "left", 2 * RADIUS, track_id=1),
                 probe_hand({"thumb.proximal": right + [gap, 0, 0], "index.proximal": right - [gap, 0, 0]},
                            "right", 2 * RADIUS))
        return HandFrame(t, hands)

    def close(self):
        pass


class Gated(ScriptedPinch):
    """A ScriptedPinch that waits on ``gate`` (a semaphore) before each ``every``-th frame: with
    ``every`` the protocol's frame batch, a session run from it commits a batch, then waits for the
    test to let it make the next one, so a reader can be checked batch by batch on any machine.
    ``waiting`` (a semaphore), when given, is released each time it starts to wait."""

    def __init__(self, keyframes, gate, every: int, waiting=None):
        super().__init__(keyframes)
        self.gate, self.every, self.waiting = gate, every, waiting

    def next_frame(self, observation=None):
        if self.index and self.index % self.every == 0:
            if self.waiting is not None:
                self.waiting.release()
            self.gate.acquire()
        return super().next_frame(observation)


def gated_session(folder, gate, waiting=None) -> threading.Thread:
    """P01's session of the study in ``folder``, started now in another thread (it opens the study
    itself), played by ``Gated`` pinches: each task commits a frame batch, then releases ``waiting``
    (when given) and waits for ``gate``."""
    from microg.study.inputs import ScriptedInputs
    from microg.study.session import SimulationClock, run_session
    from microg.study.store import open_study

    def run() -> None:
        with open_study(folder) as store:
            every = store.protocol.frame_batch
            inputs = ScriptedInputs(lambda plan, seed: Gated(pinch_keyframes(plan), gate, every, waiting))
            session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
            run_session(store, session.id, inputs, clock=SimulationClock())

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread
