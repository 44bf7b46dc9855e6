"""A page and its WebSocket served from a thread of their own: the one server of the participant's page
(``display``) and the researcher's dashboard (``dashboard``), and the rules both keep.

- It listens on 127.0.0.1 unless given another host; off 127.0.0.1 the page and its WebSocket are
  served over TLS with the ``certificate`` given (``microg.view.tls``; WebXR needs a secure context,
  which plain HTTP is on the machine itself only) and a one-time ``token`` is required (the
  dashboard asks for one on 127.0.0.1 too: other users of the machine reach 127.0.0.1 as well).
- Every request's Host must be the served address (each header given exactly once), so a page of
  another site cannot reach the server through a name it points at this machine; the WebSocket
  (``/ws``) refuses any Origin but the page's own, its scheme included; ``/ws`` and the ``private``
  paths ask for the token.
- It serves the files it is given, by request path, and nothing else: no request path reaches the
  file system.
- A connection that ends before it spoke HTTP (a browser's unused preconnection, a page refusing the
  certificate, a port scanner) leaves no traceback in the researcher's terminal (``HANDSHAKES``).

The owner gives the files (``start``) and a coroutine that serves each WebSocket connection
(``on_connection``), and hands work to the server's event loop with ``call``.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import mimetypes
import os
import secrets
import signal
import threading
import time
from pathlib import Path
from typing import Awaitable, Callable
from urllib.parse import parse_qs, urlsplit

from .tls import LOCALHOST, Certificate


class PageError(RuntimeError):
    """A page cannot be served where it was asked to be; the message says why and what to do."""


class _QuietHandshakes(logging.Filter):
    """Drops websockets' records of a connection that ended before it spoke HTTP (a browser's
    preconnection it never used, a page refusing the certificate, a port scanner, garbage on the
    port): logged as errors with their tracebacks, they would flood the researcher's terminal, and
    nothing is wrong with the page. Any other record goes on."""

    def filter(self, record: logging.LogRecord) -> bool:
        from websockets.exceptions import InvalidHandshake

        error = record.exc_info[1] if record.exc_info else None
        return not isinstance(error, (InvalidHandshake, EOFError, OSError, TimeoutError))


SERVER_LOG = logging.getLogger(__name__)
"""The page servers' log (websockets'), without the records of connections that ended unspoken."""
HANDSHAKES = _QuietHandshakes()
SERVER_LOG.addFilter(HANDSHAKES)
OPEN_TIMEOUT_S = 60.0
"""How long a connection may take to open (TLS and the WebSocket handshake) before the server drops it:
websockets' 10 s default was seen to cut a page's first handshake on a machine busy compiling."""


class PageServer:
    """A page's files and its WebSocket, served from a thread (module docstring). ``what`` names the
    page in messages ("the participant's page")."""

    def __init__(self, what: str, on_connection: Callable[[object], Awaitable[None]], *, host: str = LOCALHOST,
                 port: int = 0, certificate: Certificate | None = None, token: bool = False,
                 private: frozenset[str] = frozenset()):
        if host != LOCALHOST and certificate is None:
            raise ValueError(f"{what} on {host} is served over HTTPS (a browser offers WebXR to a secure page only, and "
                             "the token must not travel in the clear): give it a certificate (microg.view.tls)")
        self.what, self.host, self.certificate, self.private = what, host, certificate, private
        self._on_connection = on_connection
        self._tls = None if certificate is None else certificate.context()
        self.scheme = "http" if certificate is None else "https"
        self.token = secrets.token_urlsafe(12) if token or host != LOCALHOST else None
        self._port = port
        self.files: dict[str, Path] = {}
        """The files by request path: all the server serves."""
        self.loop: asyncio.AbstractEventLoop | None = None
        self._started = threading.Event()
        self._failed: OSError | None = None
        """Why the server could not start (an address or port it cannot have), for ``start`` to say."""
        self._stop: asyncio.Event | None = None
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        return self._port

    @property
    def url(self) -> str:
        return f"{self.scheme}://{self.host}:{self._port}/" + (f"?token={self.token}" if self.token else "")

    def start(self, files: dict[str, Path]) -> None:
        """Serve ``files`` (request path -> file) and the WebSocket; PageError when the address or
        port cannot be had."""
        self.files = dict(files)
        self._thread = threading.Thread(target=self._serve, name=self.what, daemon=True)
        self._thread.start()
        self._started.wait()
        if self._failed is not None:
            error = self._failed
            hint = {errno.EADDRINUSE: f"another program serves port {self._port} there: give another --port (0: a "
                                      "free one)",
                    errno.EADDRNOTAVAIL: f"{self.host} is not an address of this machine: give --host one of its own "
                                         "(ip address lists them)",
                    errno.EACCES: f"port {self._port} needs privileges: give a --port above 1023 (0: a free one)"}
            raise PageError(f"cannot serve {self.what} at {self.host}:{self._port} "
                            f"({os.strerror(error.errno) if error.errno else error}): "
                            + hint.get(error.errno, "check --host and --port"))

    def close(self) -> None:
        if self.loop is not None and self._stop is not None and self._failed is None:
            self.loop.call_soon_threadsafe(self._stop.set)
        if self._thread is not None:
            self._thread.join(timeout=10)

    def call(self, function: Callable, *args) -> None:
        """Run ``function(*args)`` on the server's event loop (from any thread), once it runs."""
        if self.loop is not None:
            self.loop.call_soon_threadsafe(function, *args)

    # ------------------------------------------------------------ plumbing

    def _serve(self) -> None:
        try:
            asyncio.run(self._main())
        except OSError as error:
            if self._started.is_set():
                raise
            self._failed = error  # the address or port cannot be had: start says so
            self._started.set()

    async def _main(self) -> None:
        from websockets.asyncio.server import serve

        self._stop = asyncio.Event()
        self.loop = asyncio.get_running_loop()
        async with serve(self._on_connection, self.host, self._port, process_request=self._http, ssl=self._tls,
                         origins=None, compression=None, max_size=2 ** 20, open_timeout=OPEN_TIMEOUT_S,
                         logger=SERVER_LOG) as server:
            self._port = server.sockets[0].getsockname()[1]
            self._started.set()
            await self._stop.wait()

    def _allowed_origins(self) -> set[str]:
        hosts = {self.host, "localhost"} if self.host == LOCALHOST else {self.host}
        return {f"{self.scheme}://{h}:{self._port}" for h in hosts}

    def refusal(self, request) -> str | None:
        """Why a request must be refused (a foreign Host or Origin, or either given more than once; a
        missing token), or None."""
        for name in ("Host", "Origin"):
            if len(given := request.headers.get_all(name)) > 1:
                return f"{name} given {len(given)} times"
        host = request.headers.get("Host", "")
        if host not in {o.split("://", 1)[1] for o in self._allowed_origins()}:
            return f"Host {host!r} is not this server"
        path = urlsplit(request.path).path
        origin = request.headers.get("Origin")
        if path == "/ws" and origin not in self._allowed_origins():
            return f"Origin {origin!r} is not this page's"
        if self.token is not None and (path == "/ws" or path in self.private):
            token = parse_qs(urlsplit(request.path).query).get("token", [None])[0]
            if not (token and secrets.compare_digest(token, self.token)):
                return f"the request did not present the token of {self.what}"
        return None

    def _http(self, connection, request):
        from websockets.datastructures import Headers
        from websockets.http11 import Response

        refusal = self.refusal(request)
        if refusal is not None:
            return connection.respond(403, f"refused: {refusal}\n")
        path = urlsplit(request.path).path
        if path == "/ws":
            return None
        file = self.files.get(path)
        if file is None:
            return connection.respond(404, "not found\n")
        try:
            body = file.read_bytes()
        except OSError:
            return connection.respond(404, "not found\n")
        kind = mimetypes.guess_type(file.name)[0] or "application/octet-stream"
        if file.suffix == ".js":
            kind = "text/javascript"
        return Response(200, "OK", Headers([("Content-Type", kind), ("Content-Length", str(len(body))),
                                             ("Cache-Control", "no-store")]), body)


class Stopping:
    """Ctrl-C (SIGINT), SIGTERM and SIGHUP end a command that serves a page (the view, the dashboard)
    between two of its steps: the handler only notes the signal, and the loop sees it after its next
    sleep. Raised wherever it lands, a KeyboardInterrupt can cut a call into a server in the middle,
    and once (one fresh-clone test run in many) the process then did not end at all after Ctrl-C.
    The note is a plain attribute: a lock taken in the handler (an Event's) could be the one the
    interrupted code holds. A second signal raises at once (the loop is stuck)."""

    def __init__(self) -> None:
        self.signal: str | None = None

    def wait(self, seconds: float) -> bool:
        """Sleep ``seconds``; whether a signal came."""
        time.sleep(seconds)
        return self.signal is not None

    def handle(self, number, frame) -> None:
        if self.signal is not None:
            raise KeyboardInterrupt
        self.signal = signal.Signals(number).name
