"""The researcher's dashboard (``microg dashboard``): the whole study on one page, live while sessions run.

    with open_study("studies/s1", readonly=True, accept_damaged=True) as store, Dashboard(store) as board:
        print(board.url)                         # http://127.0.0.1:PORT/?token=...

It reads the study's store alone, through a read-only connection of its own (``microg.study.overview``:
rows added since the last read, by rowid, and only when another connection committed; a reader in
WAL mode never blocks a session's writes), ``READ_S`` apart on a thread of its own, and pushes the
overview to every page over the WebSocket when it changed. The page (``dashboard_page/``) draws it,
with its charts drawn by Chart.js (installed from the lockfile into ``page/vendor``, never fetched).

The page is served by ``microg.view.pageserver`` like the participant's page: 127.0.0.1 unless
given another host, then over TLS with the study's certificate; Host and Origin checked; and a
one-time token always (the dashboard shows every participant's data, and other users of the
machine reach 127.0.0.1 too), which ``/ws`` and the report (``/report``) ask for.

A page may ask for the view of a session (``{"type": "view", "session": ID}``): on 127.0.0.1 the
dashboard starts ``microg view STUDY --session ID`` (one process per session, reused, stopped with
the dashboard) and answers with its address; off 127.0.0.1 (a phone) the view, which serves this
machine only, cannot be reached, and the answer is the command to run at the lab computer.
"""

from __future__ import annotations

import asyncio
import json
import queue
import re
import socket
import subprocess
import sys
import threading
from datetime import datetime, timezone
from pathlib import Path

from microg.study.overview import Overview
from microg.study.store import Store, StoreError

from .pageserver import PageServer
from .tls import LOCALHOST, Certificate

PAGE = Path(__file__).with_name("dashboard_page")
"""The dashboard's own files: index.html, dashboard.js, dashboard.css."""
VENDOR = Path(__file__).with_name("page") / "vendor"
CHART = "chart.umd.min.js"
"""Chart.js, as the setup installs it beside three.js (scripts/install-web-deps.sh)."""
READ_S = 0.5
"""Seconds between two reads of the store (2 Hz): a batch of frames is committed every half second or so."""
VIEW_START_S = 120.0
"""How long a view's process may take to say where it is before the dashboard gives up on it."""
VIEW_ADDRESS = re.compile(r"microg view: open (http://\S+) ")


