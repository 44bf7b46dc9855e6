"""The real Leap recordings the project ships in data/leap-v2-recordings."""

from pathlib import Path

import pytest

from microg.paths import LEAP_RECORDINGS

FILES = {"grab.json.gz": 374, "pinch.json.gz": 307, "HandSplay-110fps.json.gz": 288, "wave.json.gz": 111}
"""Each recording and its frame count (the recordings' README)."""


@pytest.fixture(scope="session")
def recordings() -> Path:
    return LEAP_RECORDINGS
