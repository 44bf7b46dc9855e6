"""The participant's page address as a QR code (segno), so a headset opens it by looking at it (the
Quest's camera) or a phone by scanning, instead of typing a long address with its token.

``terminal_code(url)`` draws it in the terminal with half blocks, two modules a character (light
modules in the terminal's text colour, for the usual light text on a dark background);
``write_code(url, path)`` writes it as a PNG. Both keep the quiet zone a scanner needs.
"""

from __future__ import annotations

import io
from pathlib import Path

import segno

ERROR_CORRECTION = "m"
"""Medium (15 %): a code shown on a screen and read by a camera at an angle."""
TERMINAL_BORDER = 2
"""Light modules around the code in the terminal (the terminal's own margin adds to it)."""
PNG_SCALE = 10
"""Pixels per module in the PNG."""


def code(url: str) -> segno.QRCode:
    """The QR code (never a Micro QR, which phone cameras do not read) of ``url``."""
    return segno.make(url, error=ERROR_CORRECTION, micro=False)


def terminal_code(url: str) -> str:
    """``url``'s code as lines of text for the terminal."""
    out = io.StringIO()
    code(url).terminal(out=out, compact=True, border=TERMINAL_BORDER)
    return out.getvalue()


def write_code(url: str, path: str | Path) -> Path:
    """Write ``url``'s code into the PNG file ``path`` (its folder must exist); returns the path."""
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"--qr {path}: give a .png file")
    code(url).save(str(path), kind="png", scale=PNG_SCALE, border=4)
    return path
