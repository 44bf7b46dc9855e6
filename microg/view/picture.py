"""Pictures for reports and papers: an image strip of a logged task's key moments (like the paper's
Figs. 7 and 9) and a short animation, drawn headless by pybullet's CPU renderer (TinyRenderer: no
display, no GPU). The strip is laid out with matplotlib, so it can be PNG, PDF or SVG, with each
panel's heads-up display as text under it.

The same drawing compares runs of one scene that no study logged (``microg sim gallery``: a
scripted demo under each interaction model, its frames made by ``scene.world_scene``): a strip with
a row per run, and an animation with the runs side by side.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from microg.skeleton import MIN_PHALANX_LENGTH

from .scene import PALETTE, TRACKED_THINNER, Camera, Capsules, FrameScene, TaskLayout, bone_colours, hud_lines, \
    ring_mesh, z_to_direction
from .track import KeyMoment, Track

STRIP_FORMATS = (".png", ".pdf", ".svg")
ANIMATION_FORMATS = (".gif", ".webp")
TRACKED_FADE = 0.55
"""The tracked hand, when drawn with the rendered one, is its colour blended this far toward white
(the CPU renderer has no transparency)."""
PANEL_FRAME = "0.35"
"""Grey of the line around each panel of a strip."""
CENTRE_DOT = 0.005
"""Radius (m) of the dot at each place's centre."""
QUARTER_TURN_ABOUT_Y = (0.0, np.sqrt(0.5), 0.0, np.sqrt(0.5))
"""(x, y, z, w): the second of a zone's crossed rings (a send's target, a handover's place), facing x."""
LETTERS = "abcdefghijklmnopqrstuvwxyz"
"""The panels' letters, as in the paper's figures: (a), (b), ..."""


def _rgba(colour, fade: float = 0.0) -> list[float]:
    rgb = np.asarray(colour, dtype=float) / 255.0
    return list(rgb + fade * (1.0 - rgb)) + [1.0]


def _xyzw(wxyz) -> list[float]:
    w, x, y, z = (float(v) for v in wxyz)
    return [x, y, z, w]


@contextlib.contextmanager
def _quiet_stderr():
    """Send what C code writes on standard error to /dev/null: pybullet announces its build time
    when imported, which would land in the middle of the command's output."""
    sys.stderr.flush()
    saved, null = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 2)
    try:
        yield
    finally:
        ctypes.CDLL(None).fflush(None)
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


class Renderer:
    """A pybullet client in DIRECT mode (no window) that draws one ``FrameScene`` at a time."""

    def __init__(self, layout: TaskLayout, camera: Camera, size: tuple[int, int] = (640, 480)):
        with _quiet_stderr():
            import pybullet

            self.client = pybullet.connect(pybullet.DIRECT)
        self.pb = pybullet
        self.layout, self.camera, self.size = layout, camera, size
        self.ring = ring_mesh(layout.place_radius)
        self.target_ring = ring_mesh(layout.target_radius) if layout.target is not None else None
        width, height = size
        self.view = pybullet.computeViewMatrix(list(camera.eye), list(camera.target), [0, 1, 0])
        self.projection = pybullet.computeProjectionMatrixFOV(camera.fov_deg, width / height, 0.01, 10.0)

    def close(self) -> None:
        self.pb.disconnect(self.client)

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def _body(self, shape: int, rgba: list[float], position, orientation=(0.0, 0.0, 0.0, 1.0), **options) -> None:
        visual = self.pb.createVisualShape(shape, rgbaColor=rgba, physicsClientId=self.client, **options)
        self.pb.createMultiBody(baseMass=0, baseVisualShapeIndex=visual, basePosition=list(position),
                                baseOrientation=list(orientation), physicsClientId=self.client)

    def _capsules(self, capsules: Capsules, colours: np.ndarray, fade: float = 0.0, thinner: float = 1.0) -> None:
        drawn = capsules.drawn
        turns = z_to_direction(capsules.end - capsules.start)
        for k in np.flatnonzero(drawn):
            length = float(np.linalg.norm(capsules.end[k] - capsules.start[k]))
            rgba = _rgba(colours[k], fade)
            radius = float(capsules.radius[k]) * thinner
            if length < MIN_PHALANX_LENGTH:
                self._body(self.pb.GEOM_SPHERE, rgba, capsules.centre[k], radius=radius)
            else:
                self._body(self.pb.GEOM_CAPSULE, rgba, capsules.centre[k], _xyzw(turns[k]), radius=radius,
                           length=length)

    def draw(self, scene: FrameScene, hands: str = "rendered") -> np.ndarray:
        """The frame as an (H, W, 3) uint8 image; ``hands``: rendered, tracked or both."""
        pb, layout = self.pb, self.layout
        pb.resetSimulation(physicsClientId=self.client)
        if layout.table_height is not None:
            centre = layout.table_centre - [0.0, layout.table_size[1] / 2, 0.0]
            self._body(pb.GEOM_BOX, _rgba(PALETTE["table"]), centre, halfExtents=list(layout.table_size / 2))
        if layout.surface is not None:
            vertices, faces = layout.surface
            self._body(pb.GEOM_MESH, _rgba(PALETTE["object"]), scene.object_position, _xyzw(scene.object_orientation),
                       vertices=vertices.tolist(), indices=faces.ravel().tolist())
        elif layout.shape == "sphere":
            self._body(pb.GEOM_SPHERE, _rgba(PALETTE["object"]), scene.object_position, radius=layout.size[0] / 2)
        else:
            self._body(pb.GEOM_BOX, _rgba(PALETTE["object"]), scene.object_position,
                       _xyzw(scene.object_orientation), halfExtents=list(layout.size / 2))
        vertices, faces = self.ring
        for place, state in zip(layout.places, scene.places):
            rgba = _rgba(PALETTE[state])
            self._body(pb.GEOM_MESH, rgba, place, vertices=vertices.tolist(), indices=faces.ravel().tolist())
            self._body(pb.GEOM_SPHERE, rgba, place, radius=CENTRE_DOT)
        if self.target_ring is not None:
            vertices, faces = self.target_ring
            rgba = _rgba(PALETTE["target"])
            for turn in ((0.0, 0.0, 0.0, 1.0), QUARTER_TURN_ABOUT_Y):
                self._body(pb.GEOM_MESH, rgba, layout.target, turn, vertices=vertices.tolist(),
                           indices=faces.ravel().tolist())
            self._body(pb.GEOM_SPHERE, rgba, layout.target, radius=CENTRE_DOT)
        if hands in ("tracked", "both"):
            both = hands == "both"
            self._capsules(scene.tracked, bone_colours(np.zeros_like(scene.touching), "tracked"),
                           TRACKED_FADE if both else 0.0, TRACKED_THINNER if both else 1.0)
        if hands in ("rendered", "both"):
            self._capsules(scene.rendered, bone_colours(scene.touching, "rendered"))
        width, height = self.size
        _, _, rgba, _, _ = pb.getCameraImage(width, height, self.view, self.projection, renderer=pb.ER_TINY_RENDERER,
                                             shadow=1, lightDirection=[0.4, 1.0, 0.6], physicsClientId=self.client)
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]


