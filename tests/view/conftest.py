"""Studies to view: one logged with the scripted pinch (real physics, about a second), and the
means to run a session slowly in another thread while a view reads it."""

from __future__ import annotations

import socket
import threading
from pathlib import Path

import numpy as np
import pytest

from microg.study.assignment import Participant
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import create_study, open_study

from tests.study.conftest import PROTOCOLS, scripted_inputs


def new_study(folder: Path) -> Path:
    """A tiny study (the cube in microgravity) with participant P01 enrolled."""
    with create_study(folder, load_protocol(PROTOCOLS / "tiny.toml"), seed=1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
    return folder


def run_scripted(folder: Path, pace: float = 0.0) -> None:
    """Run P01's session with the scripted pinch; ``pace`` seconds of wall time per frame."""
    inputs = scripted_inputs()
    if pace:
        make = inputs.make

        def paced(plan, seed):
            source = make(plan, seed)
            source.pace = pace
            return source

        inputs.make = paced
    with open_study(folder) as store:
        session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
        run_session(store, session.id, inputs, clock=SimulationClock())


def session_in_background(folder: Path, pace: float) -> threading.Thread:
    """P01's session, started now in another thread (it opens the study itself)."""
    thread = threading.Thread(target=run_scripted, args=(folder, pace), daemon=True)
    thread.start()
    return thread


@pytest.fixture(scope="package")
def logged_study(tmp_path_factory) -> Path:
    """A finished session: the phases stage1 and stage2 with the cube, both completed without a drop."""
    folder = new_study(tmp_path_factory.mktemp("view") / "study")
    run_scripted(folder)
    return folder


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def project(points, camera, width: int, height: int) -> np.ndarray:
    """Pixel (column, row) of world points in a pinhole camera with a vertical field of view,
    y up, looking from ``camera.eye`` at ``camera.target``."""
    forward = camera.target - camera.eye
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.atleast_2d(points) - camera.eye
    x, y, z = d @ right, d @ up, d @ forward
    tangent = np.tan(np.radians(camera.fov_deg) / 2)
    return np.column_stack([width / 2 * (1 + x / (z * tangent * width / height)), height / 2 * (1 - y / (z * tangent))])


HUES = {"object": (15, 40), "lit": (45, 62), "done": (115, 150), "target": (182, 200), "rendered": (205, 232),
        "highlight": (300, 335)}
"""Hue windows (degrees) of the view's palette: object, lit place, done place, a send's target zone,
hand, contact."""


def colour_mask(image: np.ndarray, name: str) -> np.ndarray:
    """Pixels of ``image`` (H, W, 3 uint8) in the hue window of palette colour ``name``, clearly
    coloured (saturated, not dark)."""
    from matplotlib.colors import rgb_to_hsv

    hsv = rgb_to_hsv(image[..., :3] / 255.0)
    low, high = HUES[name]
    return (hsv[..., 0] * 360 >= low) & (hsv[..., 0] * 360 <= high) & (hsv[..., 1] > 0.45) & (hsv[..., 2] > 0.25)


def pixels_near(mask: np.ndarray, centre, radius: float) -> int:
    rows, columns = np.nonzero(mask)
    return int((np.hypot(columns - centre[0], rows - centre[1]) <= radius).sum())
