"""The same scenes in MuJoCo and PyBullet, beside ours, in one run: errors and time per step.

How the peers are built (what is the same, what differs):

- The same boxes (size, mass, uniform-density inertia), zero gravity, the same dt, the same
  fingertip spheres on the same track, linearly interpolated between tracking frames exactly as
  ``microg.sim.step`` does.
- For the errors (impact, tumble, shake) the phalanges are spheres on bodies of ``HAND_MASS``
  (1000 kg, 10^4 times the cube) whose pose and velocity are set before every step: kinematic in
  effect, and with the velocity a contact needs. How an engine is driven does not change its errors.
- For the time per step (the live scenes) each engine is built and driven in its own idiom:
  MuJoCo's fingers are mocap bodies (no degrees of freedom), stepped by ``rollout`` in C
  (``driven`` = ``c_loop``) or by ``mj_step`` after setting ``mocap_pos`` from Python
  (``python_per_step``); PyBullet's are kinematic bodies (mass 0, moved by
  ``resetBasePositionAndOrientation``) stepped from Python, as PyBullet has no loop of its own;
  ours is one ``step`` per tracking frame, its substeps in one compiled call (``c_loop``), or one
  ``step`` per physics step (``python_per_step``); the batch of worlds is ``step_batch`` against
  ``rollout`` of as many worlds, both on one thread. Every run is checked for doing ours' work
  (``grasp_check``): a mocap body has no velocity, so MuJoCo's friction cannot carry the cube, and
  only the held grasp (``HOLD``) is equal work for it.
- Restitution: PyBullet takes e directly (the hand's restitution is 1, Bullet multiplies them).
  MuJoCo has no restitution coefficient; its contact is a damped spring, so e is mapped to the
  damping ratio that bounces back e of the speed, zeta = -ln e / sqrt(pi^2 + ln^2 e), with the
  stiffest time constant it allows (2 dt).
- Friction: both use one Coulomb coefficient, the static one (0.8); ours has a dynamic 0.5.
- Neither has the god-object hand or the tracking filter: they get the raw (noisy) hand, so
  ours is compared at F = 1 in the shake.
- The pinch: ours squeezes 10 mm into each face (the god-object springs need it to hold); a rigid
  engine pushed 10 mm deep from both sides ejects the cube, so the peers pinch ``PEER_PINCH`` deep.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from . import ours
from .charts import mark_fronts
from .scenarios import FINGER_RADIUS, HAND_MASS, HOLD, IMPACT, LIVE, SHAKE, TUMBLE, box_overlap, quat_matrix


PEER_PINCH = 0.001
"""m: how far the peers' fingertips reach into the cube's faces in the shake."""


@dataclass
class Bodies:
    """What a peer engine reports after a step: box poses and velocities (world frame)."""

    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray


class Peer:
    """One peer engine holding boxes and kinematic finger spheres."""

    name = "peer"

    def set_hand(self, centres: np.ndarray, velocities: np.ndarray) -> None: ...

    def step(self) -> None: ...

    def bodies(self) -> Bodies: ...

    def close(self) -> None: ...


def damping_ratio(restitution: float) -> float:
    """The damping ratio of a linear spring contact that returns ``restitution`` of the speed."""
    log = math.log(restitution)
    return -log / math.sqrt(math.pi ** 2 + log * log)


class MuJoCo(Peer):
    """Boxes on free joints; fingers on three slide joints each (``HAND_MASS``, pose and velocity set
    every step) or, with ``mocap``, mocap bodies (no degrees of freedom, no velocity)."""

    name = "mujoco"

    def __init__(self, boxes, fingers: int, dt: float, integrator: str = "Euler", states=None, mocap: bool = False):
        import mujoco
        self.mujoco = mujoco
        parts = [f'<mujoco><option timestep="{dt!r}" gravity="0 0 0" integrator="{integrator}"/><worldbody>']
        for i, (box, at) in enumerate(boxes):
            zeta = damping_ratio(box.restitution)
            parts.append(f'<body name="box{i}" pos="{at[0]} {at[1]} {at[2]}"><freejoint/>'
                         f'<geom type="box" size="{box.half[0]} {box.half[1]} {box.half[2]}" mass="{box.mass}" '
                         f'friction="{box.static_friction} 0.005 0.0001" solref="{2 * dt!r} {zeta!r}" '
                         f'contype="2" conaffinity="1"/></body>')
        for k in range(fingers):
            if mocap:
                parts.append(f'<body name="finger{k}" mocap="true" pos="0 -{1 + k} 0"><geom type="sphere" '
                             f'size="{FINGER_RADIUS}" contype="1" conaffinity="2"/></body>')
                continue
            parts.append(f'<body name="finger{k}" pos="0 0 0">'
                         + "".join(f'<joint name="f{k}{a}" type="slide" axis="{v}"/>'
                                   for a, v in zip("xyz", ("1 0 0", "0 1 0", "0 0 1")))
                         + f'<geom type="sphere" size="{FINGER_RADIUS}" mass="{HAND_MASS}" contype="1" '
                           f'conaffinity="2"/></body>')
        parts.append("</worldbody></mujoco>")
        self.model = mujoco.MjModel.from_xml_string("".join(parts))
        self.data = mujoco.MjData(self.model)
        self.n_boxes, self.fingers, self.mocap = len(boxes), fingers, mocap
        for i, (state) in enumerate(states or []):
            self.data.qvel[6 * i:6 * i + 3] = state[0]
            self.data.qvel[6 * i + 3:6 * i + 6] = state[1]  # body frame = world frame at t = 0
        mujoco.mj_forward(self.model, self.data)
        self.hand = slice(7 * self.n_boxes, 7 * self.n_boxes + 3 * fingers)
        self.hand_velocity = slice(6 * self.n_boxes, 6 * self.n_boxes + 3 * fingers)

    def set_hand(self, centres, velocities):
        if self.mocap:
            self.data.mocap_pos[:] = centres
            return
        self.data.qpos[self.hand] = centres.reshape(-1)
        self.data.qvel[self.hand_velocity] = velocities.reshape(-1)

    def step(self):
        self.mujoco.mj_step(self.model, self.data)

    def bodies(self):
        n = self.n_boxes
        qpos = self.data.qpos[:7 * n].reshape(n, 7)
        qvel = self.data.qvel[:6 * n].reshape(n, 6)
        rotations = [quat_matrix(q) for q in qpos[:, 3:]]
        return Bodies(qpos[:, :3].copy(), qpos[:, 3:].copy(), qvel[:, :3].copy(),
                      np.array([r @ w for r, w in zip(rotations, qvel[:, 3:])]))  # free joint: local angular velocity


class PyBullet(Peer):
    """Boxes as multibodies; fingers of ``HAND_MASS`` with pose and velocity set every step or, with
    ``kinematic``, of mass 0 (static to Bullet) moved by ``resetBasePositionAndOrientation``."""

    name = "pybullet"

    def __init__(self, boxes, fingers: int, dt: float, states=None, kinematic: bool = False):
        import pybullet
        self.p = pybullet
        self.client = pybullet.connect(pybullet.DIRECT)
        p, c = pybullet, self.client
        p.setGravity(0, 0, 0, physicsClientId=c)
        p.setTimeStep(dt, physicsClientId=c)
        self.boxes = []
        for i, (box, at) in enumerate(boxes):
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=box.half.tolist(), physicsClientId=c)
            body = p.createMultiBody(box.mass, shape, basePosition=at, physicsClientId=c)
            p.changeDynamics(body, -1, restitution=box.restitution, lateralFriction=box.static_friction,
                             linearDamping=0.0, angularDamping=0.0, physicsClientId=c)
            if states:
                p.resetBaseVelocity(body, states[i][0], states[i][1], physicsClientId=c)
            self.boxes.append(body)
        sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=FINGER_RADIUS, physicsClientId=c)
        self.fingers = []
        for k in range(fingers):
            body = p.createMultiBody(0.0 if kinematic else HAND_MASS, sphere, basePosition=(0, -1 - k, 0),
                                     physicsClientId=c)
            p.changeDynamics(body, -1, restitution=1.0, lateralFriction=1.0, linearDamping=0.0, angularDamping=0.0,
                             physicsClientId=c)
            for other in self.fingers:
                p.setCollisionFilterPair(body, other, -1, -1, 0, physicsClientId=c)
            self.fingers.append(body)
        self.kinematic = kinematic

    def set_hand(self, centres, velocities):
        p, c = self.p, self.client
        for body, centre, velocity in zip(self.fingers, centres, velocities):
            p.resetBasePositionAndOrientation(body, centre.tolist(), (0, 0, 0, 1), physicsClientId=c)
            if not self.kinematic:
                p.resetBaseVelocity(body, velocity.tolist(), (0, 0, 0), physicsClientId=c)

    def step(self):
        self.p.stepSimulation(physicsClientId=self.client)

    def bodies(self):
        p, c = self.p, self.client
        poses = [p.getBasePositionAndOrientation(b, physicsClientId=c) for b in self.boxes]
        speeds = [p.getBaseVelocity(b, physicsClientId=c) for b in self.boxes]
        return Bodies(np.array([x for x, _ in poses]), np.array([(q[3], q[0], q[1], q[2]) for _, q in poses]),
                      np.array([v for v, _ in speeds]), np.array([w for _, w in speeds]))

    def close(self):
        self.p.disconnect(physicsClientId=self.client)


def make_peer(engine: str, variant: str, boxes, fingers: int, dt: float, states=None) -> Peer:
    if engine == "mujoco":
        return MuJoCo(boxes, fingers, dt, variant, states)
    return PyBullet(boxes, fingers, dt, states)


def hand_track(frame_times: np.ndarray, samples: np.ndarray, dt: float, duration: float):
    """Per physics step: the hand at the step's end and its velocity, linearly interpolated between
    frames (what ``microg.sim.step`` does with the hand). samples: (T, K, 3)."""
    steps = int(math.floor(duration / dt + 1e-9))
    ends = (np.arange(steps) + 1) * dt
    frame = np.clip(np.searchsorted(frame_times, ends - 1e-12), 1, len(frame_times) - 1)
    t0, t1 = frame_times[frame - 1], frame_times[frame]
    alpha = ((ends - t0) / (t1 - t0))[:, None, None]
    positions = samples[frame - 1] + alpha * (samples[frame] - samples[frame - 1])
    velocities = (samples[frame] - samples[frame - 1]) / (t1 - t0)[:, None, None]
    return ends, positions, velocities


def run_steps(peer: Peer, positions, velocities, after=None) -> float:
    """Step the peer along the hand track; returns the CPU seconds spent (hand setting included;
    the same clock as ``ours``)."""
    spent = 0.0
    for i in range(len(positions)):
        start = time.process_time()
        peer.set_hand(positions[i], velocities[i])
        peer.step()
        spent += time.process_time() - start
        if after is not None:
            after(i)
    return spent


def impact(engine, variant, dt, rate=110.0, phases=4):
    scenario = IMPACT
    worst = {"restitution_error": 0.0, "max_penetration": 0.0, "cost_us_per_s": np.inf}
    frames = np.arange(int(round(scenario.duration * rate)) + 1) / rate
    substeps = max(1, round(1 / (rate * dt)))
    for k in range(phases):
        shifted = replace(scenario, phase=(k + 0.5) / (phases * substeps))
        samples = np.array([[shifted.finger(t, 1 / rate)] for t in frames])
        ends, positions, velocities = hand_track(frames, samples, dt, scenario.duration)
        peer = make_peer(engine, variant, [(scenario.box, scenario.centre)], 1, dt)
        deepest = [0.0]
        before = peer.bodies()

        def probe(i):
            nonlocal before
            overlap = box_overlap(positions[i, 0], FINGER_RADIUS, before.position[0],
                                  quat_matrix(before.orientation[0]), scenario.box.half)
            deepest[0] = max(deepest[0], overlap)
            before = peer.bodies()

        spent = run_steps(peer, positions, velocities, probe)
        momentum = scenario.box.mass * peer.bodies().velocity[0]
        peer.close()
        worst["restitution_error"] = max(worst["restitution_error"], scenario.restitution_error(momentum))
        worst["max_penetration"] = max(worst["max_penetration"], deepest[0])
        worst["cost_us_per_s"] = min(worst["cost_us_per_s"], 1e6 * spent / scenario.duration)
    return worst


def tumble(engine, variant, dt, scenario=TUMBLE):
    box = scenario.box
    peer = make_peer(engine, variant, [(box, (0.0, 0.2, 0.0))], 0, dt, states=[((0, 0, 0), scenario.omega)])
    per_sample = int(round(scenario.sample / dt))
    momentum, energy, omega_body = [], [], []
    spent = 0.0
    for _ in scenario.times:
        start = time.process_time()
        for _ in range(per_sample):
            peer.step()
        spent += time.process_time() - start
        b = peer.bodies()
        rotation = quat_matrix(b.orientation[0] / np.linalg.norm(b.orientation[0]))
        body = rotation.T @ b.angular_velocity[0]
        momentum.append(rotation @ (box.inertia * body))
        energy.append(0.5 * body @ (box.inertia * body))
        omega_body.append(body)
    peer.close()
    errors = scenario.errors(np.array(momentum), np.array(energy), np.array(omega_body))
    return {**errors, "cost_us_per_s": 1e6 * spent / scenario.duration}


def shake(engine, variant, dt, rate=110.0, scenario=SHAKE):
    scenario = replace(scenario, depth=PEER_PINCH)
    frames = np.arange(int(round(scenario.duration * rate)) + 1) / rate
    noise = scenario.noise_track(frames)
    samples = np.array([np.array(scenario.fingers(t)) + jitter for t, jitter in zip(frames, noise)])
    ends, positions, velocities = hand_track(frames, samples, dt, scenario.duration)
    peer = make_peer(engine, variant, [(scenario.box, scenario.centre)], 2, dt)
    offset = np.empty((len(ends), 3))

    def record(i):
        offset[i] = peer.bodies().position[0] - positions[i].mean(axis=0)

    spent = run_steps(peer, positions, velocities, record)
    peer.close()
    slip = scenario.slip(ends, offset) if np.isfinite(offset).all() else np.inf
    return {"slip": slip, "cost_us_per_s": 1e6 * spent / scenario.duration}


REPEATS = 7
"""Each timing of the live scene is the fastest of this many runs (a shared machine only ever slows
a run down)."""
BATCH_WORLDS = 256
"""Worlds in the batched-stepping measurement (the issue's target)."""
HELD_FROM = 0.5
"""s: by now the grasp has closed (at 0.3 s) and settled in every engine that holds it."""
PATH_TOLERANCE = FINGER_RADIUS
"""m: a peer does ours' work (``equal_work``) while its cube stays within a fingertip's radius of
ours and, once the grasp has settled, no fewer phalanges overlap it than overlap ours."""
LIVE_SCENES = {"live_hold": HOLD, "live_carry": LIVE}
"""The paper's scene held still (every peer can hold it in its own idiom) and carried to and fro
(a mocap body has no velocity, so MuJoCo's friction cannot carry the cube: the check says so)."""
MUJOCO_VARIANTS = ("Euler", "RK4", "implicitfast")
BATCHED_VARIANTS = ("Euler", "implicitfast")


def live_track(scene, dt: float, duration: float, rate: float):
    """The frame times and, per physics step, the hand's sphere centres and velocities."""
    frames = np.arange(int(round(duration * rate)) + 1) / rate
    samples = np.array([scene.spheres(t)[0] for t in frames])
    _, positions, velocities = hand_track(frames, samples, dt, duration)
    return frames, positions, velocities


def stepped(peer: Peer, positions, velocities, substeps: int) -> dict:
    """Drive ``peer`` from Python, one call per physics step (``python_per_step``): CPU microseconds
    per step (the hand's setting included) and the cube's pose after every frame (read off the clock)."""
    frames = len(positions) // substeps
    position, orientation = np.empty((frames, 3)), np.empty((frames, 4))
    spent = 0.0
    for i in range(frames):
        start = time.process_time()
        for j in range(i * substeps, (i + 1) * substeps):
            peer.set_hand(positions[j], velocities[j])
            peer.step()
        spent += time.process_time() - start
        bodies = peer.bodies()
        position[i], orientation[i] = bodies.position[0], bodies.orientation[0]
    peer.close()
    return {"us_per_step": 1e6 * spent / len(positions), "position": position, "orientation": orientation}


def rollout(peer: MuJoCo, positions, substeps: int, worlds: int = 1) -> dict:
    """MuJoCo's own loop in C, ``rollout``, over ``worlds`` copies on one thread, the mocap fingers
    moved along the track (``c_loop``): CPU microseconds per world-step, and world 0's cube pose
    after every frame."""
    import mujoco
    from mujoco import rollout as mj_rollout
    model, data = peer.model, peer.data
    physics = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, physics))
    mujoco.mj_getState(model, data, initial, physics)
    steps = len(positions)
    state = np.empty((worlds, steps, initial.size))
    start = time.process_time()
    mj_rollout.rollout(model, data, np.tile(initial, (worlds, 1)), positions.reshape(1, steps, -1),
                       control_spec=mujoco.mjtState.mjSTATE_MOCAP_POS, state=state)
    spent = time.process_time() - start
    cube = state[0, substeps - 1::substeps, 1:8]  # the state is time, then qpos (the cube's first)
    return {time_metric(worlds): 1e6 * spent / (worlds * steps), "position": cube[:, :3].copy(),
            "orientation": cube[:, 3:].copy()}