def _title(track: Track) -> str:
    run = track.run
    result = f"{run.time_s:.1f} s" if run.status == "completed" else run.status
    return (f"{run.participant}, task {run.task_index}: {run.phase}, {run.object} ({run.object_code}), "
            f"{run.interaction}: {result}, {run.attempts if run.attempts is not None else 0} attempts")


def write_strip(track: Track, layout: TaskLayout, *, camera: Camera, moments: list[KeyMoment], out: Path,
                hands: str = "rendered", size: tuple[int, int] = (480, 360), title: bool = True) -> Path:
    """An image strip, one panel per moment, each with its label above and the heads-up display
    (stage, task timer, place timer, attempts) under it."""
    out = _format(out, STRIP_FORMATS, "an image strip")
    if not moments:
        raise ValueError(f"run {track.run.id} has no frames to draw")
    n_places = len(layout.places)
    scenes = [track.scene(m.index, n_places) for m in moments]
    with Renderer(layout, camera, size) as renderer:
        images = [renderer.draw(scene, hands) for scene in scenes]
    panels = [Panel(image, f"({letter}) {moment.label}", hud_lines(scene, layout))
              for letter, image, moment, scene in zip(LETTERS, images, moments, scenes)]
    return _save_panels([panels], [""], out=out, size=size, title=_title(track) if title else None)


def write_comparison_strip(runs: Mapping[str, Sequence[FrameScene]], labels: Sequence[str], *, layout: TaskLayout,
                           camera: Camera, out: Path, hands: str = "rendered", size: tuple[int, int] = (320, 240),
                           title: str | None = None) -> Path:
    """Runs of one scene side by side, as the paper's Fig. 7 compares its model with CLAP: a row per
    run (named at its left), a column per moment (``labels``: each run has one scene per label), each
    panel captioned with its time and whether the object is held (``world_lines``)."""
    out = _format(out, STRIP_FORMATS, "an image strip")
    if not runs or any(len(scenes) != len(labels) for scenes in runs.values()):
        raise ValueError(f"each run needs one scene per moment ({len(labels)}: {', '.join(labels)})")
    with Renderer(layout, camera, size) as renderer:
        rows = [[Panel(renderer.draw(scene, hands), f"({letter}) {label}", world_lines(scene))
                 for letter, label, scene in zip(LETTERS, labels, scenes)] for scenes in runs.values()]
    return _save_panels(rows, list(runs), out=out, size=size, title=title)


def world_lines(scene: FrameScene) -> list[str]:
    """The caption of a scene without a task: its time and whether the object is held."""
    return [f"{scene.t:.2f} s · {'held' if scene.held else 'not held'}"]


@dataclass(frozen=True, eq=False)
class Panel:
    """One picture of a strip: the image, the label above it, the lines of text under it."""

    image: np.ndarray
    label: str
    lines: list[str]


def _format(out: Path, formats: tuple[str, ...], what: str) -> Path:
    out = Path(out)
    if out.suffix.lower() not in formats:
        raise ValueError(f"--out {out}: {what} is {', '.join(formats)}")
    return out


