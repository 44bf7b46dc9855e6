"""A test bench for simulated participants: pick-and-place runs against the real physics.

Each run is the task every session plays (``microg.task.play``: hand tracking's guard and window
filter, the physics, the task's rules and display, a lost object put back), with the bench's own layout: the object
starts in front of the device and the places lie on an arc 10-15 cm away, about as far as the
paper's Fig. 9 suggests. Under gravity the object starts on the physics' table (its bottom face on
the table top) and a dropped object falls back onto it; in microgravity there is no table.

    python -m microg.participant.bench --seeds 5
"""

from __future__ import annotations

import argparse
import itertools
import math
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from microg.hands.filter import FILTER_WINDOW
from microg.hands.guard import GuardConfig
from microg.paths import object_file
from microg.skeleton import HandFrame
from microg.sim import (INTERACTION_MODELS, PlacedObject, TableParameters, World, compose_scene, load_object,
                        make_world)
from microg.task import KINDS, Lanes, TaskRules, play
from .participant import SimulatedParticipant
from .plan import TaskPlan

EARTH = (0.0, -9.81, 0.0)
ZERO_G = (0.0, 0.0, 0.0)
START = (0.0, 0.20, 0.0)
PLACES = ((0.10, 0.22, -0.04), (0.0, 0.26, -0.10), (-0.10, 0.22, -0.04))


def bench_rules(time_limit_s: float = 120.0) -> TaskRules:
    """The task's rules with the bench's layout; the other numbers are the paper protocol's."""
    return TaskRules(start=START, start_orientation=(1.0, 0.0, 0.0, 0.0), places=PLACES, place_radius=0.03,
                     hold_s=3.0, timeout_s=time_limit_s, grasp_settle_s=0.1, drop_grace_s=0.25,
                     workspace_min=(-0.35, 0.0, -0.3), workspace_max=(0.35, 0.6, 0.3))


def bench_plan(object_name: str, gravity=EARTH, time_limit_s: float = 120.0) -> TaskPlan:
    return TaskPlan(object=load_object(object_file(object_name)), start=START, rules=bench_rules(time_limit_s),
                    gravity=gravity)


def bench_world(plan: TaskPlan, interaction: str) -> World:
    """The plan's object alone at its start under ``interaction``; under gravity it rests on a table."""
    table = TableParameters(height=plan.start[1] - plan.object.half_extents[1]) if any(plan.gravity) else None
    return make_world(compose_scene([PlacedObject(plan.object, plan.start)], interaction, gravity=plan.gravity,
                                    table=table))


@dataclass(frozen=True)
class BenchRun:
    completed: bool
    completion_time: float
    """From the task's first frame until the object was let go after the last place (s, the task's
    rule); NaN if not completed."""
    places_done: int
    attempts: int
    """Holds that ended before the release stage (the task's attempts)."""
    frames: int
    participant_time: float
    """Seconds of computer time spent producing the participant's frames."""
    world_time: float
    """Seconds of computer time spent on the rest of each frame: hand tracking, physics, the task's rules."""


class _Timed:
    """A hand source whose ``next_frame`` calls are timed."""

    def __init__(self, source):
        self.source, self.seconds, self.description = source, 0.0, source.description

    def next_frame(self, observation=None) -> HandFrame | None:
        clock = time.perf_counter()
        frame = self.source.next_frame(observation)
        self.seconds += time.perf_counter() - clock
        return frame

    def close(self) -> None:
        self.source.close()


def run_once(participant: SimulatedParticipant, interaction: str) -> BenchRun:
    """Play the participant's task once on a fresh world, until the task ends or the participant stops."""
    plan = participant.plan
    world = bench_world(plan, interaction)
    source = _Timed(participant)
    lanes = Lanes(KINDS[plan.rules.kind], world, 1, guard=GuardConfig(nominal_rate=world.model.scene.tracking_rate),
                  window=FILTER_WINDOW)
    lanes.load(0, world, plan.rules)
    frames, began = 0, time.perf_counter()
    for moments in play(lanes, source):
        frames += len(moments)
    state = lanes.state(0)
    spent = time.perf_counter() - began
    completion = state.completion_time
    return BenchRun(completion is not None, math.nan if completion is None else completion, state.place,
                       state.attempts, frames, source.seconds, spent - source.seconds)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Success rate and completion time of simulated participants.")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--objects", nargs="+", default=["cube", "flat_cuboid", "long_cuboid"])
    parser.add_argument("--skills", nargs="+", default=["veteran", "beginner"])
    parser.add_argument("--interactions", nargs="+", default=sorted(INTERACTION_MODELS))
    parser.add_argument("--time-limit", type=float, default=120.0, help="The task's timeout (s).")
    args = parser.parse_args(argv)
    cells = list(itertools.product(args.skills, args.objects, args.interactions, ("earth", "zero_g")))
    rows = []
    with tqdm(total=len(cells) * args.seeds, unit="run") as bar:
        for skill, name, interaction, gravity in cells:
            plan = bench_plan(name, EARTH if gravity == "earth" else ZERO_G, args.time_limit)
            results = []
            for seed in range(args.seeds):
                participant = SimulatedParticipant(plan, skill, seed, time_limit_s=args.time_limit + 10.0)
                results.append(run_once(participant, interaction))
                bar.update()
            done = [r for r in results if r.completed]
            frames = sum(r.frames for r in results)
            rows.append((skill, name, interaction, gravity, len(done), len(results),
                         np.mean([r.completion_time for r in done]) if done else math.nan,
                         np.mean([r.attempts for r in results]),
                         1e6 * sum(r.participant_time for r in results) / frames,
                         1e6 * sum(r.world_time for r in results) / frames))
    print(f"{'skill':9} {'object':12} {'interaction':20} {'gravity':7} {'success':>8} {'time (s)':>9} "
          f"{'attempts':>8} {'us/frame participant':>21} {'world':>8}")
    for skill, name, interaction, gravity, ok, n, mean_time, attempts, participant_us, world_us in rows:
        print(f"{skill:9} {name:12} {interaction:20} {gravity:7} {ok:>4}/{n:<3} {mean_time:9.1f} {attempts:8.1f} "
              f"{participant_us:21.0f} {world_us:8.0f}")


if __name__ == "__main__":
    main()