def time_metric(worlds: int) -> str:
    return "us_per_step" if worlds == 1 else "us_per_world_step"


def grasp_check(scene, frames: np.ndarray, run: dict, reference: dict) -> dict:
    """Whether ``run`` did the work ours did: the cube's largest distance (m) from ours' path, and the
    fewest phalanges overlapping it once the grasp has settled, both by geometry alone
    (``LiveScene.overlaps``), the same for every engine."""
    count = len(run["position"])
    times = frames[1:count + 1]
    held = times >= HELD_FROM
    deviation = float(np.max(np.linalg.norm(run["position"] - reference["position"][:count], axis=1)))
    overlaps = min(scene.overlaps(t, p, q) for t, p, q in zip(times[held], run["position"][held],
                                                              run["orientation"][held]))
    return {"path_deviation": deviation, "overlaps_held": overlaps}


def fastest(measure, repeats: int = REPEATS, metric: str = "us_per_step") -> dict:
    """The fastest of ``repeats`` timings (a shared machine only ever slows a run down)."""
    return min((measure() for _ in range(repeats)), key=lambda result: result[metric])


def live_runs(config: ours.Config, scene, duration: float, batch_duration: float, worlds: int | None):
    """The frame times and every engine's runs of one live scene at ``config``'s dt, keyed (engine,
    variant, driven, worlds), ours in its own loop first (the reference). ``worlds``: also the
    batched runs, of that many worlds."""
    dt, substeps = config.dt, config.substeps
    frames, positions, velocities = live_track(scene, dt, duration, config.tracking_rate)
    boxes, fingers = list(scene.boxes), positions.shape[1]
    runs = {("microg", "midpoint", "c_loop", 1): lambda: ours.live_path(config, duration, scene),
            ("microg", "midpoint", "python_per_step", 1): lambda: ours.live_path(config, duration, scene, True)}
    for variant in MUJOCO_VARIANTS:
        runs["mujoco", variant, "c_loop", 1] = lambda v=variant: rollout(
            MuJoCo(boxes, fingers, dt, v, mocap=True), positions, substeps)
        runs["mujoco", variant, "python_per_step", 1] = lambda v=variant: stepped(
            MuJoCo(boxes, fingers, dt, v, mocap=True), positions, velocities, substeps)
    runs["pybullet", "default", "python_per_step", 1] = lambda: stepped(
        PyBullet(boxes, fingers, dt, kinematic=True), positions, velocities, substeps)
    if worlds:
        batch_steps = int(round(batch_duration * config.tracking_rate)) * substeps
        runs["microg", "midpoint", "c_loop", worlds] = lambda: ours.live_batch(config, worlds, batch_duration, scene)
        for variant in BATCHED_VARIANTS:
            runs["mujoco", variant, "c_loop", worlds] = lambda v=variant: rollout(
                MuJoCo(boxes, fingers, dt, v, mocap=True), positions[:batch_steps], substeps, worlds)
    return frames, runs


