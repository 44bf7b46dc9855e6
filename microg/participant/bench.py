"""A test bench for simulated participants: one pick-and-place trial against the real physics.

This is the participant's own bench, not the study engine: it runs a participant in closed loop
with a world and referees the task by the rule the study applies (a place counts once the object
has stayed within ``place_radius`` of it for ``hold_s`` without a break, places in order; the
trial completes when the object is let go after the third place; a drop is an object that was
grasped, then stayed out of the grasp for ``DROP_S`` and got ``DROP_DISTANCE`` further from the palm
than it was when last grasped, before the task ended).

Under gravity the object starts on the physics' table (its bottom face on the table top), and a
dropped object falls back onto it; in microgravity there is no table. An object that ends up out
of reach (slid off, or drifted away in microgravity) is put back at its start, as study software
typically respawns a lost object.

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

from microg.paths import object_file
from microg.sim.bodies import load_object
from microg.sim.hand import HandFrame
from microg.sim.observe import grasped
from microg.sim.scene import INTERACTION_MODELS, PlacedObject, TableParameters, compose_scene
from microg.sim.world import World, make_world, step
from .participant import SimulatedParticipant
from .plan import PickPlacePlan

DROP_S = 0.25
"""An object out of the grasp this long (s) after being held, and ``DROP_DISTANCE`` (m) further from
the palm than when last grasped, counts as dropped."""
DROP_DISTANCE = 0.03
OUT_OF_REACH = 0.45
"""An object this far (m) from its start is out of reach and is put back at its start."""
AFTER_S = 1.0
"""After the participant has finished, the world runs on this long (s) so the referee sees the release."""
EARTH = (0.0, -9.81, 0.0)
ZERO_G = (0.0, 0.0, 0.0)

START = (0.0, 0.20, 0.0)
PLACES = ((0.10, 0.22, -0.04), (0.0, 0.26, -0.10), (-0.10, 0.22, -0.04))
"""The bench's task layout (m, device frame): the object starts in front of the device, the three
places lie on an arc 10-15 cm away, about as far as the paper's Fig. 9 suggests."""


@dataclass(frozen=True)
class TrialResult:
    completed: bool
    completion_time: float
    """Simulation time (s) at which the object was seen let go after the third place (out of the grasp
    for ``DROP_S`` and away from the palm); NaN if not completed."""
    places_done: int
    drops: int
    frames: int
    participant_time: float
    """Seconds of computer time spent producing the participant's frames."""
    physics_time: float
    """Seconds of computer time spent stepping the world."""


@dataclass
class _Referee:
    plan: PickPlacePlan
    index: int
    places_done: int = 0
    inside_since: float | None = None
    held_before: bool = False
    out_since: float | None = None
    held_distance: float = 0.0
    drops: int = 0
    completed_at: float = math.nan

    def observe(self, world: World, palm: np.ndarray | None) -> None:
        t = world.time
        position = world.data.position[self.index]
        holding = bool(grasped(world)[self.index])
        if self.places_done < 3:
            inside = np.linalg.norm(position - np.asarray(self.plan.places[self.places_done])) <= self.plan.place_radius
            if not inside:
                self.inside_since = None
            elif self.inside_since is None:
                self.inside_since = t
            elif t - self.inside_since >= self.plan.hold_s:
                self.places_done += 1
                self.inside_since = None
        distance = math.inf if palm is None else float(np.linalg.norm(position - palm))
        if holding:
            self.held_before, self.out_since, self.held_distance = True, None, distance
        elif self.held_before:
            self.out_since = t if self.out_since is None else self.out_since
            if t - self.out_since >= DROP_S and distance > self.held_distance + DROP_DISTANCE:
                if self.places_done == 3:
                    self.completed_at = t
                else:
                    self.drops += 1
                self.held_before, self.out_since = False, None

    @property
    def completed(self) -> bool:
        return not math.isnan(self.completed_at)


def _restore(world: World, index: int, placed: PlacedObject) -> None:
    data = world.data
    data.position[index] = placed.position
    data.orientation[index] = placed.orientation
    data.velocity[index] = 0.0
    data.angular_velocity[index] = 0.0


