"""Cold start: from a fresh Python process to the first physics frame, with an empty compile cache.

The first command after ``pip install`` compiles the physics for its scene (numba, ``microg.skeleton.cache``);
later runs load it from the user's cache directory. Each run is a fresh subprocess with its own
``NUMBA_CACHE_DIR`` (a new empty directory for the cold runs, the same one again for the warm run),
timed from before the interpreter starts to the first frame's return: wall seconds, and the CPU
seconds the process used (what a quiet 2-core machine would take; on a shared one the wall time
is longer).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

TARGET_S = 20.0
"""Cold start to the first frame (the issue's target)."""

FIRST_FRAME = """
from microg.sim import HandFrame, PlacedObject, compose_scene, load_object, make_world, step
from microg.paths import object_file
from microg.participant.scripted import probe_hand
scene = compose_scene([PlacedObject(load_object(object_file("cube")), (0.0, 0.2, 0.0))], "impulse_penetration")
world = step(make_world(scene), HandFrame(0.0, (probe_hand({"index.distal": (0.0, 0.25, 0.0)}),)))
world = step(world, HandFrame(1 / 110, (probe_hand({"index.distal": (0.0, 0.249, 0.0)}),)))
"""
"""The paper's model in zero g with the study's effects (gyroscopic, continuous collision): what
``microg sim demo`` and a study's first task compile."""


def first_frame(cache: Path) -> dict[str, float]:
    """Run ``FIRST_FRAME`` in a fresh interpreter with numba's cache in ``cache``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", FIRST_FRAME], check=True, env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu}


def run(out: Path, figures: Path, quick: bool = False) -> pd.DataFrame:
    """Measure cold starts (empty cache) and a warm start (the cache the last cold run left);
    write ``coldstart.csv``."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="microg-coldstart-") as scratch:
        for i in range(1 if quick else 2):
            cache = Path(scratch) / f"cold{i}"
            rows.append({"measure": "cold start to first frame (empty cache)", **first_frame(cache),
                         "target_s": TARGET_S})
        rows.append({"measure": "warm start to first frame (cache filled)", **first_frame(cache), "target_s": TARGET_S})
    table = pd.DataFrame(rows)
    table["load_average"] = os.getloadavg()[0]
    table["met"] = table["wall_s"] <= table["target_s"]
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "coldstart.csv", index=False)
    return table
