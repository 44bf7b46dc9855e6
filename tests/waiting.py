"""Waiting in tests: on an event, never on the clock, and never without a bound.

Every wait ends when what it waits for happens; ``WAIT_S`` only keeps a broken run from hanging
(it is no timing assertion: a loaded machine is far quicker than that), and the failure then says
what was waited for and what was seen instead.
"""

from __future__ import annotations

import queue
import signal
import subprocess
import threading
import time
from typing import Callable

WAIT_S = 120.0
"""Seconds any wait may take before the test fails: generous, against a hang only."""
POLL_S = 0.02


def wait_until(condition: Callable[[], object], what: str, seen: Callable[[], object] | None = None,
               going: Callable[[], bool] | None = None, timeout: float = WAIT_S):
    """``condition()``'s first truthy value, polled; AssertionError naming ``what`` was waited for and
    what ``seen()`` shows, after ``timeout`` s or as soon as ``going()`` says that what would make it
    hold has stopped (a thread or process ended)."""
    deadline = time.monotonic() + timeout
    while not (value := condition()):
        stopped = going is not None and not going()
        if stopped or time.monotonic() > deadline:
            raise AssertionError(f"{'stopped' if stopped else f'waited {timeout:g} s'} while waiting for {what}"
                                 + (f"; saw: {seen()!r}" if seen is not None else ""))
        time.sleep(POLL_S)
    return value


def next_item(items: queue.Queue, what: str, seen: Callable[[], object] | None = None, timeout: float = WAIT_S):
    """The next item of ``items``, or AssertionError naming what was waited for and what ``seen()`` shows."""
    try:
        return items.get(timeout=timeout)
    except queue.Empty:
        raise AssertionError(f"waited {timeout:g} s for {what}"
                             + (f"; saw: {seen()!r}" if seen is not None else "")) from None


def joined(thread: threading.Thread, what: str, timeout: float = WAIT_S) -> None:
    """Wait for ``thread`` to end, or AssertionError naming it."""
    thread.join(timeout)
    if thread.is_alive():
        raise AssertionError(f"waited {timeout:g} s for {what} to end")


def ended(process: subprocess.Popen, what: str, timeout: float = WAIT_S, stacks: bool = False) -> int:
    """``process``'s exit status once it ends; killed, and AssertionError naming it, after ``timeout`` s.
    With ``stacks`` (a child run with ``PYTHONFAULTHANDLER=1`` whose stderr is a pipe nobody else
    reads), it is stopped with SIGABRT first, and the error shows where each of its threads was."""
    try:
        return process.wait(timeout)
    except subprocess.TimeoutExpired:
        if stacks:
            process.send_signal(signal.SIGABRT)  # faulthandler prints every thread's stack, then aborts
            try:
                process.wait(timeout / 4)
            except subprocess.TimeoutExpired:
                pass
        if process.poll() is None:
            process.kill()
            process.wait()
        where = f"; its threads when stopped:\n{process.stderr.read()[-12000:]}" if stacks else ""
        raise AssertionError(f"waited {timeout:g} s for {what} to end; killed it{where}") from None


def line_reader(stream) -> queue.Queue:
    """The lines of ``stream`` (a child's stdout) as they come, in a queue a test can wait on with a
    bound (``next_item``); None once the stream ends."""
    lines: queue.Queue = queue.Queue()

    def read() -> None:
        for line in stream:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    return lines
