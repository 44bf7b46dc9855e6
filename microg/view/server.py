"""The browser view: a viser server on localhost that draws a session's task runs, live or replayed.

One loop (``View.tick``) moves the playback cursor and draws the frame under it; another duty of
the same loop (``View.poll``) reads what the session committed since the last poll. A live view
is a replay that follows the newest frame of the newest run (``Playback.follow``): pausing or
seeking leaves the live edge, the "follow live" box goes back to it.

The time slider is both the cursor's display and a control, so its value is only ever changed on
viser's event loop: the loop sets a page's seek and the view takes it there at once (``seeks``),
and the tick hands its own updates to the loop. Read later from another thread, a seek could
already have been overwritten by the next tick's cursor.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import io
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from microg.skeleton import SLOTS
from microg.study.session import handling_stop_signals
from microg.study.store import SessionRecord, Store, StoreError

from .pageserver import Stopping
from .scene import HAND_MODES, PALETTE, TRACKED_OPACITY, TRACKED_THINNER, Capsules, FrameScene, TaskLayout, \
    bone_colours, default_camera, hud_lines, ring_mesh, task_layout, z_to_direction
from .track import RunInfo, Track, find_run, find_session, open_readonly, read_track, session_runs

HOST = "127.0.0.1"
"""The view is served on this machine only."""
SPEEDS = ("0.25x", "0.5x", "1x", "2x", "4x")
FRAME_INTERVAL = 1 / 30
"""Seconds between drawn frames."""
POLL_INTERVAL = 0.25
"""Seconds between reads of the database."""
BROWSER_ASPECT = 1.0
"""Width / height of the scene the default camera frames: a browser window less the control panel."""
LEAP_DEVICE = (0.08, 0.011, 0.03)
"""Size (m) of the box drawn at the origin: the tracker, whose frame the scene is in."""


@dataclass
class Playback:
    """Where the view is in the current run, and how it moves."""

    seconds: float = 0.0
    """Cursor: seconds after the run's first frame."""
    playing: bool = False
    speed: float = 1.0
    follow: bool = False
    """Stay on the newest frame of the newest run (a live session)."""

    def advance(self, elapsed: float, duration: float) -> None:
        """Move the cursor by ``elapsed`` wall seconds; playing stops at the end of the run."""
        if self.follow:
            self.seconds = duration
        elif self.playing:
            self.seconds = min(self.seconds + elapsed * self.speed, duration)
            self.playing = self.seconds < duration


def _unit_meshes():
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    cylinder = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=16)
    return (np.asarray(sphere.vertices), np.asarray(sphere.faces)), (np.asarray(cylinder.vertices),
                                                                       np.asarray(cylinder.faces))


def _linear(colours: np.ndarray) -> np.ndarray:
    """sRGB colours (0-255) as the linear values viser's batched meshes take per instance, so a
    hand looks the colour that a single mesh of the same colour would."""
    srgb = np.asarray(colours, dtype=np.float64) / 255.0
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


class HandLayer:
    """One hand drawing (tracked or rendered) as batched meshes: a cylinder per bone and a sphere
    at each bone's ends; bones not drawn get scale zero."""

    def __init__(self, server, name: str, opacity: float | None):
        (sphere_v, sphere_f), (cylinder_v, cylinder_f) = _unit_meshes()
        n = SLOTS
        identity = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        self.bones = server.scene.add_batched_meshes_simple(
            f"/hands/{name}/bones", cylinder_v, cylinder_f, identity, np.zeros((n, 3)),
            batched_scales=np.zeros((n, 3)), opacity=opacity, lod="off", cast_shadow=False)
        self.ends = server.scene.add_batched_meshes_simple(
            f"/hands/{name}/ends", sphere_v, sphere_f, np.tile(identity, (2, 1)), np.zeros((2 * n, 3)),
            batched_scales=np.zeros(2 * n), opacity=opacity, lod="off", cast_shadow=False)

    def draw(self, capsules: Capsules, colours: np.ndarray, thinner: float = 1.0) -> None:
        drawn = capsules.drawn
        start = np.where(drawn[:, None], capsules.start, 0.0)
        end = np.where(drawn[:, None], capsules.end, 0.0)
        radius = np.where(drawn, capsules.radius, 0.0) * thinner
        length = np.linalg.norm(end - start, axis=1)
        self.bones.batched_positions = 0.5 * (start + end)
        self.bones.batched_wxyzs = z_to_direction(end - start)
        self.bones.batched_scales = np.column_stack([radius, radius, length])
        self.bones.batched_colors = _linear(colours)
        self.ends.batched_positions = np.vstack([start, end])
        self.ends.batched_scales = np.concatenate([radius, radius])
        self.ends.batched_colors = _linear(np.vstack([colours, colours]))

    @property
    def visible(self) -> bool:
        return self.bones.visible

    @visible.setter
    def visible(self, value: bool) -> None:
        self.bones.visible = self.ends.visible = value


