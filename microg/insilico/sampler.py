"""pyabc's evaluations on Dask in a fixed order, so that the same seed gives the same posterior
whatever the number of workers, and an interrupted generation keeps what it finished.

pyabc does the inference (proposals, kernels, epsilons, weights); its own ``DaskDistributedSampler``
reseeds every task from the operating system's entropy and accepts whichever evaluations finish
first, so its posterior depends on the workers. ``OrderedDaskSampler`` is a scheduling adapter:
evaluation ``index`` of generation ``t`` runs pyabc's ``simulate_one`` with numpy's global
generator (which pyabc and scipy draw from) seeded from ``SeedSequence([seed, stream, t + 1,
index])``; the generation keeps evaluations 0..k, k being the index of the n-th accepted one,
however many were running beyond it. Each finished evaluation is written to an ``EvaluationCache``
(SQLite) as it arrives, and a resumed generation computes only the missing ones.
"""

from __future__ import annotations

import json
import math
import random
import sqlite3
import threading
import time
from pathlib import Path

import cloudpickle
import numpy as np
from pyabc.parameters import Parameter
from pyabc.population import Particle
from pyabc.sampler import Sampler
from tqdm import tqdm

ABC_STREAM = 0x414243
"""Mixed into every evaluation's seed, so that no other draw of the run shares its stream."""
_ONE_AT_A_TIME = threading.Lock()
"""numpy's global generator is one per process: a worker with several threads evaluates one at a time."""


def seeded_call(function, entropy: list[int]):
    """``function()`` with numpy's and Python's global generators seeded from ``entropy``."""
    with _ONE_AT_A_TIME:
        sequence = np.random.SeedSequence(entropy)
        np.random.seed(sequence.generate_state(8))
        random.seed(int(sequence.generate_state(1)[0]))
        return function()


def pickled_call(function: bytes, entropy: list[int], *arguments):
    """``function(*arguments)`` on a worker, seeded from ``entropy`` (``seeded_call``). The function
    comes pickled with cloudpickle (by value where registered so, as Dask's own pickling may not),
    and is unpickled once per worker and run."""
    if _LOADED[0] is not function:
        _LOADED[:] = [function, cloudpickle.loads(function)]
    loaded = _LOADED[1]
    return seeded_call(lambda: loaded(*arguments), entropy)


_LOADED: list = [None, None]
"""The worker's last function: (its pickled bytes, the function)."""


