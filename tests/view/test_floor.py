"""The floor of ``microg bench display``: a minimal page that takes the participant page's stream and
draws it, measured as the participant page is (its numbers are the floor the benchmark puts ours beside)."""

from __future__ import annotations

import asyncio
import json

import pytest

from microg.bench import display
from microg.bench.floor import RATE_HZ

from .browser import MISSING


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING}")
def test_the_floor_page_draws_the_stream_it_is_sent_and_reports_each_frame_on_the_servers_clock(tmp_path):
    table = display.floor_latency(tmp_path, 5.0, (640, 400))
    assert len(table) > 20, "the page drew frames of the stream"
    assert table["frame"].is_monotonic_increasing and table["frame"].is_unique, "each frame drawn once, in order"
    received = table["received_ms"] - table["ready_ms"]
    slack = table["clock_spread_ms"].iloc[0] + table["clock_rtt_ms"].iloc[0]
    assert (received > -slack).all(), "a frame arrives after the server had it, within the clock sync's error"
    assert (table["drawn_ms"] >= table["received_ms"]).all(), "a frame is drawn after it arrived"
    sent = table["frame"].iloc[-1] - table["frame"].iloc[0]
    span_s = (table["drawn_ms"].iloc[-1] - table["drawn_ms"].iloc[0]) / 1e3
    assert sent / span_s == pytest.approx(RATE_HZ, rel=0.5), "the server sends at the tracking rate"


def test_the_floor_server_refuses_another_origin(tmp_path):
    from websockets.asyncio.client import connect
    from websockets.exceptions import InvalidStatus

    floor = display._Served(["-m", "microg.bench.floor", "--port", str(display._free_port())], tmp_path / "floor.log",
                            "floor page")
    address = floor.url.replace("http://", "ws://") + "ws"

    async def first_message(origin: str) -> dict:
        async with connect(address, origin=origin, open_timeout=60) as socket:
            return json.loads(await asyncio.wait_for(socket.recv(), 60))

    try:
        assert asyncio.run(first_message(floor.url.rstrip("/")))["type"] == "frame"
        with pytest.raises(InvalidStatus, match="403"):
            asyncio.run(first_message("http://example.org"))
    finally:
        floor.stop()