class SceneDrawer:
    """The 3D scene of a task: tracker, table, object, place rings or a send's or a handover's zone, the two
    hands."""

    def __init__(self, server):
        self.server = server
        self.layout: TaskLayout | None = None
        self.object = None
        self.places: list = []
        self.fixed: list = []
        server.scene.add_box("/tracker", color=(40, 40, 45), dimensions=LEAP_DEVICE, position=(0.0, 0.0, 0.0))
        self.tracked = HandLayer(server, "tracked", TRACKED_OPACITY)
        self.rendered = HandLayer(server, "rendered", None)

    def set_layout(self, layout: TaskLayout) -> None:
        """Rebuild what differs between tasks: the object, the places or the zone, the table."""
        for handle in [self.object, *self.places, *self.fixed]:
            if handle is not None:
                handle.remove()
        scene = self.server.scene
        self.layout, self.places, self.fixed = layout, [], []
        if layout.surface is not None:
            self.object = scene.add_mesh_simple("/object", *layout.surface, color=PALETTE["object"])
        elif layout.shape == "sphere":
            self.object = scene.add_icosphere("/object", radius=float(layout.size[0] / 2), color=PALETTE["object"])
        else:
            self.object = scene.add_box("/object", color=PALETTE["object"], dimensions=tuple(layout.size))
        vertices, faces = ring_mesh(layout.place_radius)
        for k, place in enumerate(layout.places):
            self.places.append(scene.add_mesh_simple(f"/places/{k}/ring", vertices, faces, color=PALETTE["pending"],
                                                     position=tuple(place), cast_shadow=False))
            self.places.append(scene.add_icosphere(f"/places/{k}/centre", radius=0.005, color=PALETTE["pending"],
                                                   position=tuple(place), cast_shadow=False))
        if layout.target is not None:
            vertices, faces = ring_mesh(layout.target_radius)
            for name, turn in (("front", (1.0, 0.0, 0.0, 0.0)), ("side", (np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0))):
                self.fixed.append(scene.add_mesh_simple(f"/target/{name}", vertices, faces, color=PALETTE["target"],
                                                        position=tuple(layout.target), wxyz=turn, cast_shadow=False))
        if layout.table_height is not None:
            self.fixed.append(scene.add_box("/table", color=PALETTE["table"], dimensions=tuple(layout.table_size),
                                            position=tuple(layout.table_centre - [0.0, layout.table_size[1] / 2, 0.0])))

    def draw(self, scene: FrameScene, hands: str) -> None:
        self.object.position = tuple(scene.object_position)
        self.object.wxyz = tuple(scene.object_orientation)
        for k, state in enumerate(scene.places):
            self.places[2 * k].color = self.places[2 * k + 1].color = PALETTE[state]
        self.tracked.visible = hands in ("tracked", "both")
        self.rendered.visible = hands in ("rendered", "both")
        if self.tracked.visible:
            self.tracked.draw(scene.tracked, bone_colours(np.zeros_like(scene.touching), "tracked"),
                              TRACKED_THINNER if hands == "both" else 1.0)
        if self.rendered.visible:
            self.rendered.draw(scene.rendered, bone_colours(scene.touching, "rendered"))


