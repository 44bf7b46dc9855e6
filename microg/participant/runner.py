"""Simulated participants playing tasks, many side by side, in compiled code: one loop for a logged
session and for an in-silico study.

Each lane of ``microg.task.Lanes`` gets a simulated participant (one hand, or two for a kind played
with both: ``Play.then`` ``hand_over``): ``Players`` holds their records. ``run(lanes, players,
until)`` plays every active lane frame after frame: the participant perceives what
its lane's world showed and what the task displays (``participant.perceive``), moves its hand
(``step_participant`` or ``step_hands``), and the frame goes the one frame path
(``microg.task.play.frame_path``: the tracking guard, the window filter, the physics, the kind's
rules, respawn). It returns to Python when a lane's task ended (finished, or its participant gave no
more frames: ``players.ended``) or when a lane kept ``until`` frames (a session's batch to log).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np
from numba import njit
from numba.typed import List

from microg.sim.compiled import entry_point, specialised
from microg.skeleton import HANDS, SIDES, TRACKER_FLOAT
from microg.task import COMPLETED, TIMEOUT, Kind, Lanes, frame_path

from .actions import ALONE, GIVING, PLAYER, SEEN, STATE, TAKING_OVER
from .anatomy import WIDTHS
from .grasp import GRASP, KEYS
from .noise import FrameTiming, TrackingNoiseLevels
from .participant import MEASURED_NOISE, MEASURED_TIMING, perceive, start, step_hands, step_participant
from .plan import TaskPlan
from .skill import SkillProfile


class Players:
    """The simulated participants of ``size`` lanes, each with one or two hands (their ``PLAYER``,
    ``STATE`` and ``SEEN`` records, random streams and grasps); ``active`` and ``ended`` per lane."""

    def __init__(self, kind: Kind, size: int):
        self.kind = kind
        self.players, self.states = np.zeros((size, 2), PLAYER), np.zeros((size, 2), STATE)
        self.seens = np.zeros((size, 2), SEEN)
        self.streams = List([List([np.random.default_rng(0) for _ in range(4)]) for _ in range(2 * size)])
        self.grasps = np.zeros((size, 2, KEYS), GRASP)
        self.hands, self.sides = np.ones(size, dtype=np.int64), np.zeros((size, 2), dtype=np.int64)
        self.frames = np.zeros(size, HANDS)
        self.active, self.ended = np.zeros(size, dtype=np.bool_), np.zeros(size, dtype=np.bool_)
        final = (kind.index(COMPLETED), kind.index(TIMEOUT))
        self.over = np.array([i in final for i in range(len(kind.stages))])
        self.loose = np.array([stage.loose for stage in kind.stages])
        self.release = np.array([stage.release for stage in kind.stages])
        self.run = None
        """The compiled runner for these players' lanes (``run``), once called."""

    def load(self, b: int, plan: TaskPlan, skill: SkillProfile, seed: int, timing: FrameTiming = MEASURED_TIMING,
             noise: TrackingNoiseLevels = MEASURED_NOISE, time_limit_s: float = 300.0) -> None:
        """Lane ``b``'s participant before its first frame (``participant.start``): one hand, or both
        for a kind played with both (the first hand gives, the other takes over)."""
        both = self.kind.play.then == "hand_over"
        if both:
            first = self.kind.aims(plan.rules).first_hand
            sides = (first, SIDES[1 - SIDES.index(first)])
            roles = (GIVING, TAKING_OVER)
        else:
            sides, roles = (plan.hand,), (ALONE,)

        for h, (side, role) in enumerate(zip(sides, roles)):
            self.players[b, h], self.states[b, h] = np.zeros(1, PLAYER)[0], np.zeros(1, STATE)[0]
            _, _, streams, grasps = start(replace(plan, hand=side), skill, seed, timing, noise, time_limit_s,
                                          player=self.players[b, h], state=self.states[b, h], role=role)
            self.streams[2 * b + h] = streams
            self.grasps[b, h] = grasps
            self.sides[b, h] = SIDES.index(side)
        self.hands[b] = len(sides)
        self.seens[b] = np.zeros(1, SEEN)[0]
        self.active[b], self.ended[b] = True, False

    def arrays(self) -> tuple:
        return (self.players, self.states, self.seens, self.streams, self.grasps, self.hands, self.sides, self.frames,
                self.active, self.ended, self.over, self.loose, self.release, WIDTHS)