def _save_panels(rows: list[list[Panel]], row_labels: list[str], *, out: Path, size: tuple[int, int],
                 title: str | None) -> Path:
    """Lay the panels out in rows, each framed in grey, and save the figure."""
    from matplotlib.figure import Figure

    columns = max(len(row) for row in rows)
    aspect = size[1] / size[0]
    lines = max(len(panel.lines) for row in rows for panel in row)
    height = len(rows) * (2.4 * aspect + 0.35 + 0.15 * lines) + (0.3 if title else 0.0)
    figure = Figure(figsize=(2.4 * columns, height), layout="constrained")
    axes = figure.subplots(len(rows), columns, squeeze=False)
    for row, label, row_axes in zip(rows, row_labels, axes):
        for panel, ax in zip(row, row_axes):
            ax.imshow(panel.image)
            ax.set_xticks([])
            ax.set_yticks([])
            for spine in ax.spines.values():
                spine.set_color(PANEL_FRAME)
            ax.set_title(panel.label, fontsize=9)
            ax.text(0.5, -0.04, "\n".join(panel.lines), transform=ax.transAxes, ha="center", va="top", fontsize=7,
                    linespacing=1.4)
        row_axes[0].set_ylabel(label, fontsize=9)
        for ax in row_axes[len(row):]:
            ax.set_visible(False)
    if title:
        figure.suptitle(title, fontsize=9)
    figure.savefig(out, dpi=200, bbox_inches="tight")
    return out


def write_animation(track: Track, layout: TaskLayout, *, camera: Camera, out: Path, hands: str = "rendered",
                    size: tuple[int, int] = (480, 360), fps: float = 15.0, speed: float = 1.0,
                    progress: bool = True) -> Path:
    """The run as an animated GIF or WebP at ``speed`` times real time, the heads-up display in a
    band under the scene."""
    from tqdm import tqdm

    out = _format(out, ANIMATION_FORMATS, "an animation")
    if fps <= 0 or speed <= 0:
        raise ValueError(f"fps = {fps}, speed = {speed}: both must be positive")
    if not len(track.frames):
        raise ValueError(f"run {track.run.id} has no frames to draw")
    n_places = len(layout.places)
    times = np.arange(0.0, track.duration + 1e-9, speed / fps)
    pictures = []
    with Renderer(layout, camera, size) as renderer:
        for t in tqdm(times, unit="frame", desc=out.name, disable=not progress):
            scene = track.scene(track.index_at(float(t)), n_places)
            pictures.append(_captioned(renderer.draw(scene, hands), hud_lines(scene, layout)))
    return _save_animation(pictures, out, fps)


def write_comparison_animation(runs: Mapping[str, Sequence[FrameScene]], layout: TaskLayout, *, camera: Camera,
                               out: Path, hands: str = "rendered", size: tuple[int, int] = (320, 240),
                               fps: float = 15.0) -> Path:
    """Runs of one scene side by side in one animation (GIF or WebP): frame i shows scene i of every
    run, each named above and captioned under (``world_lines``); the runs' scenes are ``1 / fps``
    seconds apart."""
    out = _format(out, ANIMATION_FORMATS, "an animation")
    if fps <= 0:
        raise ValueError(f"fps = {fps}: must be positive")
    counts = {len(scenes) for scenes in runs.values()}
    if len(counts) != 1 or not counts.pop():
        raise ValueError("the runs of a comparison need the same number of scenes, at least one")
    pictures = []
    with Renderer(layout, camera, size) as renderer:
        for moment in zip(*runs.values()):
            panels = [_captioned(renderer.draw(scene, hands), world_lines(scene), heading=name)
                      for name, scene in zip(runs, moment)]
            pictures.append(_side_by_side(panels))
    return _save_animation(pictures, out, fps)


def _font(size: tuple[int, int]):
    from PIL import ImageFont

    return ImageFont.load_default(size=max(10, size[1] // 26))


def _captioned(image: np.ndarray, lines: list[str], heading: str | None = None):
    """The image with ``lines`` in a white band under it (and ``heading`` in one over it)."""
    from PIL import Image, ImageDraw

    height, width = image.shape[:2]
    font = _font((width, height))
    line = font.size + 4
    top = line + 8 if heading else 0
    band = len(lines) * line + 8
    picture = Image.new("RGB", (width, top + height + band), "white")
    picture.paste(Image.fromarray(image), (0, top))
    draw = ImageDraw.Draw(picture)
    if heading:
        draw.text((8, 4), heading, fill="black", font=font)
    draw.multiline_text((8, top + height + 6), "\n".join(lines), fill="black", font=font, spacing=4)
    return picture


def _side_by_side(pictures):
    """One picture of the given ones in a row."""
    from PIL import Image

    row = Image.new("RGB", (sum(p.width for p in pictures), max(p.height for p in pictures)), "white")
    x = 0
    for picture in pictures:
        row.paste(picture, (x, 0))
        x += picture.width
    return row


def _save_animation(pictures, out: Path, fps: float) -> Path:
    pictures[0].save(out, save_all=True, append_images=pictures[1:], duration=round(1000 / fps), loop=0)
    return out
