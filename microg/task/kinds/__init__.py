"""The task kinds, one module each, and the registry every other part of microg reads.

``KINDS`` maps a kind's name to its ``microg.task.kind.Kind``. A kind defined elsewhere (a study's
own, a test's) joins with ``register``; nothing else in microg names a kind.
"""

from __future__ import annotations

from microg.task.kind import Kind

from . import catch, handover, pick_and_place, send, stop_spin

KINDS: dict[str, Kind] = {}
"""Every kind by its name, the shipped ones first in this order (a frame log's stage codes follow it)."""


def register(kind: Kind) -> Kind:
    """Add ``kind`` to ``KINDS`` (a kind of that name again: replaced, as a reloaded module does)."""
    KINDS[kind.name] = kind
    return kind


for _module in (pick_and_place, catch, stop_spin, send, handover):
    register(_module.KIND)

PICK_AND_PLACE = pick_and_place.KIND.name
"""The paper's kind, the default of every protocol."""