def run_trial(participant: SimulatedParticipant, world: World, time_limit_s: float = 120.0) -> TrialResult:
    """Run ``participant`` on ``world`` until it finishes, the task completes or time runs out."""
    plan = participant.plan
    index = world.model.index(plan.object_name)
    placed = world.model.scene.objects[index]
    referee = _Referee(plan, index)
    frames, participant_time, physics_time = 0, 0.0, 0.0
    ended_at = math.inf
    while world.time <= min(time_limit_s, ended_at + AFTER_S):
        clock = time.perf_counter()
        frame = participant.next_frame(world) if math.isinf(ended_at) else None
        participant_time += time.perf_counter() - clock
        if frame is None:
            # The participant has gone: the hand leaves the tracker and the world runs on.
            ended_at = min(ended_at, world.time)
            frame = HandFrame(world.data.frame_time + participant.timing.period)
        clock = time.perf_counter()
        world = step(world, frame)
        physics_time += time.perf_counter() - clock
        frames += 1
        if np.linalg.norm(world.data.position[index] - np.asarray(placed.position)) > OUT_OF_REACH:
            _restore(world, index, placed)
        referee.observe(world, frame.hands[0].palm_position if frame.hands else None)
        if referee.completed:
            break
    return TrialResult(referee.completed, referee.completed_at, referee.places_done, referee.drops, frames,
                       participant_time, physics_time)


def bench_world(object_name: str, interaction: str, gravity=EARTH, position=START) -> World:
    """A world with one shipped object at ``position`` and the study's usual effects; under gravity
    the object rests on a table."""
    spec = load_object(object_file(object_name))
    placed = PlacedObject(spec, tuple(position))
    table = TableParameters(height=position[1] - spec.half_extents[1]) if any(gravity) else None
    return make_world(compose_scene([placed], interaction, gravity=gravity, table=table))


def bench_plan(object_name: str) -> PickPlacePlan:
    return PickPlacePlan(object_name, PLACES)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Success rate and completion time of simulated participants.")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--objects", nargs="+", default=["cube", "flat_cuboid", "long_cuboid"])
    parser.add_argument("--skills", nargs="+", default=["veteran", "beginner"])
    parser.add_argument("--interactions", nargs="+", default=sorted(INTERACTION_MODELS))
    parser.add_argument("--time-limit", type=float, default=120.0)
    args = parser.parse_args(argv)
    cells = list(itertools.product(args.skills, args.objects, args.interactions, ("earth", "zero_g")))
    rows = []
    with tqdm(total=len(cells) * args.seeds, unit="trial") as bar:
        for skill, name, interaction, gravity in cells:
            results = []
            for seed in range(args.seeds):
                world = bench_world(name, interaction, EARTH if gravity == "earth" else ZERO_G)
                participant = SimulatedParticipant(bench_plan(name), skill, seed)
                results.append(run_trial(participant, world, args.time_limit))
                bar.update()
            done = [r for r in results if r.completed]
            frames = sum(r.frames for r in results)
            rows.append((skill, name, interaction, gravity, len(done), len(results),
                         np.mean([r.completion_time for r in done]) if done else math.nan,
                         np.mean([r.drops for r in results]),
                         1e6 * sum(r.participant_time for r in results) / frames,
                         1e6 * sum(r.physics_time for r in results) / frames))
    print(f"{'skill':9} {'object':12} {'interaction':20} {'gravity':7} {'success':>8} {'time (s)':>9} "
          f"{'drops':>6} {'us/frame participant':>21} {'physics':>8}")
    for skill, name, interaction, gravity, ok, n, mean_time, drops, participant_us, physics_us in rows:
        print(f"{skill:9} {name:12} {interaction:20} {gravity:7} {ok:>4}/{n:<3} {mean_time:9.1f} {drops:6.1f} "
              f"{participant_us:21.0f} {physics_us:8.0f}")


if __name__ == "__main__":
    main()
