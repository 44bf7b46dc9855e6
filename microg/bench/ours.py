"""The benchmark scenarios on ``microg.sim``: errors against the independent answers, and the cost.

Cost is the CPU time of this process inside ``step`` only (frames are built and filtered before the
clock starts), as microseconds per simulated second. CPU time, not wall time: on a machine shared with
other work, it is what a core of our own would take, and it charges every engine alike (``peers``
uses the same clock). Numba compiles on first use: call ``warm_up`` before timing anything.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from microg.skeleton import Hand, HandFrame, slot
from microg.sim import (Material, ObjectSpec, PlacedObject, angular_momentum, compose_scene,
                        kinetic_energy, make_batch, make_world, stack_frames, step, step_batch)
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
    and the CPU seconds of the steps. The filter runs first, off the clock: it belongs to the hands
    (``microg.hands.filter``), not to the physics, and costs the same at every dt (``filter_cost``).
    The frames are then made the records the step reads (``stack_frames``), off the clock too, as
    every peer's hand track is made before its clock starts. One clock around the whole loop, as
    around MuJoCo's ``rollout`` (a clock read costs half a microsecond, a third of a physics step);
    ``after(world, i)``, called after frame i, runs in a second pass, off the clock (the step is
    deterministic: the two passes are the same to the bit)."""
    if filter_window > 1:
        smooth = HandFilter(filter_window, 1.0 / world.model.scene.tracking_rate).smooth
        frames = [smooth(frame) for frame in frames]
    records = stack_frames(frames)
    first = world
    start = time.process_time()
    for record in records:
        world = step(world, record)
    spent = time.process_time() - start
    if after is not None:
        again = first
        for i, record in enumerate(records):
            again = step(again, record)
            after(again, i)
    return world, spent


def physics_steps(frames, substeps: int, filter_window: int, rate: float) -> list[HandFrame]:
    """The (filtered) frames cut into one frame per physics step, the hand on the line between two
    frames as the world moves it: stepping through these runs the same physics one step a call."""
    smooth = HandFilter(filter_window, 1.0 / rate).smooth if filter_window > 1 else (lambda frame: frame)
    filtered = [smooth(frame) for frame in frames]
    cut = filtered[:1]
    for before, after in zip(filtered, filtered[1:]):
        for j in range(1, substeps + 1):
            alpha = j / substeps
            hands = tuple(Hand(h.side, b.joints + alpha * (h.joints - b.joints), h.widths,
                               b.palm_position + alpha * (h.palm_position - b.palm_position), h.palm_orientation,
                               h.track_id) for h, b in zip(after.hands, before.hands))
            cut.append(HandFrame(before.timestamp + alpha * (after.timestamp - before.timestamp), hands))
    return cut


