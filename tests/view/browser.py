"""Screenshots of a page in headless Chromium (Debian's ``chromium`` and ``chromium-driver``),
driven by selenium, WebGL on SwiftShader (no GPU needed).

A page that builds its scene over a websocket is ready when it says so and has stopped changing:
``screenshot`` waits for a text on the page, then until two screenshots in a row are the same.
"""

from __future__ import annotations

import io
import time
from pathlib import Path

import numpy as np
from PIL import Image

from microg.bench.display import chromium as _chromium
from microg.bench.display import missing

MISSING = missing()
"""What the browser tests lack on this machine ("" when they can run)."""


def chromium(size: tuple[int, int] = (1200, 800), flags: tuple[str, ...] = ()):
    """A headless Chromium under selenium with a ``size`` viewport (the benchmark's) and its command-line
    ``flags``; closed on leaving."""
    return _chromium(size, flags)


def page_text(driver) -> str:
    from selenium.webdriver.common.by import By

    return driver.find_element(By.TAG_NAME, "body").text


def open_page(driver, url: str, wait_for: str, timeout_s: float = 60.0) -> None:
    """Load ``url`` and wait until the page shows ``wait_for``."""
    from selenium.webdriver.support.ui import WebDriverWait

    driver.set_page_load_timeout(timeout_s)
    driver.get(url)
    WebDriverWait(driver, timeout_s).until(lambda d: wait_for in page_text(d))


def settled_picture(driver, timeout_s: float = 60.0) -> bytes:
    """A PNG of the page once two screenshots in a row are the same."""
    deadline, previous = time.monotonic() + timeout_s, None
    while True:
        picture = driver.get_screenshot_as_png()
        pixels = np.asarray(Image.open(io.BytesIO(picture)))
        if previous is not None and np.array_equal(pixels, previous):
            return picture
        if time.monotonic() > deadline:
            raise TimeoutError(f"the page kept changing for {timeout_s:g} s")
        previous = pixels
        time.sleep(0.5)


def screenshot(url: str, out: Path, size: tuple[int, int] = (1200, 800), wait_for: str = "",
               dismiss_notices: bool = False, timeout_s: float = 60.0) -> Path:
    """Load ``url`` in a ``size`` viewport; once the page shows ``wait_for`` and its picture has
    settled, save it as a PNG. ``dismiss_notices`` closes pop-up notices first (the view warns
    that WebGL runs without a GPU)."""
    from selenium.webdriver.common.by import By

    with chromium(size) as driver:
        open_page(driver, url, wait_for, timeout_s)
        if dismiss_notices:
            for button in driver.find_elements(By.CSS_SELECTOR, ".mantine-Notification-closeButton"):
                button.click()
        out.write_bytes(settled_picture(driver, timeout_s))
    return out
