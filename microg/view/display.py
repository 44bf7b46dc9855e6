"""The participant's view: a page the session serves itself, fed every frame as the physics computes it.

    with ParticipantDisplay(protocol) as display:          # serves http://127.0.0.1:PORT/
        run_session(..., outputs=Outputs(sinks=(display,)), operator=DisplayOperator(display, operator),
                    rater=DisplayRater(display, on_rejected))

The display is one of the session's frame sinks: the session thread hands each frame's outcome
to ``take`` (never through the database); the
server thread keeps only the newest frame and sends it to each page as soon as the page can take
it, so a slow browser skips frames and never falls behind. A phase with ``added_latency_ms`` (a
factor of the study) has the server hold each of its frames until that much after its physics was
ready (``due``) before it becomes the newest one; the physics and the log go on undelayed, and the
session logs the setting once per task (``display_latency``). Everything else the participant
sees (the instructions, a "get ready" before each task, the completion cue, the questionnaire)
goes out at once, in order, and is repeated to a page that connects late. The page draws the
newest frame at the display's refresh rate (``page/participant.js``), and answers the
questionnaire, syncs its clock, reports when it drew each frame (``latency``) and, in a headset
(``page/xr.js``), anchors the workspace where the participant puts it (``placement``) and streams
the hand joints it tracks (``hands``: ``microg.hands.webxr``).

What the page measures and decides (the clock offset, the placement, the level it draws at:
resolution and antialiasing) goes to ``on_event(kind, data)`` as ``display_clock``,
``display_placement`` and ``display_quality``, with the latency a task's phase adds
(``display_latency``); what the page sends arrives on the server's thread and is handed on from
the thread that drives the display (the session's, whose store connection it may use) at its
next call.

Security (``microg.view.pageserver``, the one server of every page): 127.0.0.1 unless given another
host; then a one-time token (printed with the address), and the page and its WebSocket over TLS
with the ``certificate`` given (``microg.view.tls``): WebXR needs a secure context, which plain HTTP
is on the machine itself only. The WebSocket refuses any Origin but the page's own (its scheme too)
and any Host but the served one, so a web page open elsewhere in the browser cannot read the
session; only the page's own files are served, by name. What the page reports drawing is kept for
the last ``DRAWN_KEPT`` frames only, so a long session (or a page that reports faster) keeps a
bounded memory.
"""

from __future__ import annotations

import asyncio
import collections
import json
import math
import queue
import time
from pathlib import Path

import numpy as np

from microg.skeleton import SIDES, side_slots
from microg.study.protocol import Phase, Protocol, Viewpoint
from microg.study.questionnaire import Answer, Question, RatingError, parse_answer
from microg.study.store import PlannedTask
from microg.task import KINDS, Moments

from .pageserver import PageServer
from .scene import PALETTE, default_camera, rendered_bones, task_layout, HandValues
from .tls import LOCALHOST, Certificate

PAGE = Path(__file__).with_name("page")
"""The page's files: index.html, participant.js, style.css, and vendor/ (three.js, installed by setup)."""
ANSWER_POLL_S = 0.25
"""While waiting for an answer, the display hands on the page's events this often (s)."""
DRAWN_KEPT = 3600
"""Drawn-frame reports kept: the last minute at 60 Hz."""


def now_ms() -> float:
    """The session's clock for the page: wall time in milliseconds (the page syncs to it)."""
    return time.time() * 1e3