class EvaluationCache:
    """Finished evaluations, one row per (stage, index), as JSON: a resumed stage reads them back."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.db = sqlite3.connect(self.path, timeout=60)
        self.db.execute("PRAGMA journal_mode = WAL")
        with self.db:
            self.db.execute("CREATE TABLE IF NOT EXISTS evaluations (stage TEXT NOT NULL, idx INTEGER NOT NULL, "
                            "payload TEXT NOT NULL, PRIMARY KEY (stage, idx))")

    def read(self, stage: str) -> dict[int, dict]:
        rows = self.db.execute("SELECT idx, payload FROM evaluations WHERE stage = ?", (stage,)).fetchall()
        return {int(index): json.loads(payload) for index, payload in rows}

    def write(self, stage: str, index: int, payload: dict) -> None:
        with self.db:
            self.db.execute("INSERT OR REPLACE INTO evaluations VALUES (?, ?, ?)", (stage, int(index),
                                                                                    json.dumps(payload)))

    def close(self) -> None:
        self.db.close()


def particle_record(particle: Particle) -> dict:
    """A particle as JSON-ready data (floats written with every digit, so they read back exactly)."""
    return {"m": int(particle.m), "parameter": {k: float(v) for k, v in particle.parameter.items()},
            "weight": float(particle.weight), "sum_stat": {k: float(v) for k, v in particle.sum_stat.items()},
            "distance": float(particle.distance), "accepted": bool(particle.accepted),
            "proposal_id": int(particle.proposal_id)}  # fmt: skip


def particle_from_record(record: dict) -> Particle:
    return Particle(m=record["m"], parameter=Parameter(record["parameter"]), weight=record["weight"],
                    sum_stat=record["sum_stat"], distance=record["distance"], accepted=record["accepted"],
                    proposal_id=record["proposal_id"], preliminary=False)  # fmt: skip


def stage_name(t: int) -> str:
    return "prior" if t < 0 else f"generation {t}"


class OrderedDaskSampler(Sampler):
    """A pyabc ``Sampler`` that evaluates in index order on a Dask client (see the module docstring).

    Parameters
    ----------
    client : distributed.Client
        Where the evaluations run.
    seed : int
        The run's seed.
    cache : EvaluationCache
        Where finished evaluations are kept.
    generations : int
        The run's generations (for the progress display).
    progress : bool
        Show a progress bar per generation: accepted particles, studies done, their rate, time left.
    """

    def __init__(self, client, seed: int, cache: EvaluationCache, generations: int, progress: bool = True):
        super().__init__()
        self.client, self.seed, self.cache = client, int(seed), cache
        self.generations, self.progress = generations, progress
        self.workers_seen = 0
        self.studies_run = 0
        self._asked, self._known = -math.inf, 1

    def sample_until_n_accepted(self, n, simulate_one, t, *, max_eval=np.inf, all_accepted=False, ana_vars=None):
        from distributed import wait

        stage = stage_name(t)
        done = {i: particle_from_record(r) for i, r in self.cache.read(stage).items()}
        function = self.client.scatter(cloudpickle.dumps(simulate_one), broadcast=True)
        running: dict = {}
        next_index = 0
        started = time.monotonic()
        fresh = 0
        label = "prior sample" if t < 0 else f"generation {t + 1}/{self.generations}"
        with tqdm(total=n, desc=label, unit=" accepted", disable=not self.progress, dynamic_ncols=True,
                  bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt}{unit} "
                             "[{elapsed}<{remaining}] {postfix}") as bar:  # fmt: skip
            bar.update(min(n, sum(p.accepted for p in done.values())))
            while (cutoff := _cutoff(done, n)) is None:
                bound = _nth_accepted(done, n)
                window = 2 * self._cores() + 2
                while next_index <= bound and len(running) < window and next_index < max_eval:
                    if next_index not in done:
                        running[self.client.submit(pickled_call, function, self._entropy(t, next_index), pure=False)] \
                            = next_index
                    next_index += 1
                if not running:
                    break
                finished, _ = wait(list(running), return_when="FIRST_COMPLETED")
                for future in finished:
                    index = running.pop(future)
                    particle = future.result()
                    future.release()
                    self.cache.write(stage, index, particle_record(particle))
                    done[index] = particle
                    fresh += 1
                    if particle.accepted and sum(p.accepted for p in done.values()) <= n:
                        bar.update(1)
                rate = fresh / max(time.monotonic() - started, 1e-9)
                bar.set_postfix_str(f"studies {len(done)} ({rate:.2g}/s), workers {self.workers_seen}")
            for future in running:
                future.cancel()
        self.studies_run += fresh
        sample = self._create_empty_sample()
        last = cutoff if cutoff is not None else max(done, default=-1)
        for index in range(last + 1):
            sample.append(done[index])
        if cutoff is None:
            sample.ok = False
        self.nr_evaluations_ = last + 1
        return sample

    def _entropy(self, t: int, index: int) -> list[int]:
        return [self.seed, ABC_STREAM, t + 1, index]

    def _cores(self) -> int:
        """The cluster's cores now (asked at most once a second)."""
        now = time.monotonic()
        if now - self._asked > 1.0:
            self._asked, cores = now, self.client.ncores()
            self._known = max(1, sum(cores.values()))
            self.workers_seen = max(self.workers_seen, len(cores))
        return self._known


def _nth_accepted(done: dict[int, Particle], n: int) -> float:
    """The index of the n-th accepted evaluation among those finished (inf: fewer than n are)."""
    accepted = [index for index in sorted(done) if done[index].accepted]
    return accepted[n - 1] if len(accepted) >= n else math.inf


def _cutoff(done: dict[int, Particle], n: int) -> int | None:
    """The index of the n-th accepted evaluation once every evaluation before it has finished."""
    accepted = 0
    for index in range(max(done, default=-1) + 1):
        if index not in done:
            return None
        accepted += done[index].accepted
        if accepted == n:
            return index
    return None

