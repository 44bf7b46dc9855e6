"""``microg bench insilico``: a whole simulated study of the paper's protocol in silico (its tasks
played batched in compiled code, no frame logged: ``simulate_trials``) beside the same study run by
the session runner with every frame logged (``microg demo``'s sessions, export and report), in one
run on the same machine. Writes ``insilico.csv``: per mode, the participants, the tasks, the wall
and CPU seconds (this process and its workers), and, for the in-silico study, the target (<= 10 s
of wall time on 2 cores for 30 participants) and whether it was met. It lives in the in-silico room
because ``microg.bench`` may not import the study.
"""

from __future__ import annotations

import resource
import tempfile
import time
from pathlib import Path

import pandas as pd

TARGET_S = 10.0
"""Wall seconds for a 30-participant in-silico study of the paper's protocol on 2 cores."""


def _cpu() -> float:
    """CPU seconds of this process and its finished children so far."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def run(out: Path, quick: bool = False, workers: int = 2, seed: int = 1) -> pd.DataFrame:
    """Measure (module docstring), write ``out/insilico.csv`` and return the table."""
    from microg.paths import protocol_file
    from microg.study.demo import run_demo
    from microg.study.protocol import load_protocol

    from .studies import simulate_trials

    participants = 4 if quick else 30
    protocol = load_protocol(protocol_file("paper"))
    simulate_trials(protocol, 1, seed + 1, workers=workers)  # compiled once, off the clock, as a first run would
    rows = []
    wall, cpu = time.perf_counter(), _cpu()
    trials = simulate_trials(protocol, participants // 2, seed, workers=workers)
    wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    rows.append({"mode": "in_silico", "participants": participants, "tasks": len(trials), "workers": workers,
                 "wall_s": wall, "cpu_s": cpu, "target_s": TARGET_S if participants == 30 else None,
                 "met": (wall <= TARGET_S) if participants == 30 else None})
    with tempfile.TemporaryDirectory(prefix="microg-bench-insilico-") as folder:
        wall, cpu = time.perf_counter(), _cpu()
        result = run_demo(Path(folder) / "demo", participants, seed, "paper", jobs=workers, progress=False)
        wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    rows.append({"mode": "logged_demo", "participants": participants, "tasks": result.tasks, "workers": workers,
                 "wall_s": wall, "cpu_s": cpu, "target_s": None, "met": None})
    table = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "insilico.csv", index=False)
    return table