class ParticipantDisplay:
    """The page's server (see the module docstring). ``url`` is what the participant opens."""

    def __init__(self, protocol: Protocol, *, host: str = LOCALHOST, port: int = 0, viewpoint: Viewpoint | None = None,
                 hands=None, on_event=None, certificate: Certificate | None = None):
        self.protocol, self.hands, self.on_event = protocol, hands, on_event
        self.viewpoint = protocol.viewpoint if viewpoint is None else viewpoint
        self.server = PageServer("the participant's page", self._connection, host=host, port=port,
                                 certificate=certificate)
        self._frame: str | None = None
        self._frame_version = 0
        self._added_s = 0.0
        """The display latency the current task's phase adds (s)."""
        self._scene_version = 0
        """Counts the tasks' scenes: a frame held for an earlier scene is never shown."""
        self._context: dict[str, str] = {"workspace": self._workspace()}
        """The latest message of each kind a late page needs: workspace, scene, timeline, question."""
        self._events: queue.SimpleQueue[tuple[str, dict]] = queue.SimpleQueue()
        self._answers: queue.Queue[tuple[str, float | None]] = queue.Queue()
        self._asked = 0
        """The number of the question shown (the page answers it by this number)."""
        self.drawn: collections.deque[dict] = collections.deque(maxlen=DRAWN_KEPT)
        """What pages reported drawing, the last ``DRAWN_KEPT`` frames: frame index, when its physics
        was ready, when it was due on the page (a phase's added latency later), when it was drawn (ms),
        the render scale and the drawing buffer's size (px)."""
        self.clock: dict | None = None
        """The page's clock offset from the session's and its spread (ms), once synced."""
        self.placement: list[float] | None = None
        """The headset's anchor: the 4 x 4 matrix (row-major) from the workspace to its XR space."""
        self._clients = 0
        self._outboxes: list[asyncio.Queue] = []
        self._fresh: list[asyncio.Event] = []

    # ------------------------------------------------------------ life

    def __enter__(self) -> ParticipantDisplay:
        self.start()
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def start(self) -> None:
        """Serve the page; ``microg.view.pageserver.PageError`` when its address or port cannot be had."""
        if not (PAGE / "vendor" / "three.module.js").exists():
            raise FileNotFoundError(f"the participant page's three.js is missing from {PAGE / 'vendor'}: "
                                    "install the front-end packages with `make setup` (npm ci)")
        files = {"/" + file.relative_to(PAGE).as_posix(): file for file in PAGE.rglob("*") if file.is_file()}
        self.server.start(files | {"/": PAGE / "index.html"})

    def close(self) -> None:
        self.server.close()

    @property
    def host(self) -> str:
        return self.server.host

    @property
    def port(self) -> int:
        return self.server.port

    @property
    def url(self) -> str:
        return self.server.url

    @property
    def token(self) -> str | None:
        return self.server.token

    @property
    def certificate(self) -> Certificate | None:
        return self.server.certificate

    @property
    def connected(self) -> int:
        """Pages connected now."""
        return self._clients

    # ------------------------------------------------------------ what the session shows

    def deliver_events(self) -> None:
        """Hand what the page measured or decided since the last call to ``on_event`` (see the
        module docstring); the display calls it itself whenever the session shows something."""
        while self.on_event is not None and not self._events.empty():
            self.on_event(*self._events.get())

    def phase(self, phase: Phase) -> None:
        """An orientation or instructions phase: its text, until the next thing is shown."""
        self.deliver_events()
        self._publish("timeline", {"kind": "phase", "phase": phase.name, "text": phase.text.strip()})

    def get_ready(self, task: PlannedTask) -> None:
        """Before a task: the scene of the task, and "get ready"."""
        self.deliver_events()
        layout = task_layout(self.protocol, task.object, task.phase)
        kind = KINDS[layout.kind]
        camera = default_camera(layout, fov_deg=self.viewpoint.fov_deg)
        eye = camera.eye if self.viewpoint.eye is None else np.asarray(self.viewpoint.eye)
        target = camera.target if self.viewpoint.look_at is None else np.asarray(self.viewpoint.look_at)
        self._publish("scene", {
            "task": task.index, "phase": task.phase, "object": task.object, "shape": layout.shape,
            "size": layout.size.tolist(), "start": layout.start.tolist(), "places": layout.places.tolist(),
            "surface": None if layout.surface is None else {"vertices": layout.surface[0].ravel().tolist(),
                                                            "faces": layout.surface[1].ravel().tolist()},
            "place_radius": layout.place_radius, "hold_s": layout.hold_s, "kind": layout.kind,
            "first_hand": None if kind.view.first_hand is None else kind.view.first_hand(self.protocol.task),
            "stages": {stage.name: stage.text for stage in kind.stages},
            "target": None if layout.target is None else {"centre": layout.target.tolist(),
                                                          "radius": layout.target_radius},
            "table": None if layout.table_height is None else {"centre": layout.table_centre.tolist(),
                                                              "size": layout.table_size.tolist()},
            "camera": {"eye": list(map(float, eye)), "target": list(map(float, target)),
                       "fov_deg": self.viewpoint.fov_deg},
            "palette": PALETTE})
        self._frame = None
        self._scene_version += 1
        self._added_s = self.protocol.added_latency_ms(task.phase) / 1e3
        self._publish("timeline", {"kind": "ready", "task": task.index, "object": task.object,
                                   "label": self._label(task)})

    def task_started(self, task: PlannedTask) -> None:
        self.deliver_events()
        if self._added_s:
            self._events.put(("display_latency", {"task": task.index, "phase": task.phase,
                                                  "added_latency_ms": self._added_s * 1e3}))
        self._publish("timeline", {"kind": "task", "task": task.index, "label": self._label(task)})

    def task_finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        """The completion cue."""
        self.deliver_events()
        self._publish("timeline", {"kind": "done", "task": task.index, "status": status, "time_s": time_s})

    def progressed(self, text: str) -> None:
        """How far a participant training to a criterion is, under the last task's cue."""
        self._publish("timeline", {"kind": "progress", "text": text})

    def take(self, moments: Moments) -> None:
        """The newest of a task's frames (``microg.task.Moments``): the rendered hand with its
        highlight, the object, the places, the timers; kept as the newest frame (after the phase's
        added latency: ``due``) and sent to each page as soon as it can take it. With hands from the
        page, ``read`` is when the page read the newest of them (its own clock)."""
        self.deliver_events()
        ready, held_until = now_ms(), time.monotonic() + self._added_s
        record = moments.records[-1]
        frame, after, display = record["hands"], record["after"], moments.display(len(moments) - 1)
        hands = []
        for side in range(len(SIDES)):
            if not frame["present"][side]:
                continue
            points = frame["points"][side]
            values = HandValues(points[1:].reshape(5, 5, 3), frame["widths"][side], points[0],
                                frame["orientation"][side], after["rendered"][side_slots(side)])
            bones = rendered_bones(values)
            drawn = bones.drawn
            hands.append({"side": side, "start": np.round(bones.start[drawn], 5).tolist(),
                          "end": np.round(bones.end[drawn], 5).tolist(),
                          "radius": np.round(bones.radius[drawn], 5).tolist(),
                          "touching": after["touching"][side_slots(side)].astype(bool)[drawn].tolist()})
        t, started = float(frame["t"]), float(record["started"])
        message = {"type": "frame", "i": self._frame_version + 1, "t": t, "ready": ready,
                   "object": np.round(np.concatenate([after["position"], after["orientation"]]), 6).tolist(),
                   "hands": hands, "stage": display.stage, "place": display.place, "lit": display.lit,
                   "place_timer": round(display.timer_s, 3),
                   "task_timer": round(t - started, 3) if not math.isnan(started) else 0.0,
                   "attempts": int(record["attempts"]), "held": bool(record["held"])}
        if self.hands is not None:
            message["read"] = self.hands.last_read
        if self._added_s:
            message["due"] = ready + self._added_s * 1e3
        self._frame_version += 1
        if self._added_s and self.server.loop is not None:
            self.server.call(self.server.loop.call_at, held_until, self._show, json.dumps(message),
                             self._scene_version)
        else:
            self._frame = json.dumps(message)
            self._notify()

    def ask(self, question: Question) -> None:
        """Show one questionnaire item (its answers come from ``next_answer``): its instrument, the
        interaction model it is about, its text, and how it is answered: the points of a rating with
        the anchors that have words, or a choice's choices with how they are shown."""
        self.deliver_events()
        item, instrument = question.item, question.instrument
        response = item.response
        self._asked += 1
        answering = ({"response": "choice", "choices": [[c, instrument.choice_label(c)] for c in item.choices]}
                     if response.kind == "choice" else
                     {"response": "rating", "min": response.low, "max": response.high, "step": response.step,
                      "points": list(response.points), "anchors": [list(a) for a in item.words]})
        self._publish("question", {"kind": "question", "seq": self._asked, "instrument": instrument.id,
                                   "title": instrument.title, "instructions": instrument.instructions,
                                   "administration": question.administration, "interaction": question.interaction,
                                   "item": item.id,
                                   "label": question.label, "question": item.text, "number": question.number,
                                   "count": question.count, **answering})

    def next_answer(self) -> tuple[str, float | None]:
        """Wait for the page's next answer to the question shown: its text (not yet checked) and the
        seconds the page measured from showing the item to the answer (None when it did not say),
        handing on what the page measures meanwhile."""
        while True:
            self.deliver_events()
            try:
                return self._answers.get(timeout=ANSWER_POLL_S)
            except queue.Empty:
                continue

    def answer_rejected(self, message: str) -> None:
        self._send_event({"type": "rejected", "message": message})

    def answer_accepted(self) -> None:
        self._context.pop("question", None)
        self._send_event({"type": "accepted"})

    # ------------------------------------------------------------ plumbing

    def _workspace(self) -> str:
        """What a headset needs to place the workspace before any task: the point the participant's
        palm marks (the table top's centre, or without a table the desk under the workspace, at
        the tracker's height), the table's footprint and the height of the highest place's top
        (for the text above them), in the tracker frame; and whether the session reads its hands
        from the page."""
        layout = task_layout(self.protocol, self.protocol.objects[0].name)
        height = 0.0 if layout.table_height is None else layout.table_height
        mark = [float(layout.table_centre[0]), float(height), float(layout.table_centre[2])]
        top = max(float(layout.places[:, 1].max()) + layout.place_radius, float(layout.start[1]))
        return json.dumps({"type": "workspace", "mark": mark, "top": top,
                           "footprint": [float(layout.table_size[0]), float(layout.table_size[2])],
                           "stream_hands": self.hands is not None})

    def _label(self, task: PlannedTask) -> str:
        label = next((p.label for p in self.protocol.phases if p.name == task.phase), task.phase)
        return f"{label}: {task.object.replace('_', ' ')} ({task.order_position} of " \
               f"{len(self.protocol.objects) if task.phase != 'training' else self.protocol.training.tasks})"

    def _publish(self, kind: str, body: dict) -> None:
        message = json.dumps({"type": kind, **body})
        self._context[kind] = message
        self._send_event(json.loads(message))

    def _send_event(self, body: dict) -> None:
        text = json.dumps(body)
        self.server.call(self._queue_event, text)

    def _queue_event(self, text: str) -> None:
        for outbox in self._outboxes:
            outbox.put_nowait(text)

    def _notify(self) -> None:
        self.server.call(self._wake)

    def _wake(self) -> None:
        for flag in self._fresh:
            flag.set()

    def _show(self, frame: str, scene: int) -> None:
        """A held frame becomes the newest when it is due (the loop's clock is ``time.monotonic``),
        unless the next task's scene is shown by then."""
        if scene == self._scene_version:
            self._frame = frame
            self._wake()

    async def _connection(self, websocket) -> None:
        outbox: asyncio.Queue = asyncio.Queue()
        fresh = asyncio.Event()
        self._outboxes.append(outbox)
        self._fresh.append(fresh)
        self._clients += 1
        for kind in ("workspace", "scene", "timeline", "question"):
            if kind in self._context:
                outbox.put_nowait(self._context[kind])
        if self._frame is not None:
            fresh.set()
        sender = asyncio.create_task(self._send(websocket, outbox, fresh))
        try:
            async for message in websocket:
                self._receive(websocket, message)
        except Exception:  # a page that goes away mid-message is simply gone
            pass
        finally:
            sender.cancel()
            self._outboxes.remove(outbox)
            self._fresh.remove(fresh)
            self._clients -= 1

    async def _send(self, websocket, outbox: asyncio.Queue, fresh: asyncio.Event) -> None:
        """Events in order; then the newest frame (never a backlog of frames)."""
        while True:
            while not outbox.empty():
                await websocket.send(outbox.get_nowait())
            waiting_event = asyncio.ensure_future(outbox.get())
            waiting_frame = asyncio.ensure_future(fresh.wait())
            done, pending = await asyncio.wait({waiting_event, waiting_frame}, return_when=asyncio.FIRST_COMPLETED)
            for future in pending:
                future.cancel()
            if waiting_event in done:
                await websocket.send(waiting_event.result())
            if fresh.is_set():
                fresh.clear()
                if self._frame is not None:
                    await websocket.send(self._frame)

    def _receive(self, websocket, text: str) -> None:
        try:
            message = json.loads(text)
            kind = message["type"]
        except (ValueError, KeyError, TypeError):
            return
        if kind == "ping":
            asyncio.ensure_future(websocket.send(json.dumps({"type": "pong", "t0": message.get("t0"),
                                                             "ts": now_ms()})))
        elif kind == "clock":
            clock = {name: _number(message.get(key)) for name, key in
                     (("offset_ms", "offset"), ("rtt_ms", "rtt"), ("spread_ms", "spread"))}
            if clock["offset_ms"] is not None:
                self.clock = clock
                self._events.put(("display_clock", clock))
        elif kind == "drawn":
            self.drawn.append({"frame": message.get("i"), "t": message.get("t"), "ready_ms": message.get("ready"),
                               "due_ms": message.get("due"), "drawn_ms": message.get("drawn"),
                               "render_scale": _number(message.get("scale")),
                               "render_width": _number(message.get("width")),
                               "render_height": _number(message.get("height"))})
        elif kind == "quality":
            level = {name: _number(message.get(key)) for name, key in (
                ("render_scale", "scale"), ("render_width", "width"), ("render_height", "height"),
                ("refresh_ms", "refresh"), ("gpu_ms", "cost"))}
            if level["render_scale"] is not None:
                self._events.put(("display_quality", {**level, "antialias": message.get("antialias") is True}))
        elif kind == "answer" and "question" in self._context and message.get("seq") == self._asked:
            seconds = _number(message.get("rt"))
            self._answers.put((str(message.get("value", "")), None if seconds is None or seconds < 0 else seconds / 1e3))
        elif kind == "hands" and self.hands is not None:
            self.hands.receive(message, self.clock)
        elif kind == "placement":
            anchor = message.get("anchor")
            values = [_number(v) for v in anchor] if isinstance(anchor, list) and len(anchor) == 16 else [None]
            if None not in values:
                self.placement = values
                self._events.put(("display_placement", {
                    "anchor": values, "mode": str(message.get("mode", "")),
                    "reference_space": str(message.get("space", "")), "hand": str(message.get("hand", ""))}))


