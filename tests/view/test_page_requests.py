"""What reaches the participant page's server from the network: every request gets an answer (200,
403 or 404), none a traceback in the operator's terminal, and what the page reports stays bounded."""

from __future__ import annotations

import json
import logging
import socket

import pytest
from websockets.sync.client import connect

from microg.paths import protocol_file
from microg.study.protocol import load_protocol
from microg.view.display import DRAWN_KEPT, ParticipantDisplay
from tests.waiting import WAIT_S, wait_until


@pytest.fixture(scope="module")
def display():
    with ParticipantDisplay(load_protocol(protocol_file("paper"))) as served:
        yield served


def answer(display: ParticipantDisplay, request: bytes) -> bytes:
    """The status line the server answers a raw HTTP request with."""
    with socket.create_connection(("127.0.0.1", display.port), timeout=WAIT_S) as sock:
        sock.sendall(request)
        received = b""
        while b"\r\n" not in received and (chunk := sock.recv(4096)):
            received += chunk
    return received.split(b"\r\n", 1)[0]


def get(display, path: bytes, *headers: str) -> bytes:
    lines = [f"Host: 127.0.0.1:{display.port}", *headers]
    return answer(display, b"GET " + path + b" HTTP/1.1\r\n" + "".join(f"{h}\r\n" for h in lines).encode() + b"\r\n")


UPGRADE = ("Upgrade: websocket", "Connection: Upgrade", "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
           "Sec-WebSocket-Version: 13")


@pytest.mark.parametrize("path, headers, status", [
    (b"/", (), b"200"),
    (b"/participant.js", (), b"200"),
    (b"/a\x00b", (), b"404"),  # a NUL byte: was a traceback (the file system refuses it)
    (b"/" + b"a" * 300 + b".js", (), b"404"),  # a name longer than the file system takes: was a traceback
    (b"/../../etc/passwd", (), b"404"),
    (b"/vendor", (), b"404"),
    (b"/%00", (), b"404"),
    (b"/\xff\xfe", (), b"404"),
    (b"/ws", UPGRADE + ("Origin: http://127.0.0.1:{port}", "Origin: http://evil.example"), b"403"),  # was a traceback
    (b"/", ("Origin: http://a.example", "Origin: http://b.example"), b"403"),
    (b"/", ("Host: 127.0.0.1:{port}",), b"403"),  # Host twice
])
def test_every_request_gets_an_answer_and_none_a_traceback(display, caplog, path, headers, status):
    with caplog.at_level(logging.ERROR, logger="websockets"):
        assert get(display, path, *(h.format(port=display.port) for h in headers)).split()[1] == status
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR], caplog.text


def test_the_page_reports_are_kept_for_the_last_minute_only(display):
    origin = f"http://127.0.0.1:{display.port}"
    with connect(f"ws://127.0.0.1:{display.port}/ws", origin=origin) as page:
        for i in range(DRAWN_KEPT + 500):  # a page (or a script) that reports more frames than a minute's
            page.send(json.dumps({"type": "drawn", "i": i, "t": i / 60, "ready": 0.0, "drawn": 1.0}))
        page.send(json.dumps({"type": "drawn", "i": "last"}))
        wait_until(lambda: display.drawn and display.drawn[-1]["frame"] == "last", "the page's last report",
                   seen=lambda: list(display.drawn)[-1:])
    assert len(display.drawn) == DRAWN_KEPT and display.drawn[0]["frame"] == 501
