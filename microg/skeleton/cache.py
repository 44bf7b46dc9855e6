"""Where numba keeps the compiled physics: the user's cache directory, not the source tree.

The kernels and each scene's specialised step are compiled on first use and cached on disk
(``njit(cache=True)``). Numba's default is a ``__pycache__`` beside the sources, which a read-only
installation (a system or container install) cannot write, so every run would compile again.
Compiling ahead of time at install was the other choice; we cache instead because the step is
specialised for the effects a scene names (any of 2^9 compositions, each compiled only when a
scene asks for it), and numba's ahead-of-time compiler is deprecated.

``use_user_cache`` runs when ``microg.skeleton`` (the ground floor every compiled room imports) is
imported, before any kernel is defined: unless the
user set ``NUMBA_CACHE_DIR``, the cache goes to the platform's user cache directory
(``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux, ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%``
on Windows) under ``microg/numba/<stamp>``; if that cannot be written, to the temporary directory.
The stamp is a hash of the sources of every room with compiled code (``COMPILED``: the physics,
the hand vocabulary's jump rule, the hand filter and guard, the simulated participant, the task's
rules and the batched in-silico engine): numba checks a cached function against its
own file only, not against the kernels it calls in other files, so an upgrade (or an edit) that
changed a kernel would otherwise run the old compiled step. A new stamp compiles afresh.

One writer per function: numba's cache is not safe with two processes compiling the same function
at once (both compile it, both write it), which is what a demo's workers did on their first run.
``use_user_cache`` also makes every cached function take a lock file beside its cache index
(``OneWriterCache``): the first process to want a function compiles it while the others wait, then
load what it saved.
"""

from __future__ import annotations

import hashlib
import logging
import os
import sys
import tempfile
from pathlib import Path

import numba
from numba.core import dispatcher, event
from numba.core.caching import FunctionCache

try:
    import fcntl
except ImportError:  # Windows: numba's cache as it is, without the lock
    fcntl = None

log = logging.getLogger(__name__)


def user_cache_dir() -> Path:
    """The platform's per-user cache directory."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


COMPILED = ("hands", "insilico", "participant", "sim", "skeleton", "task")
"""The rooms of ``microg`` that hold compiled kernels (numba), whose sources the stamp covers."""


def source_stamp() -> str:
    """A short hash of every source file of the rooms in ``COMPILED``."""
    digest = hashlib.sha256()
    package = Path(__file__).parents[1]
    for path in sorted(p for room in COMPILED for p in (package / room).glob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            return True
    except OSError:
        return False


class OneWriterCache(FunctionCache):
    """numba's disk cache of one function, compiled by one process at a time.

    ``load_overload`` takes the function's lock (a file beside its index) before it looks in the
    cache; on a miss the lock is kept while this process compiles, and ``save_overload`` lets it go
    once the entry is written (``_Failed`` does if the compile fails). A process that wants the
    function meanwhile waits in ``load_overload`` (and logs that it waits) and then loads that entry.
    Compiles nest along the call graph (a kernel's callees compile while it does), which has no
    cycles, so two processes never wait on each other; the kernel frees a dead process's lock."""

    def __init__(self, py_func):
        super().__init__(py_func)
        self._depth, self._lock_file = 0, None

    def load_overload(self, sig, target_context):
        self._lock()
        try:
            found = super().load_overload(sig, target_context)
        except BaseException:
            self._unlock()
            raise
        if found is not None:
            self._unlock()
        return found

    def save_overload(self, sig, data):
        try:
            super().save_overload(sig, data)
        finally:
            self._unlock()

    def _lock(self) -> None:
        self._depth += 1
        if self._depth > 1 or fcntl is None:
            return  # held already (the same function again, for another signature), or no locks here
        path = self._cache_file._index_path + ".lock"
        try:
            self._impl.locator.ensure_cache_path()
            self._lock_file = open(path, "a")
        except OSError:
            return  # an unwritable cache caches nothing anyway
        try:
            fcntl.flock(self._lock_file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            log.info("waiting for another process compiling %s (%s)", self._name, path)
            fcntl.flock(self._lock_file, fcntl.LOCK_EX)

    def _unlock(self) -> None:
        if self._depth == 0:
            return  # let go already (a compile whose overload numba filed under other types)
        self._depth -= 1
        if self._depth == 0 and self._lock_file is not None:
            self._lock_file.close()  # closing the file releases the lock
            self._lock_file = None


class _Failed(event.Listener):
    """Lets a function's lock go when its compile raises, as numba's typing often makes one do
    while it tries signatures (``save_overload`` never comes then). A compile that raised added no
    overload for its arguments (numba's ``Event.is_failed`` does not tell: it is never true)."""

    def on_start(self, current):
        pass

    def on_end(self, current):
        compiled = current.data.get("dispatcher")
        cache = getattr(compiled, "_cache", None)
        if isinstance(cache, OneWriterCache) and tuple(current.data["args"]) not in compiled.overloads:
            cache._unlock()


def one_writer_per_function() -> None:
    """Make every cached numba function a ``OneWriterCache`` (before any is defined)."""
    if dispatcher.FunctionCache is not OneWriterCache:
        dispatcher.FunctionCache = OneWriterCache
        event.register("numba:compile", _Failed())


def use_user_cache() -> str:
    """Point numba's cache at the user cache directory (module docstring), one writer per function;
    returns the directory used."""
    one_writer_per_function()
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    stamp, user = source_stamp(), os.getuid() if hasattr(os, "getuid") else 0
    for candidate in (user_cache_dir() / "microg" / "numba" / stamp,
                      Path(tempfile.gettempdir()) / f"microg-numba-{user}" / stamp):
        if _writable(candidate):
            numba.config.CACHE_DIR = str(candidate)
            return str(candidate)
    return ""
