"""Throughput: steps per second of the live scene, batches of simulated participants, memory.

The live scene is ``scenarios.LIVE`` (one hand, three objects, a 14-contact grasp carried to and
fro). A batch runs N independent participants, each a world of the three objects driven by its
own hand through the pick-and-carry of ``microg.participant.scripted.pinch_and_carry`` with a seeded
variation of where it carries the cube and how fast. Scripted hands keep the batch a measure of
the physics alone; ``microg demo`` measures whole simulated sessions. Batched stepping beside
MuJoCo's ``rollout``, with the work checked equal, is in ``peers``.
"""

from __future__ import annotations

import multiprocessing
import time
import tracemalloc
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from tqdm import tqdm  # noqa: E402

from microg.skeleton import HandFrame  # noqa: E402
from microg.sim import step  # noqa: E402
from microg.participant.scripted import pinch_and_carry, probe_hand  # noqa: E402

from . import ours  # noqa: E402
from .peers import BATCH_WORLDS, fastest  # noqa: E402

REAL_TIME_TARGET = 100.0
"""x real time at 1 kHz (the issue's target)."""
STUDY_TARGET = (30, 120.0)
"""30 participants in 120 s on 2 cores (measured by the lead with ``microg demo``)."""


def scripted_participant(seed: int, rate: float = 110.0) -> list[HandFrame]:
    """The frames of one scripted participant: pick the cube, carry it somewhere, let go."""
    rng = np.random.default_rng(seed)
    carry = (rng.uniform(-0.2, 0.2), rng.uniform(0.0, 0.15), rng.uniform(-0.1, 0.1))
    path, released = pinch_and_carry(ours.LIVE.cube_at, ours.LIVE.cube.half[0], carry=carry,
                                     move=rng.uniform(1.0, 2.0))
    return [HandFrame(float(t), (probe_hand(path(t)),)) for t in np.arange(0.0, released + 0.5, 1 / rate)]


def participant_run(seed: int) -> tuple[float, float, int]:
    """Run one participant; returns (simulated s, wall s, physics steps)."""
    frames = scripted_participant(seed)
    world = ours.live_world(ours.Config())
    start = time.perf_counter()
    for frame in frames:
        world = step(world, frame)
    return frames[-1].timestamp, time.perf_counter() - start, world.data.steps


def batch(participants: int, workers: int) -> dict[str, float]:
    """Run ``participants`` participants on ``workers`` processes; rates from the wall clock."""
    start = time.perf_counter()
    if workers == 1:
        results = [participant_run(seed) for seed in range(participants)]
    else:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            results = pool.map(participant_run, range(participants))
    wall = time.perf_counter() - start
    simulated = sum(r[0] for r in results)
    steps = sum(r[2] for r in results)
    return {"participants": participants, "workers": workers, "wall_s": wall, "simulated_s": simulated,
            "steps_per_s": steps / wall, "real_time_factor": simulated / wall,
            "participants_per_minute": 60 * participants / wall}


def memory_per_participant(participants: int = 20) -> float:
    """Bytes held per live participant: its world after a few frames (what a batch keeps in memory)."""
    frames = scripted_participant(0)[:20]
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    worlds = []
    for _ in range(participants):
        world = ours.live_world(ours.Config())
        for frame in frames:
            world = step(world, frame)
        worlds.append(world)
    held = tracemalloc.get_traced_memory()[0] - base
    tracemalloc.stop()
    return held / participants


def run(out: Path, figures: Path, quick: bool = False, participants: int | None = None) -> pd.DataFrame:
    """Measure and write ``throughput.csv`` and ``bench-throughput.png``."""
    ours.warm_up()
    participants = participants or (4 if quick else 30)
    duration = 1.0 if quick else 4.0
    rows = []
    live_configs = {"default (110 Hz x 4)": ours.Config(), "110 Hz x 2": ours.Config(110.0, 2),
                    "1 kHz (125 Hz x 8)": ours.Config(125.0, 8)}
    for label, config in tqdm(live_configs.items(), desc="live scene", unit="config"):
        result = fastest(lambda: ours.live(config, duration))
        rows.append({"measure": f"live scene, {label}", "dt": config.dt, **result,
                     "target": REAL_TIME_TARGET if "1 kHz" in label else np.nan})
    for workers in tqdm((1, 2), desc="participant batches", unit="batch"):
        rows.append({"measure": f"batch of {participants} scripted participants, {workers} process(es)",
                     "dt": ours.Config().dt, **batch(participants, workers)})
    worlds = 32 if quick else BATCH_WORLDS
    batch_duration = 0.3 if quick else 1.0
    config = ours.Config(110.0, 4)  # dt = 1/440 s, as in the peers' comparison
    ours.live_batch(config, 2, 0.05)  # compile outside the clock
    batched = fastest(lambda: ours.live_batch(config, worlds, batch_duration), 2, "us_per_world_step")
    rows.append({"measure": f"batch of {worlds} worlds, step_batch, live scene 110 Hz x 4, 1 core", "dt": config.dt,
                 **{key: batched[key] for key in ("worlds", "world_steps_per_s_per_core", "us_per_world_step",
                                                  "real_time_factor")}})
    rows.append({"measure": "window filter (F = 3) on the live hand, per frame (us); runs before the physics",
                 "value": ours.filter_cost(config, batch_duration)})
    rows.append({"measure": "memory per participant (bytes)", "value": memory_per_participant(4 if quick else 20)})
    table = pd.DataFrame(rows)
    best = table.dropna(subset=["participants_per_minute"])["participants_per_minute"].max()
    table.loc[len(table)] = {"measure": f"minutes for a study of {STUDY_TARGET[0]} scripted participants, 2 cores",
                             "value": STUDY_TARGET[0] / best, "target": STUDY_TARGET[1] / 60}
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "throughput.csv", index=False)
    chart(table, figures / "bench-throughput.png")
    return table


def chart(table: pd.DataFrame, path: Path) -> Path:
    rated = table.dropna(subset=["real_time_factor"])
    figure, ax = plt.subplots(figsize=(8, 0.6 * len(rated) + 1.5))
    ax.barh(rated["measure"], rated["real_time_factor"], color="tab:blue")
    target = table["target"].where(table["measure"].str.contains("1 kHz")).dropna()
    if len(target):
        ax.axvline(float(target.iloc[0]), color="tab:red", ls="--", label="target at 1 kHz: 100x real time")
        ax.legend(loc="lower right", fontsize=8)
    ax.set(xlabel="simulated seconds per wall second (x real time)", title="microg throughput")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
