"""The compile cache's stamp covers every source file whose kernels can end up in a cached function."""

from __future__ import annotations

import re
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