def impact(config: Config, scenario: Impact = IMPACT, phases: int = 4) -> dict[str, float]:
    """Over ``phases`` touch times spread across a physics step: the worst restitution error
    (relative) and the deepest overlap (m) of the fingertip into the bar that the engine had to
    resolve (the hand at the end of a step against the bar before the step: measured in a second,
    untimed run one physics step a call); the hits counted."""
    placed = [PlacedObject(spec_of(scenario.box), scenario.centre)]
    times = config.frame_times(scenario.duration)
    half = scenario.box.half
    worst = {"restitution_error": 0.0, "max_penetration": 0.0, "hits": 0, "cost_us_per_s": np.inf}
    for k in range(phases):
        shifted = replace(scenario, phase=(k + 0.5) / (phases * config.substeps))
        frames = [HandFrame(float(t), (probe_hand({"index.distal": shifted.finger(t, 1 / config.tracking_rate)},
                                                  width=2 * FINGER_RADIUS),)) for t in times]
        world, spent = run_frames(world_for(config, placed), frames, filter_window=config.filter_window)
        momentum = scenario.box.mass * world.data.velocity[0]
        deepest, hits = 0.0, 0
        stepped = world_for(config, placed)
        for frame in physics_steps(frames, config.substeps, config.filter_window, config.tracking_rate):
            position, rotation = stepped.data.position[0].copy(), quat_matrix(stepped.data.orientation[0])
            stepped = step(stepped, frame)
            deepest = max(deepest, box_overlap(stepped.data.hand_position[INDEX], FINGER_RADIUS, position, rotation,
                                               half))
            hits += int((stepped.data.impulse > 0).sum())
        worst["restitution_error"] = max(worst["restitution_error"], scenario.restitution_error(momentum))
        worst["max_penetration"] = max(worst["max_penetration"], deepest)
        worst["hits"] = max(worst["hits"], hits)
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
    """Physics steps per CPU second for the paper's scene, and the contacts it holds. The physics
    alone: the window filter runs before it, in ``microg.hands`` (``filter_cost``)."""
    frames = live_frames(config, duration, scene)
    contacts = []
    world, spent = run_frames(live_world(config, scene), frames,
                              lambda w, i: contacts.append(int(w.data.active.sum())), 1)
    steps = world.data.steps
    return {"us_per_step": 1e6 * spent / steps, "steps_per_s": steps / spent, "real_time_factor": duration / spent,
            "min_contacts": min(contacts[len(contacts) // 4:]), "cube_speed_max": float(np.abs(world.data.velocity).max())}


def live_path(config: Config, duration: float = 4.0, scene: LiveScene = LIVE, per_step: bool = False) -> dict:
    """CPU microseconds per physics step of the live scene, and the cube's pose after every frame.

    Driven one ``step`` per frame (its substeps in one compiled call: the ``c_loop`` of the peer
    bench), or with ``per_step`` one ``step`` per physics step (the frames cut at every step, the
    same physics: ``python_per_step``). Only the ``step`` calls are timed."""
    frames = live_frames(config, duration, scene)
    every = 1
    if per_step:
        frames, every = physics_steps(frames, config.substeps, 1, config.tracking_rate), config.substeps
    count = (len(frames) - 1) // every
    position, orientation = np.empty((count, 3)), np.empty((count, 4))

    def record(world, i):
        if i and i % every == 0:
            position[i // every - 1] = world.data.position[0]
            orientation[i // every - 1] = world.data.orientation[0]

    world, spent = run_frames(live_world(config, scene), frames, record)
    return {"us_per_step": 1e6 * spent / world.data.steps, "position": position, "orientation": orientation}


def live_batch(config: Config, worlds: int, duration: float = 1.0, scene: LiveScene = LIVE) -> dict:
    """``worlds`` copies of the live scene stepped together by ``step_batch`` on one core: CPU time
    per world-step (only the ``step_batch`` calls are timed; the frames are stacked outside the
    clock), and world 0's cube pose after every frame."""
    frames = live_frames(config, duration, scene)
    batch = make_batch(live_world(config, scene).model.scene, worlds)
    position, orientation = np.empty((len(frames) - 1, 3)), np.empty((len(frames) - 1, 4))
    spent = 0.0
    for i, frame in enumerate(frames):
        stacked = stack_frames([frame] * worlds)
        start = time.process_time()
        batch = step_batch(batch, stacked)
        spent += time.process_time() - start
        if i:
            first = batch.world(0).data
            position[i - 1], orientation[i - 1] = first.position[0], first.orientation[0]
    steps = worlds * batch.world(0).data.steps
    return {"worlds": worlds, "world_steps_per_s_per_core": steps / spent, "us_per_world_step": 1e6 * spent / steps,
            "real_time_factor": worlds * duration / spent, "position": position, "orientation": orientation}


def filter_cost(config: Config, duration: float = 1.0, scene: LiveScene = LIVE) -> float:
    """Microseconds per frame of the window filter (Eq. 1, ``config.filter_window``) on the live hand."""
    frames = live_frames(config, duration, scene)
    smooth = HandFilter(config.filter_window, 1.0 / config.tracking_rate).smooth
    start = time.process_time()
    for frame in frames:
        smooth(frame)
    return 1e6 * (time.process_time() - start) / len(frames)


def warm_up() -> None:
    """Compile every kernel the benchmarks use, so no timing includes numba's compiler."""
    for integrator in ("midpoint", "semi_implicit_euler", "explicit_euler"):
        config = Config(angular_integrator=integrator, substeps=1)
        impact(config, replace(IMPACT, duration=0.15), phases=1)
        tumble(config, replace(TUMBLE, duration=1.0))
    shake(Config(substeps=1), replace(SHAKE, cycles=2, hold=0.5))
    live(Config(substeps=1), duration=0.2)