@njit(cache=True)
def _sense(players, seens, b, h, side, seen, task, over, loose, release):
    """Hand ``h`` of lane ``b`` perceives its world's object and the task's display."""
    stage = task.stage
    perceive(players[b, h], seens[b, h], 0.0, 0.0, seen.position, seen.orientation, seen.touching,
             seen.grasped_by[side] != 0, True, over[stage], loose[stage], release[stage], task.place,
             not math.isnan(task.lit_since))
    seens[b, h].velocity[:] = seen.velocity


@njit(cache=True)
def _pose(frame, side, track, joints, palm, orientation, widths):
    """A hand of the participant's frame: its palm and joints, widths and palm orientation, at a
    tracker's precision (``microg.skeleton.TRACKER_FLOAT``)."""
    frame.present[side], frame.track_id[side] = 1, track
    frame.points[side, 0] = palm.astype(TRACKER_FLOAT)
    frame.points[side, 1:] = joints.reshape((-1, 3)).astype(TRACKER_FLOAT)
    frame.widths[side] = widths.astype(TRACKER_FLOAT)
    frame.orientation[side] = orientation.astype(TRACKER_FLOAT)


_RUN = """
def {name}(lanes, players, until):
    (pl, st, seens, streams, grasps, hands, sides, frames, active, ended, over, loose, release, widths) = players
    tasks, seen, n_frames = lanes[11], lanes[16], lanes[20]
    joints, palm, orientation = np.empty((2, 5, 5, 3)), np.empty((2, 3)), np.empty((2, 4))
    while True:
        stop = False
        for b in range(len(active)):
            if not active[b]:
                continue
            task = tasks[b]
            for h in range(hands[b]):
                _sense(pl, seens, b, h, sides[b, h], seen[b], task, over, loose, release)
            if hands[b] == 2:
                seens[b, 0].other_action, seens[b, 1].other_action = st[b, 1].action, st[b, 0].action
                seens[b, 0].other_grasped = seen[b].grasped_by[sides[b, 1]] != 0
                seens[b, 1].other_grasped = seen[b].grasped_by[sides[b, 0]] != 0
                t = step_hands(pl[b, 0], st[b, 0], seens[b, 0], streams[2 * b], grasps[b, 0], joints[0], palm[0],
                               orientation[0], pl[b, 1], st[b, 1], seens[b, 1], streams[2 * b + 1], grasps[b, 1],
                               joints[1], palm[1], orientation[1])
            else:
                t = step_participant(pl[b, 0], st[b, 0], seens[b, 0], streams[2 * b], grasps[b, 0], joints[0],
                                     palm[0], orientation[0])
            frame = frames[b]
            if math.isnan(t):
                {take}(lanes, b, frame, True)
                active[b], ended[b], stop = False, True, True
                continue
            frame.t = t
            frame.present[:] = 0
            frame.track_id[:] = 0
            frame.points[:] = np.nan
            frame.widths[:] = np.nan
            frame.orientation[:] = np.nan
            for h in range(hands[b]):
                _pose(frame, sides[b, h], h + 1, joints[h], palm[h], orientation[h], widths)
            {take}(lanes, b, frame, False)
            if tasks[b].stage >= {final}:
                active[b], ended[b], stop = False, True, True
            if n_frames[b] >= until:
                stop = True
        if stop:
            return
"""


@lru_cache(maxsize=None)
def runner(kind: Kind, effects: frozenset[str], meshes: bool):
    """The compiled ``run(lanes, players, until)`` for lanes of a kind's tasks on worlds
    of ``effects`` (module docstring)."""
    take = frame_path(kind, effects, meshes)
    name = "run_" + take.py_func.__name__[len("take_"):]
    return specialised(_RUN.replace("{final}", str(kind.index(COMPLETED))), name, {"take": take}, __file__,
                       globals())


def run(lanes: Lanes, players: Players, until: int) -> None:
    """Play ``lanes`` with ``players`` until a lane ends or a lane keeps ``until`` frames."""
    args = (lanes.arrays(), players.arrays(), until)
    if players.run is None:
        players.run = entry_point(runner(lanes.kind, lanes.effects, lanes.meshes), args)
    players.run(*args)