class Dashboard:
    """The dashboard of ``store`` (a study opened read-only: ``open_study(..., readonly=True)``, whose
    connection the dashboard's reader thread uses; see the module docstring); ``url`` is what to open."""

    def __init__(self, store: Store, *, host: str = LOCALHOST, port: int = 0, certificate: Certificate | None = None):
        self.store = store
        self.overview = Overview(store)
        self.server = PageServer("the dashboard", self._connection, host=host, port=port, certificate=certificate,
                                 token=True, private=frozenset({"/report"}))
        self._latest: str | None = None
        """The newest message for the pages (JSON): the overview, or why the store could not be read."""
        self._fresh: list[asyncio.Event] = []
        self._stop = threading.Event()
        self._reader: threading.Thread | None = None
        self._views: dict[int, tuple[subprocess.Popen, str]] = {}
        self._views_lock = threading.Lock()

    def __enter__(self) -> Dashboard:
        self.start()
        return self

    def __exit__(self, *_) -> None:
        self.close()

    @property
    def url(self) -> str:
        return self.server.url

    def start(self) -> None:
        """Read the study, serve the page, read on every ``READ_S``; ``microg.view.pageserver.PageError`` when
        the address or port cannot be had."""
        if not (VENDOR / CHART).exists():
            raise FileNotFoundError(f"the dashboard's Chart.js is missing from {VENDOR}: install the front-end "
                                    "packages with `make setup` (npm ci)")
        files = {"/" + file.name: file for file in PAGE.iterdir() if file.is_file()}
        self.read()
        report = {} if self.overview.report is None else {"/report": self.overview.report}
        self.server.start(files | report | {"/": PAGE / "index.html", f"/vendor/{CHART}": VENDOR / CHART})
        self._reader = threading.Thread(target=self._read_on, name="dashboard reader", daemon=True)
        self._reader.start()

    def close(self) -> None:
        self._stop.set()
        if self._reader is not None:
            self._reader.join(timeout=10)
        self.server.close()
        with self._views_lock:
            views, self._views = list(self._views.values()), {}
        for process, _ in views:
            _stop_process(process)

    # ------------------------------------------------------------ reading

    def read(self) -> bool:
        """Read what the store holds new; whether the overview changed (then the pages get it)."""
        if not self.overview.refresh():
            return False
        summary = self.overview.summary()
        summary["read_at"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        self._latest = json.dumps({"type": "overview", **summary})
        self.server.call(self._route_report, self.overview.report)
        self.server.call(self._publish)
        return True

    def _read_on(self) -> None:
        while not self._stop.wait(READ_S):
            try:
                self.read()
            except StoreError as error:  # the file became unreadable: say so, and go on trying
                self._latest = json.dumps({"type": "error", "message": str(error)})
                self.server.call(self._publish)

    def _route_report(self, report: Path | None) -> None:
        """On the server's loop: ``/report`` serves the report the overview found."""
        if report is None:
            self.server.files.pop("/report", None)
        else:
            self.server.files["/report"] = report

    def _publish(self) -> None:
        """On the server's loop: every page gets the newest message (``_latest``) next."""
        for fresh in self._fresh:
            fresh.set()

    # ------------------------------------------------------------ pages

    async def _connection(self, websocket) -> None:
        fresh = asyncio.Event()
        self._fresh.append(fresh)
        if self._latest is not None:
            fresh.set()
        sender = asyncio.create_task(self._send(websocket, fresh))
        try:
            async for text in websocket:
                try:
                    message = json.loads(text)
                    kind, session = message["type"], int(message["session"])
                except (ValueError, KeyError, TypeError):
                    continue
                if kind == "view":
                    answer = await asyncio.get_running_loop().run_in_executor(None, self.open_view, session)
                    await websocket.send(json.dumps({"type": "view", "session": session, **answer}))
        except Exception:  # a page that goes away mid-message is simply gone
            pass
        finally:
            sender.cancel()
            self._fresh.remove(fresh)

    async def _send(self, websocket, fresh: asyncio.Event) -> None:
        """The newest overview whenever it changes (never a backlog)."""
        while True:
            await fresh.wait()
            fresh.clear()
            await websocket.send(self._latest)

    # ------------------------------------------------------------ the view of a session

    def open_view(self, session: int) -> dict:
        """``{"url": ...}`` of ``microg view`` of ``session`` (started now, or the one started before), or
        ``{"command": ..., "why": ...}`` when it cannot be opened from the page."""
        command = f"microg view {self.store.dir} --session {session}"
        if session not in self.overview.sessions:
            return {"why": f"study {self.store.name!r} has no session {session}", "command": None}
        if self.server.host != LOCALHOST:
            return {"command": command, "why": "the view serves the lab computer only (127.0.0.1): run it there"}
        with self._views_lock:
            running = self._views.get(session)
            if running is not None and running[0].poll() is None:
                return {"url": running[1]}
            with socket.socket() as probe:
                probe.bind((LOCALHOST, 0))
                port = probe.getsockname()[1]
            process = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "view",
                                        str(self.store.dir), "--session", str(session), "--port", str(port)],
                                       stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                       text=True)
            url, said = _view_address(process)
            if url is None:
                _stop_process(process)
                return {"command": command, "why": f"the view did not start: {said.strip()[-400:] or 'no output'}"}
            self._views[session] = (process, url)
            return {"url": url}


def _view_address(process: subprocess.Popen) -> tuple[str | None, str]:
    """The address a starting ``microg view`` prints (None if it ends first or takes ``VIEW_START_S``), and
    what it printed until then. Its later output is read on and dropped, so it never blocks on a full pipe."""
    lines: queue.Queue = queue.Queue()

    def read() -> None:
        for line in process.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    said = ""
    while True:
        try:
            line = lines.get(timeout=VIEW_START_S)
        except queue.Empty:
            return None, said + f"(nothing more for {VIEW_START_S:g} s)"
        if line is None:
            return None, said
        said += line
        found = VIEW_ADDRESS.search(line)
        if found:
            return found.group(1), said


def _stop_process(process: subprocess.Popen) -> None:
    """End a view the dashboard started: SIGTERM (the view stops between two frames), then SIGKILL."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