def live_rows(timesteps, duration: float, batch_duration: float, worlds: int, repeats: int) -> list[dict]:
    """The live scenes' time per step for every engine and drive, each with its equal-work check."""
    rows = []
    jobs = [(rate, substeps, name) for rate, substeps in timesteps for name in LIVE_SCENES]
    for rate, substeps, name in tqdm(jobs, desc="peers, live scenes", unit="scene"):
        scene, config = LIVE_SCENES[name], ours.Config(rate, substeps, "midpoint", 1)
        batched = worlds if config.dt == ours.Config().dt else None
        frames, runs = live_runs(config, scene, duration, batch_duration, batched)
        reference = mine = None
        for (engine, variant, driven, count), measure in runs.items():
            metric = time_metric(count)
            result = fastest(measure, repeats, metric)
            if reference is None:  # ours in its own loop, the first run
                reference = result
                mine = grasp_check(scene, frames, reference, reference)
            check = grasp_check(scene, frames, result, reference)
            rows.append({"engine": engine, "variant": variant if engine == "microg" else engine + ":" + variant,
                         "scenario": name, "tracking_rate": rate, "substeps": substeps, "dt": config.dt,
                         "filter_window": 1, "driven": driven, "worlds": count, "metric": metric, "error": np.nan,
                         "value": result[metric], "cost_us_per_s": np.nan, **check,
                         "equal_work": check["path_deviation"] <= PATH_TOLERANCE
                         and check["overlaps_held"] >= mine["overlaps_held"]})
    return rows


