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
the hand vocabulary's jump rule, the hand filter and guard, the simulated participant): numba checks a cached function against its
own file only, not against the kernels it calls in other files, so an upgrade (or an edit) that
changed a kernel would otherwise run the old compiled step. A new stamp compiles afresh.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path

import numba


def user_cache_dir() -> Path:
    """The platform's per-user cache directory."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


COMPILED = ("hands", "participant", "sim", "skeleton")
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


def use_user_cache() -> str:
    """Point numba's cache at the user cache directory (module docstring); returns the directory used."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    stamp, user = source_stamp(), os.getuid() if hasattr(os, "getuid") else 0
    for candidate in (user_cache_dir() / "microg" / "numba" / stamp,
                      Path(tempfile.gettempdir()) / f"microg-numba-{user}" / stamp):
        if _writable(candidate):
            numba.config.CACHE_DIR = str(candidate)
            return str(candidate)
    return ""