def foreign(headers, port: int) -> str | None:
    """Why a WebSocket handshake (its request ``headers``) does not come from the view's own page
    on ``port``, or None: the Host must be this machine's address, the Origin the view's own."""
    own = {f"{HOST}:{port}", f"localhost:{port}"}
    hosts, origins = headers.get_all("Host"), headers.get_all("Origin")
    if len(hosts) != 1 or hosts[0] not in own:
        return f"Host {', '.join(hosts) or None!r}"
    if len(origins) != 1 or origins[0] not in {f"http://{address}" for address in own}:
        return f"Origin {', '.join(origins) or None!r}"
    return None


def _refuse_foreign_pages(server) -> None:
    """Close every WebSocket that another page opened (a page of another site open in the same
    browser could otherwise read participant ids and trajectories), before the view sends it anything.

    viser has no Origin option, but its connection server runs each connect callback, in order,
    before it starts sending to the client (``viser.infra.WebsockServer``); the last one registered
    here sees the handshake's headers and closes a foreign connection with 1008 (policy violation).
    Connections made before the callback was registered are swept the same way: the view has drawn
    nothing yet."""
    websock = server._websock_server

    async def refuse(client) -> None:
        connection = websock._live_connections.get(client.client_id)
        if connection is None:
            return
        why = foreign(connection.request.headers, connection.local_address[1])
        if why is not None:
            await connection.close(1008, f"{why} is not this view's page")

    websock.on_client_connect(refuse)
    for connection in tuple(websock._live_connections.values()):
        if foreign(connection.request.headers, connection.local_address[1]) is not None:
            asyncio.run_coroutine_threadsafe(connection.close(1008, "not this view's page"),
                                             websock._background_event_loop)


