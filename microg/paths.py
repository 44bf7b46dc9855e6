"""Where the project's shipped files live: protocols, object definitions, instruments, sample recordings.

They are the repository's top-level ``protocols/`` and ``data/`` folders; an installed package
carries them as ``microg/protocols`` and ``microg/data`` (package data, see pyproject.toml).
"""

from __future__ import annotations

from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


def _shipped(name: str) -> Path:
    inside = PACKAGE / name
    return inside if inside.is_dir() else PACKAGE.parent / name


PROTOCOLS = _shipped("protocols")
OBJECTS = PROTOCOLS / "objects"
POPULATIONS = PROTOCOLS / "populations"
"""Populations of simulated participants (``microg.participant.population``)."""
INSTRUMENTS = PROTOCOLS / "instruments"
"""The shipped questionnaire instruments (``microg.instruments``)."""
DATA = _shipped("data")
LEAP_RECORDINGS = DATA / "leap-v2-recordings"
"""Four real Leap Motion recordings in LeapJS v2 JSON (see the README beside them)."""


def protocol_file(name_or_path: str | Path) -> Path:
    """A protocol file, or the name of a shipped one (``paper``, ``paper-microgravity``)."""
    path = Path(name_or_path)
    if path.exists() or path.suffix == ".toml":
        return path
    return PROTOCOLS / f"{name_or_path}.toml"


def object_file(name: str) -> Path:
    """The shipped object definition called ``name`` (e.g. ``cube``)."""
    path = OBJECTS / f"{name}.toml"
    if not path.exists():
        known = sorted(p.stem for p in OBJECTS.glob("*.toml"))
        raise FileNotFoundError(f"no object file {path} (shipped objects: {known})")
    return path
