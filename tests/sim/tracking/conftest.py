"""Where the shared Leap recordings are: ../shared/data/leap-v2-recordings beside the clone."""

from pathlib import Path

import pytest

REPOSITORY = Path(__file__).resolve().parents[3]
RECORDINGS = REPOSITORY / ".." / "shared" / "data" / "leap-v2-recordings"
FILES = {"grab.json.gz": 374, "pinch.json.gz": 307, "HandSplay-110fps.json.gz": 288, "wave.json.gz": 111}
"""Each shared recording and its frame count (the recordings' README)."""


@pytest.fixture(scope="session")
def recordings() -> Path:
    if not all((RECORDINGS / name).exists() for name in FILES):
        pytest.skip(f"shared Leap recordings not found at {RECORDINGS} (CI places shared/ beside the clone)")
    return RECORDINGS
