"""Cold start: from a fresh Python process to the first physics frame with an empty compile cache,
and a demo's first run, whose workers must not compile the same kernel twice.

The first command after ``pip install`` compiles the physics for its scene (numba, ``microg.skeleton.cache``);
later runs load it from the user's cache directory. Each run is a fresh subprocess with its own
``NUMBA_CACHE_DIR`` (a new empty directory for the cold runs, the same one again for the warm run),
timed from before the interpreter starts to the first frame's return: wall seconds, and the CPU
seconds the process used (what a quiet 2-core machine would take; on a shared one the wall time
is longer). numba's cache log (``NUMBA_DEBUG_CACHE``) names every entry saved, and a function
compiles once per entry saved: entries saved twice were compiled twice (by two processes).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import pandas as pd

TARGET_S = 20.0
"""Cold start to the first frame (the issue's target)."""

FIRST_FRAME = """
from microg.skeleton import HandFrame
from microg.sim import PlacedObject, compose_scene, load_object, make_world, step
from microg.paths import object_file
from microg.participant.scripted import probe_hand
scene = compose_scene([PlacedObject(load_object(object_file("cube")), (0.0, 0.2, 0.0))], "impulse_penetration")
world = step(make_world(scene), HandFrame(0.0, (probe_hand({"index.distal": (0.0, 0.25, 0.0)}),)))
world = step(world, HandFrame(1 / 110, (probe_hand({"index.distal": (0.0, 0.249, 0.0)}),)))
"""
"""The paper's model in zero g with the study's effects (gyroscopic, continuous collision): what
``microg sim demo`` and a study's first task compile."""

DEMO = "from microg.cli import main; main()"
DEMO_ARGS = ("demo", "--participants", "2", "--jobs", "2", "--quiet")
"""A demo of two participants on two workers: both start at once on an empty cache."""
SAVED = "data saved to "
"""How numba's cache log names an entry it wrote."""


def timed(args: list[str], cache: Path) -> dict[str, float]:
    """Run ``args`` (a fresh interpreter) with numba's cache in ``cache``: wall and CPU seconds (of
    the process and every process it waited for), the entries compiled, and how many of those were
    compiled more than once."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "NUMBA_DEBUG_CACHE": "1"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise RuntimeError(f"{' '.join(args[:3])} ... failed ({done.returncode}):\n{done.stderr[-2000:]}")
    saves = Counter(line.split(SAVED, 1)[1] for line in done.stdout.splitlines() if SAVED in line)
    return {"wall_s": wall, "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
            "compiled": len(saves), "compiled_twice": sum(count > 1 for count in saves.values())}


def run(out: Path, figures: Path, quick: bool = False) -> pd.DataFrame:
    """Measure cold starts (empty cache), a warm start (the cache the last cold run left) and a
    demo's first run on an empty cache; write ``coldstart.csv``."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="microg-coldstart-") as scratch:
        for i in range(1 if quick else 2):
            cache = Path(scratch) / f"cold{i}"
            rows.append({"measure": "cold start to first frame (empty cache)",
                         **timed([sys.executable, "-c", FIRST_FRAME], cache), "target_s": TARGET_S})
        rows.append({"measure": "warm start to first frame (cache filled)",
                     **timed([sys.executable, "-c", FIRST_FRAME], cache), "target_s": TARGET_S})
        demo = timed([sys.executable, "-c", DEMO, *DEMO_ARGS, "--out", str(Path(scratch) / "demo")],
                     Path(scratch) / "demo-cache")
        rows.append({"measure": "first microg demo, 2 participants on 2 workers (empty cache)", **demo})
    table = pd.DataFrame(rows)
    table["load_average"] = os.getloadavg()[0]
    table["met"] = (table["wall_s"] <= table["target_s"]).where(table["target_s"].notna(), table["compiled_twice"] == 0)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "coldstart.csv", index=False)
    return table
