"""The benchmark scenarios on ``microg.sim``: errors against the independent answers, and the cost.

Cost is wall time inside ``step`` only (frames are built before the clock starts), as microseconds
per simulated second. Numba compiles on first use: call ``warm_up`` before timing anything.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from microg.sim import (Hand, HandFrame, Material, ObjectSpec, PlacedObject, angular_momentum, compose_scene,
                        kinetic_energy, make_world, slot, step)
from microg.hands.filter import HandFilter
from microg.participant.scripted import probe_hand

from .scenarios import FINGER_RADIUS, IMPACT, LIVE, SHAKE, TUMBLE, Box, Impact, LiveScene, Shake, Tumble, \
    box_overlap, quat_matrix

THUMB, INDEX = slot("right", 0, 3), slot("right", 1, 3)


@dataclass(frozen=True)
class Config:
    """One point of the sweep: how often the hand arrives, how finely the physics steps, and how."""

    tracking_rate: float = 110.0
    substeps: int = 4
    angular_integrator: str = "midpoint"
    filter_window: int = 3
    interaction: str = "impulse_penetration"

    @property
    def dt(self) -> float:
        return 1.0 / (self.tracking_rate * self.substeps)

    def frame_times(self, duration: float) -> np.ndarray:
        return np.arange(int(round(duration * self.tracking_rate)) + 1) / self.tracking_rate


def spec_of(box: Box) -> ObjectSpec:
    return ObjectSpec(box.name, "box", box.size, box.mass,
                      Material(box.restitution, box.static_friction, box.dynamic_friction))


def world_for(config: Config, placed: list[PlacedObject]):
    scene = compose_scene(placed, config.interaction, tracking_rate=config.tracking_rate, substeps=config.substeps,
                          angular_integrator=config.angular_integrator)
    return make_world(scene)


def run_frames(world, frames, after=None, filter_window: int = 1) -> tuple[object, float]:
    """Filter (Eq. 1, window ``filter_window``) and step through ``frames``; returns the final world
    and the seconds spent filtering and stepping. ``after(world, i)`` is called after frame i,
    outside the clock."""
    smooth = HandFilter(filter_window, 1.0 / world.model.scene.tracking_rate)
    spent = 0.0
    for i, frame in enumerate(frames):
        start = time.perf_counter()
        world = step(world, smooth(frame))
        spent += time.perf_counter() - start
        if after is not None:
            after(world, i)
    return world, spent


def with_probe(world, probe):
    """The same world with ``probe(model, data, h)`` run in every physics step right after the hand
    moved and before anything responds to it (not timed)."""
    model = world.model
    assert model.stage_names[0] == "move_hand"
    model = replace(model, stages=model.stages[:1] + (probe,) + model.stages[1:],
                    stage_names=model.stage_names[:1] + ("probe",) + model.stage_names[1:])
    return type(world)(model, world.data)


def impact(config: Config, scenario: Impact = IMPACT, phases: int = 4) -> dict[str, float]:
    """Over ``phases`` touch times spread across a physics step: the worst restitution error
    (relative) and the deepest overlap (m) of the fingertip into the bar that the engine had to
    resolve (the hand at the end of a step against the bar before the step); the hits counted."""
    placed = [PlacedObject(spec_of(scenario.box), scenario.centre)]
    times = config.frame_times(scenario.duration)
    half = scenario.box.half
    worst = {"restitution_error": 0.0, "max_penetration": 0.0, "hits": 0, "cost_us_per_s": np.inf}
    for k in range(phases):
        shifted = replace(scenario, phase=(k + 0.5) / (phases * config.substeps))
        frames = [HandFrame(float(t), (probe_hand({"index.distal": shifted.finger(t, 1 / config.tracking_rate)},
                                                  width=2 * FINGER_RADIUS),)) for t in times]
        deepest, hits = [0.0], [0]

        def probe(model, data, h):
            overlap = box_overlap(data.hand_position[INDEX], FINGER_RADIUS, data.position[0],
                                  quat_matrix(data.orientation[0]), half)
            deepest[0] = max(deepest[0], overlap)
            hits[0] += int((data.impulse > 0).sum())  # the impulses of the step before

        world, spent = run_frames(with_probe(world_for(config, placed), probe), frames, filter_window=config.filter_window)
        momentum = scenario.box.mass * world.data.velocity[0]
        worst["restitution_error"] = max(worst["restitution_error"], scenario.restitution_error(momentum))
        worst["max_penetration"] = max(worst["max_penetration"], deepest[0])
        worst["hits"] = max(worst["hits"], hits[0])
        worst["cost_us_per_s"] = min(worst["cost_us_per_s"], 1e6 * spent / scenario.duration)
    return worst


def tumble(config: Config, scenario: Tumble = TUMBLE) -> dict[str, float]:
    """|L| and energy drift, and the body-rate error against ``solve_ivp``, over the free tumble."""
    placed = [PlacedObject(spec_of(scenario.box), (0.0, 0.2, 0.0), angular_velocity=scenario.omega)]
    times = config.frame_times(scenario.duration)
    every = int(round(scenario.sample * config.tracking_rate))
    frames = [HandFrame(float(t)) for t in times]
    momentum, energy, omega_body = [], [], []

    def record(world, i):
        if i and i % every == 0:
            momentum.append(angular_momentum(world)[0])
            energy.append(kinetic_energy(world)[0])
            omega_body.append(quat_matrix(world.data.orientation[0]).T @ world.data.angular_velocity[0])

    _, spent = run_frames(world_for(config, placed), frames, record, config.filter_window)
    errors = scenario.errors(np.array(momentum), np.array(energy), np.array(omega_body))
    return {**errors, "cost_us_per_s": 1e6 * spent / scenario.duration}


def shake(config: Config, scenario: Shake = SHAKE) -> dict[str, float]:
    """Slip of the pinched cube (m), tracking lag (s) and RMS tracking error (m) under the shake."""
    placed = [PlacedObject(spec_of(scenario.box), scenario.centre)]
    times = config.frame_times(scenario.duration)
    noise = scenario.noise_track(times)
    frames = []
    for t, jitter in zip(times, noise):
        thumb, index = scenario.fingers(t)
        hand = probe_hand({"thumb.distal": thumb + jitter, "index.distal": index + jitter}, width=2 * FINGER_RADIUS)
        frames.append(HandFrame(float(t), (hand,)))
    offset = np.empty((len(times), 3))
    hand_y = np.empty(len(times))

    def record(world, i):
        d = world.data
        middle = 0.5 * (d.hand_position[THUMB] + d.hand_position[INDEX])
        offset[i] = d.position[0] - middle
        hand_y[i] = middle[1] - scenario.centre[1]

    world, spent = run_frames(world_for(config, placed), frames, record, config.filter_window)
    finite = np.isfinite(world.data.position).all()
    return {"slip": scenario.slip(times, offset) if finite else np.inf, **scenario.tracking(times, hand_y),
            "cost_us_per_s": 1e6 * spent / scenario.duration}


def live_frames(config: Config, duration: float, scene: LiveScene = LIVE) -> list[HandFrame]:
    frames = []
    for t in config.frame_times(duration):
        joints, widths = scene.joints(t)
        frames.append(HandFrame(float(t), (Hand("right", joints, widths, joints[1:, 1].mean(axis=0)),)))
    return frames


def live_world(config: Config, scene: LiveScene = LIVE):
    return world_for(config, [PlacedObject(spec_of(box), at) for box, at in scene.boxes])


def live(config: Config, duration: float = 4.0, scene: LiveScene = LIVE) -> dict[str, float]:
    """Physics steps per second of wall time for the paper's scene, and the contacts it holds."""
    frames = live_frames(config, duration, scene)
    contacts = []
    world, spent = run_frames(live_world(config, scene), frames,
                              lambda w, i: contacts.append(int(w.data.active.sum())), config.filter_window)
    steps = world.data.steps
    return {"us_per_step": 1e6 * spent / steps, "steps_per_s": steps / spent, "real_time_factor": duration / spent,
            "min_contacts": min(contacts[len(contacts) // 4:]), "cube_speed_max": float(np.abs(world.data.velocity).max())}


def warm_up() -> None:
    """Compile every kernel the benchmarks use, so no timing includes numba's compiler."""
    for integrator in ("midpoint", "semi_implicit_euler", "explicit_euler"):
        config = Config(angular_integrator=integrator, substeps=1)
        impact(config, replace(IMPACT, duration=0.15), phases=1)
        tumble(config, replace(TUMBLE, duration=1.0))
    shake(Config(substeps=1), replace(SHAKE, cycles=2, hold=0.5))
    live(Config(substeps=1), duration=0.2)