ENGINES = (("microg", "midpoint"), ("mujoco", "Euler"), ("mujoco", "RK4"), ("mujoco", "implicitfast"),
           ("pybullet", "default"))
TIMESTEPS = ((110.0, 1), (110.0, 4), (110.0, 16))
TIME_METRICS = ("us_per_step", "us_per_world_step")


def run(out: Path, figures: Path, quick: bool = False) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every engine on every scenario at each dt; writes ``peers.csv`` (tidy), ``peer_ratios.csv``
    (ours over each peer at the default dt, same run) and ``bench-peers.png``.

    The errors (impact, tumble, shake) come from the peers driven from Python each step, their
    fingers heavy bodies set to the hand's pose and velocity (how a peer is driven does not change
    its error); the time per step of the live scenes from every engine in its own idiom (module
    docstring), in its own loop where it has one, each run checked for doing ours' work."""
    from .charts import error_cost_chart
    timesteps = ((110.0, 4),) if quick else TIMESTEPS
    tumble_scene = replace(TUMBLE, duration=5.0) if quick else TUMBLE
    shake_scene = replace(SHAKE, cycles=4, hold=0.6) if quick else SHAKE
    ours.warm_up()
    jobs = [(engine, variant, rate, substeps, scenario) for rate, substeps in timesteps
            for engine, variant in ENGINES for scenario in ("impact", "tumble", "shake")]
    rows = []
    for engine, variant, rate, substeps, scenario in tqdm(jobs, desc="peers, errors", unit="run"):
        dt = 1.0 / (rate * substeps)
        if engine == "microg":
            if scenario == "tumble":
                result = ours.tumble(ours.Config(rate, substeps, variant), tumble_scene)
            elif scenario == "shake":
                result = ours.shake(ours.Config(rate, substeps, variant, 1), shake_scene)
                result = {"slip": result["slip"], "cost_us_per_s": result["cost_us_per_s"]}
            else:
                result = ours.impact(ours.Config(rate, substeps, variant))
        else:
            result = {"impact": lambda: impact(engine, variant, dt, rate),
                      "tumble": lambda: tumble(engine, variant, dt, tumble_scene),
                      "shake": lambda: shake(engine, variant, dt, rate, shake_scene)}[scenario]()
        base = {"engine": engine, "variant": variant if engine == "microg" else engine + ":" + variant,
                "scenario": scenario, "tracking_rate": rate, "substeps": substeps, "dt": dt, "filter_window": 1,
                "driven": "c_loop" if engine == "microg" else "python_per_step", "worlds": 1}
        cost = result.pop("cost_us_per_s")
        for metric, error in result.items():
            if metric in ("hits", "min_contacts", "cube_speed_max", "lag", "tracking_rms"):
                continue
            rows.append({**base, "metric": metric, "error": float(error), "value": float(error),
                         "cost_us_per_s": cost})
    rows += live_rows(timesteps, 1.0 if quick else 4.0, 0.6 if quick else 1.0, 32 if quick else BATCH_WORLDS,
                      2 if quick else REPEATS)
    table = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "peers.csv", index=False)
    ratios = peer_ratios(table)
    ratios.to_csv(out / "peer_ratios.csv", index=False)
    errors = mark_fronts(table[~table["metric"].isin(TIME_METRICS)].dropna(subset=["error"]))
    errors["variant"] = errors["variant"].where(errors["engine"] == "microg", errors["engine"])
    error_cost_chart(errors, figures / "bench-peers.png", "microg (midpoint) beside MuJoCo and PyBullet, same run")
    return table, ratios