class View:
    """A session's view: the viser server, its controls, and what it shows."""

    def __init__(self, store: Store, session: SessionRecord | None, spec: str | None, *, port: int,
                 hands: str = "rendered"):
        import viser

        self.store, self.spec = store, spec
        self.session: SessionRecord | None = None
        self.lock = threading.RLock()
        self.playback = Playback()
        self.runs: list[RunInfo] = []
        self.track: Track | None = None
        self.layout: TaskLayout | None = None
        self.hands = hands
        self.seeks: collections.deque[float] = collections.deque(maxlen=1)
        """The newest time the page's slider asked for (put on viser's event loop), until the next tick
        moves there (a deque's append and pop are atomic across threads)."""
        with contextlib.redirect_stdout(io.StringIO()):  # viser's banner; ``serve`` says where the view is
            self.server = viser.ViserServer(host=HOST, port=port, label="microg view", verbose=False)
        _refuse_foreign_pages(self.server)
        self.server.request_share_url = lambda *args, **kwargs: None  # never tunnel the view off this machine
        self.server.gui.configure_theme(show_share_button=False, control_width="medium")
        self.server.scene.set_up_direction("+y")
        self.server.scene.configure_environment_map("city", environment_intensity=0.5)
        self.server.scene.configure_default_lights(cast_shadow=False)
        self.drawer = SceneDrawer(self.server)
        self._build_controls()
        if session is not None:
            self._show_session(session)
        self._last_poll = 0.0
        self.poll()

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.server.get_port()}"

    def close(self) -> None:
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()

    # ------------------------------------------------------------ controls

    def _build_controls(self) -> None:
        gui = self.server.gui
        self.hud = gui.add_markdown("")
        self.run_choice = gui.add_dropdown("Task run", ("(none yet)",))
        self.follow_box = gui.add_checkbox("Follow live", False, hint="Stay on the newest frame of a running session")
        self.play_button = gui.add_button("Play", icon=None)
        self.speed_choice = gui.add_dropdown("Speed", SPEEDS, initial_value="1x")
        self.time_slider = gui.add_slider("Time (s)", min=0.0, max=1.0, step=0.01, initial_value=0.0)
        self.hands_choice = gui.add_dropdown("Hands", HAND_MODES, initial_value=self.hands,
                                             hint="rendered: the god-object hand; both: the tracked one faint")

        @self.run_choice.on_update
        def _(event) -> None:
            if event.client_id is not None:
                with self.lock:
                    chosen = next((r for r in self.runs if r.title == self.run_choice.value), None)
                    if chosen is not None:
                        self.playback.follow = False
                        self.follow_box.value = False
                        self.select_run(chosen, 0.0)

        @self.follow_box.on_update
        def _(event) -> None:
            if event.client_id is not None:
                with self.lock:
                    self.playback.follow = self.follow_box.value
                    if self.playback.follow and self.runs and self.track and self.runs[-1].id != self.track.run.id:
                        self.select_run(self.runs[-1], 0.0)

        @self.play_button.on_click
        def _(event) -> None:
            with self.lock:
                playing = not self.playback.playing
                if playing and self.track and self.playback.seconds >= self.track.duration:
                    self.playback.seconds = 0.0
                self.playback.playing, self.playback.follow = playing, False
                self.follow_box.value = False

        @self.speed_choice.on_update
        def _(event) -> None:
            with self.lock:
                self.playback.speed = float(self.speed_choice.value.rstrip("x"))

        @self.time_slider.on_update
        async def _(event) -> None:  # on viser's event loop, right after it took the page's value
            if event.client_id is not None:
                self.seeks.append(float(self.time_slider.value))

        @self.hands_choice.on_update
        def _(event) -> None:
            with self.lock:
                self.hands = self.hands_choice.value

    # ------------------------------------------------------------ what is shown

    def select_run(self, run: RunInfo, seconds: float) -> None:
        """Show ``run`` from ``seconds`` after its first frame."""
        previous = (self.track.run.object, self.track.run.phase) if self.track else None
        self.track = read_track(self.store, run)
        if (run.object, run.phase) != previous:
            layout = self.layout = task_layout(self.store.protocol, run.object, run.phase)
            self.drawer.set_layout(layout)
            camera = default_camera(layout, aspect=BROWSER_ASPECT)
            self.server.initial_camera.position = tuple(camera.eye)
            self.server.initial_camera.look_at = tuple(camera.target)
            self.server.initial_camera.fov = float(np.radians(camera.fov_deg))
            for client in self.server.get_clients().values():
                client.camera.position, client.camera.look_at = tuple(camera.eye), tuple(camera.target)
        self.playback.seconds = min(seconds, self.track.duration)
        self.run_choice.value = run.title

    def start_at(self, task_index: int | None, seconds: float | None) -> None:
        """Open paused on task ``task_index`` (its last run), ``seconds`` into it."""
        with self.lock:
            if self.session is None:
                raise StoreError(f"study {self.store.name!r}: no session {self.spec or ''} has started yet; "
                                 "open the view without --task and --at to wait for it")
            if task_index is not None:
                self.select_run(find_run(self.store, self.session, task_index), 0.0)
            self.playback.follow = self.follow_box.value = False
            self.playback.playing = False
            if seconds is not None and self.track is not None:
                self.playback.seconds = min(max(seconds, 0.0), self.track.duration)

    def poll(self) -> None:
        """Read what the session committed since the last poll. A view waiting for its session
        looks for it again; a view of no particular session moves on to a newer running one."""
        with self.lock:
            if self.session is None or (self.spec is None and self.session.status != "running"):
                found = find_session(self.store, self.spec)
                if found is not None and (self.session is None or found.id != self.session.id):
                    self._show_session(found)
            if self.session is None:
                return
            self.session = self.store.session(self.session.id)
            runs = session_runs(self.store, self.session.id)
            if [r.title for r in runs] != [r.title for r in self.runs]:
                self.run_choice.options = tuple(r.title for r in runs) or ("(none yet)",)
            self.runs = runs
            if not runs:
                return
            if self.track is None:
                self.select_run(runs[-1] if self.playback.follow else runs[0], 0.0)
                self.playback.playing = not self.playback.follow
            elif self.playback.follow and runs[-1].id != self.track.run.id:
                self.select_run(runs[-1], 0.0)
            if self.track.run.status == "running":
                self.track.refresh(self.store)

    def _show_session(self, session: SessionRecord) -> None:
        self.session, self.runs, self.track = session, [], None
        self.playback = Playback(follow=session.status == "running", speed=self.playback.speed)
        self.follow_box.value = self.playback.follow

    def tick(self, elapsed: float) -> None:
        """Move the cursor by ``elapsed`` seconds and draw; poll the database when it is time."""
        now = time.monotonic()
        if now - self._last_poll >= POLL_INTERVAL:
            self._last_poll = now
            self.poll()
        with self.lock:
            if self.track is None or not len(self.track.frames):
                self.hud.content = self._waiting_text()
                return
            if self.seeks:
                seek = self.seeks.pop()
                self.playback.seconds, self.playback.follow = min(max(seek, 0.0), self.track.duration), False
                self.follow_box.value = False
            self.playback.advance(elapsed, self.track.duration)
            scene = self.track.scene(self.track.index_at(self.playback.seconds), len(self.layout.places))
            with self.server.atomic():
                self.drawer.draw(scene, self.hands)
                self.hud.content = self._hud(scene)
                self.play_button.label = "Pause" if self.playback.playing else "Play"
            self.server.get_event_loop().call_soon_threadsafe(self._show_cursor, max(self.track.duration, 0.01),
                                                              round(self.playback.seconds, 2))

    def _show_cursor(self, duration: float, seconds: float) -> None:
        """The slider's range and value, on viser's event loop (module docstring)."""
        self.time_slider.max = duration
        self.time_slider.value = seconds

    def _waiting_text(self) -> str:
        if self.session is None:
            return f"**{self.store.name}**: waiting for a session to start ({self.spec or 'any participant'})"
        doing = f"{self.track.run.title}: waiting for its first frames" if self.track else "no task has started yet"
        return f"**{self.session.participant_id}**, session {self.session.id} ({self.session.status}): {doing}"

    def _hud(self, scene: FrameScene) -> str:
        run = self.track.run
        mode = "live" if self.playback.follow and self.session.status == "running" else "replay"
        result = {"completed": f"completed in {run.time_s:.1f} s" if run.time_s is not None else "completed"}.get(
            run.status, run.status)
        lines = hud_lines(scene, self.layout)
        return "\n\n".join([
            f"**{run.participant}** · session {run.session_id} ({self.session.status}) · *{mode}*",
            f"task {run.task_index}: {run.phase}, {run.object} ({run.object_code}), {run.interaction} · {result}",
            f"### {lines[0]}", *lines[1:]])

    def describe(self) -> str:
        """What the view shows, in a line for the terminal."""
        if self.session is None:
            return f"study {self.store.name!r}: no session yet, waiting for one to start"
        mode = "following live" if self.playback.follow else "replaying"
        what = f"{self.track.run.label}" if self.track else "no task started yet"
        return f"{mode} session {self.session.id} of {self.session.participant_id} ({self.session.status}): {what}"


def serve(study_dir: str | Path, *, spec: str | None = None, port: int = 8080, hands: str = "rendered",
          task_index: int | None = None, seconds: float | None = None, announce=print) -> None:
    """Serve the view of ``study_dir`` until Ctrl-C, SIGTERM or SIGHUP (``pageserver.Stopping``); ``announce``
    gets the address and what is shown."""
    if hands not in HAND_MODES:
        raise ValueError(f"hands = {hands!r}: must be one of {HAND_MODES}")
    store = open_readonly(study_dir)
    try:
        for problem in store.problems:
            announce(f"warning: the study is damaged: {problem}")
        session = find_session(store, spec)
        view = View(store, session, spec, port=port, hands=hands)
        try:
            stopping = Stopping()
            with handling_stop_signals(stopping.handle):  # before the announcement: a signal then stops it cleanly
                if task_index is not None or seconds is not None:
                    view.start_at(task_index, seconds)
                announce(f"microg view: open {view.url} in a browser (this machine only)")
                announce(f"  {view.describe()}; Ctrl-C to stop")
                last = time.monotonic()
                while not stopping.wait(FRAME_INTERVAL):
                    now = time.monotonic()
                    view.tick(now - last)
                    last = now
        finally:
            view.close()
    finally:
        store.close()
