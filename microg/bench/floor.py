"""The floor of ``microg bench display``: the least a page can do with the participant page's stream.

``python -m microg.bench.floor --port N`` serves ``floor.html`` on 127.0.0.1 and, over its WebSocket,
frame messages of the participant page's shape (one hand's 20 bones as segments with radii and
contacts, the object's pose, the task's state) at 110 Hz, each stamped with when it was ready
on the server's clock, and answers the page's clock pings as the session does. The page keeps
the newest frame and draws its bones as lines with raw WebGL on the next animation frame, so
the latency it reports (ready to drawn) is the browser's share alone for a page that draws
every pixel (a page drawing fewer, as the participant page does when it adapts, may come in
under it).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import time
from http import HTTPStatus
from pathlib import Path

from websockets.asyncio.server import serve

PAGE = Path(__file__).with_name("floor.html")
RATE_HZ = 110.0
"""The participant page's frame rate in the benchmark (the paper's protocol's tracking rate)."""
BONES = 20


def frame(i: int, t: float) -> dict:
    """Frame ``i`` at ``t`` s: a hand's bones circling, the object beside them, as the session sends."""
    angle = 2 * math.pi * 0.5 * t
    x, y = 0.05 * math.cos(angle), 0.05 * math.sin(angle)
    start = [[round(x + 0.01 * (k % 5), 5), round(y + 0.02 * (k // 5), 5), 0.0] for k in range(BONES)]
    end = [[round(a + 0.005, 5), round(b + 0.015, 5), c] for a, b, c in start]
    return {"type": "frame", "i": i, "t": round(t, 6), "ready": time.time() * 1e3,
            "object": [round(x, 6), round(y + 0.1, 6), 0.0, 1.0, 0.0, 0.0, 0.0],
            "hands": [{"side": 1, "start": start, "end": end, "radius": [0.008] * BONES,
                       "touching": [False] * BONES}],
            "stage": "carrying", "place": 1, "lit": False, "place_timer": 0.0, "task_timer": round(t, 3),
            "attempts": 0, "held": False}


async def _stream(websocket) -> None:
    """Frames at ``RATE_HZ`` until the page goes; pongs for its pings."""

    async def answer():
        async for text in websocket:
            message = json.loads(text)
            if message.get("type") == "ping":
                await websocket.send(json.dumps({"type": "pong", "t0": message.get("t0"), "ts": time.time() * 1e3}))

    answering = asyncio.ensure_future(answer())
    start, i = time.monotonic(), 0
    try:
        while not answering.done():
            i += 1
            await asyncio.sleep(max(0.0, start + i / RATE_HZ - time.monotonic()))
            await websocket.send(json.dumps(frame(i, i / RATE_HZ)))
    finally:
        answering.cancel()


def _page(connection, request):
    """The page at ``/``; the WebSocket's handshake at ``/ws``; nothing else."""
    if request.path == "/ws":
        return None
    if request.path not in ("/", "/index.html"):
        return connection.respond(HTTPStatus.NOT_FOUND, "not found\n")
    response = connection.respond(HTTPStatus.OK, PAGE.read_text())
    response.headers["Content-Type"] = "text/html; charset=utf-8"
    return response


async def _serve(port: int) -> None:
    origin = f"http://127.0.0.1:{port}"
    async with serve(_stream, "127.0.0.1", port, process_request=_page, origins=[origin]):
        print(f"floor page: {origin}/", flush=True)
        await asyncio.Future()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, required=True)
    try:
        asyncio.run(_serve(parser.parse_args().port))
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