def peer_ratios(table: pd.DataFrame, dt: float = ours.Config().dt) -> pd.DataFrame:
    """Ours over each peer at ``dt`` (the default), metric by metric: < 1 means ours is smaller.
    Times pair the same drive (``driven``) and number of worlds; errors do not depend on the drive
    (``driven`` is the peer's)."""
    at = table[np.isclose(table["dt"], dt)]
    mine = at[at["engine"] == "microg"]
    rows = []
    for _, theirs in at[at["engine"] != "microg"].iterrows():
        same = (mine["scenario"] == theirs["scenario"]) & (mine["metric"] == theirs["metric"])
        if theirs["metric"] in TIME_METRICS:
            same &= (mine["driven"] == theirs["driven"]) & (mine["worlds"] == theirs["worlds"])
        if not same.any():
            continue
        value = float(mine.loc[same, "value"].iloc[0])
        rows.append({"peer": theirs["variant"], "scenario": theirs["scenario"], "metric": theirs["metric"],
                     "driven": theirs["driven"], "worlds": theirs["worlds"], "microg": value,
                     "peer_value": theirs["value"],
                     "ratio_microg_over_peer": value / theirs["value"] if theirs["value"] else np.inf,
                     "equal_work": theirs.get("equal_work", np.nan)})
    return pd.DataFrame(rows)
