"""The compile cache's stamp covers every source file whose kernels can end up in a cached function."""

from __future__ import annotations

import os
import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import microg
from microg.skeleton.cache import COMPILED

PACKAGE = Path(microg.__file__).parent


def test_every_room_with_compiled_kernels_is_stamped():
    """Numba checks a cached kernel against its own file only; a room with kernels outside the stamp
    could run stale machine code after an edit of a kernel it calls."""
    uses_numba = re.compile(r"^(from numba\b|import numba\b)", re.MULTILINE)
    rooms = {path.relative_to(PACKAGE).parts[0] for path in PACKAGE.rglob("*.py")
             if uses_numba.search(path.read_text()) and path.parent != PACKAGE}
    assert rooms and rooms <= set(COMPILED), sorted(rooms - set(COMPILED))


KERNELS = """
from numba import njit


@njit(cache=True)
def triple(x):
    return 3 * x


@njit(cache=True)
def first(x):
    return x[0]
"""

REPORT = """
stats = kernels.triple.stats
print("result", kernels.triple(2), sum(stats.cache_hits.values()), sum(stats.cache_misses.values()), flush=True)
"""

COMPILER = """
import sys
import microg.sim  # numba's cache with one writer per function
from numba.core import event


class Pause(event.Listener):
    def on_start(self, current):
        if current.data["dispatcher"].py_func.__name__ == "triple":
            print("compiling", flush=True)
            sys.stdin.readline()

    def on_end(self, current):
        pass


event.register("numba:compile", Pause())
import kernels
""" + REPORT

LOADER = """
import logging, sys
logging.basicConfig(stream=sys.stdout, level=logging.INFO, format="%(message)s")
import microg.sim
import kernels
""" + REPORT

BOUND = 120.0
"""s: the longest any step of the two-process test may take before it fails."""


class Lines:
    """A subprocess's stdout, line by line, waited on with a bound."""

    def __init__(self, process: subprocess.Popen, name: str):
        self.process, self.name, self.seen, self.queue = process, name, [], queue.Queue()
        threading.Thread(target=lambda: [self.queue.put(line) for line in process.stdout], daemon=True).start()

    def wait_for(self, text: str) -> str:
        deadline = time.monotonic() + BOUND
        while time.monotonic() < deadline:
            try:
                line = self.queue.get(timeout=deadline - time.monotonic())
            except queue.Empty:
                break
            self.seen.append(line)
            if text in line:
                return line
        raise AssertionError(f"{self.name}: no line with {text!r} within {BOUND} s; it printed {self.seen}, "
                             f"stderr {self.process.stderr.read() if self.process.poll() is not None else '(running)'}")


def test_a_second_process_waits_for_the_first_to_compile_a_function_and_loads_it(tmp_path):
    """Two processes want one uncompiled function at once: the first compiles it (held on purpose
    mid-compile here), the second waits for the lock and then loads the first one's entry."""
    (tmp_path / "kernels.py").write_text(KERNELS)
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    start = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True, "env": env}
    first = subprocess.Popen([sys.executable, "-c", COMPILER], stdin=subprocess.PIPE, **start)
    second = None
    try:
        first_lines = Lines(first, "first process")
        first_lines.wait_for("compiling")
        second = subprocess.Popen([sys.executable, "-c", LOADER], **start)
        second_lines = Lines(second, "second process")
        second_lines.wait_for("waiting for another process compiling")
        first.stdin.write("go\n")
        first.stdin.flush()
        assert first_lines.wait_for("result").split() == ["result", "6", "0", "1"]  # compiled it
        assert second_lines.wait_for("result").split() == ["result", "6", "1", "0"]  # loaded it
    finally:
        for process in (first, second):
            if process is not None:
                process.kill()
                process.wait(BOUND)


FAILER = """
import sys
import microg.sim
import kernels
try:
    kernels.first(3)  # an int has no [0]: the compile raises
except Exception as error:
    print("failed", type(error).__name__, flush=True)
sys.stdin.readline()
"""

USER = """
import numpy as np
import microg.sim
import kernels
print("result", kernels.first(np.arange(2.0) + 5), flush=True)
"""


def test_a_compile_that_raises_lets_the_function_go(tmp_path):
    """numba's typing often tries a signature that fails to compile: the lock must not outlive it
    (the second process would wait for ever for a save that never comes)."""
    (tmp_path / "kernels.py").write_text(KERNELS)
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    start = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True, "env": env}
    failer = subprocess.Popen([sys.executable, "-c", FAILER], stdin=subprocess.PIPE, **start)
    user = None
    try:
        Lines(failer, "failing process").wait_for("failed TypingError")
        user = subprocess.Popen([sys.executable, "-c", USER], **start)  # while the failing process lives
        assert Lines(user, "second process").wait_for("result").split() == ["result", "5.0"]
    finally:
        for process in (failer, user):
            if process is not None:
                process.kill()
                process.wait(BOUND)