def _number(value) -> float | None:
    """A finite number from the page, or None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        return None
    return float(value)


class DisplayOperator:
    """The researcher keeps the terminal (``operator``: start, skip, abort); the participant's page
    shows each phase's text, a "get ready" before each task and a cue when it is done."""

    def __init__(self, display: ParticipantDisplay, operator):
        self.display, self.operator = display, operator

    def present(self, phase: Phase) -> None:
        self.display.phase(phase)
        self.operator.present(phase)

    def ready(self, task: PlannedTask) -> bool:
        self.display.get_ready(task)
        go = self.operator.ready(task)
        if go:
            self.display.task_started(task)
        return go

    def finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        self.display.task_finished(task, status, time_s)
        self.operator.finished(task, status, time_s)

    def progressed(self, text: str) -> None:
        self.display.progressed(text)
        self.operator.progressed(text)


class DisplayRater:
    """The participant answers the questionnaire on the page; answers are checked and stored like
    terminal answers, and a rejected answer is logged (``on_rejected``) and asked again."""

    source = "participant"

    def __init__(self, display: ParticipantDisplay, on_rejected=None):
        self.display, self.on_rejected = display, on_rejected

    def answer(self, question: Question) -> Answer:
        """The page's answer, with the response time the page measured (from showing the item to the
        press that counted), else the one measured here."""
        self.display.ask(question)
        shown = time.monotonic()
        while True:
            text, seconds = self.display.next_answer()
            try:
                value = parse_answer(question, text)
            except RatingError as error:
                self.display.answer_rejected(str(error))
                if self.on_rejected:
                    self.on_rejected(question, text, str(error))
                continue
            return Answer(value, time.monotonic() - shown if seconds is None else seconds)

    def saved(self, question: Question) -> None:
        self.display.answer_accepted()
