"""Screenshots of a page with headless Chromium (Debian's ``chromium``), WebGL on SwiftShader."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync", "--hide-scrollbars",
         "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def screenshot(url: str, out: Path, size: tuple[int, int] = (1200, 800), settle_ms: int = 8000,
               timeout_s: float = 90.0) -> Path:
    """Load ``url`` and save what it shows after ``settle_ms`` of page time (the page builds its
    scene over a websocket) as a PNG."""
    if CHROMIUM is None:
        raise FileNotFoundError("chromium is not installed (apt-get install chromium)")
    with tempfile.TemporaryDirectory(prefix="microg-chromium-") as profile:
        subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
                        f"--virtual-time-budget={settle_ms}", f"--screenshot={out}", url],
                       check=True, capture_output=True, timeout=timeout_s)
    return out
