"""The browser view: what headless Chromium sees of it, that it serves this machine only, and
that a live view follows a session that another thread is writing."""

from __future__ import annotations

import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from microg.cli import main
from microg.view import (default_camera, find_run, find_session, key_moments, open_readonly, read_track,
                               task_layout)
from microg.view.server import BROWSER_ASPECT, View

from .browser import MISSING, chromium, open_page, page_text, screenshot
from tests.study.scripted import gated_session
from tests.waiting import WAIT_S, ended, joined, next_item, wait_until

from .conftest import colour_mask, free_port, new_study, pixels_near, project

WINDOW = (1200, 800)


def start_view(*arguments: str) -> tuple[subprocess.Popen, str]:
    """``microg view ARGUMENTS`` in its own process, and what it announces (the address first):
    read line by line until the announcement, or until the process ends without one."""
    process = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "view",
                                *arguments], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env=dict(os.environ, PYTHONFAULTHANDLER="1"))  # its stacks if it hangs
    lines: queue.Queue[str | None] = queue.Queue()

    def read() -> None:
        for line in process.stdout:
            lines.put(line)
        lines.put(None)  # the process closed its output: it has ended

    process.reader = threading.Thread(target=read, daemon=True)
    process.reader.start()
    announced = ""
    while "Ctrl-C to stop" not in announced:
        line = next_item(lines, "microg view to announce itself", seen=lambda: announced)
        if line is None:
            raise AssertionError(f"microg view ended without announcing itself: {announced!r} {process.stderr.read()}")
        announced += line
    process.announced_lines = lines
    return process, announced


def stop_view(process: subprocess.Popen, number: int = signal.SIGINT) -> str:
    """Ctrl-C (or another signal) for the view; what it printed after its announcement (all of it:
    read to the end)."""
    process.send_signal(number)
    ended(process, f"microg view after {signal.Signals(number).name}", stacks=True)
    joined(process.reader, "the reader of microg view's output")
    printed = []
    while (line := next_item(process.announced_lines, "the end of microg view's output")) is not None:
        printed.append(line)
    return "".join(printed)


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_sigterm_and_sighup_stop_the_view_as_ctrl_c_does(logged_study, number):
    """What a process manager or a closed terminal sends ends the view between two frames, cleanly."""
    process, _ = start_view(str(logged_study), "--session", "P01", "--port", str(free_port()))
    output = stop_view(process, number)
    assert (process.returncode, output.strip()) == (0, "view stopped"), process.stderr.read()


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium chromium-driver; "
                                           "pip install selenium)")
def test_the_view_in_a_browser_draws_the_hand_the_object_and_the_places(logged_study, tmp_path):
    with open_readonly(logged_study) as store:
        track = read_track(store, find_run(store, find_session(store, "P01"), 0))
        layout = task_layout(store.protocol, track.run.object)
    index = next(m.index for m in key_moments(track, 3) if m.label == "place 2")
    scene = track.scene(index, 3)
    process, announced = start_view(str(logged_study), "--session", "P01", "--task", "0", "--at",
                                    repr(scene.t), "--port", str(free_port()))
    try:
        url = announced.split("open ")[1].split()[0]
        assert url.startswith("http://127.0.0.1:")
        assert "replaying session 1 of P01 (completed): task 0: stage1 cube" in announced
        shot = np.asarray(Image.open(screenshot(url, tmp_path / "view.png", WINDOW, wait_for="attempts (drops)"))
                          .convert("RGB"))
    finally:
        output = stop_view(process)
    assert process.returncode == 0 and output.strip() == "view stopped"

    camera = default_camera(layout, aspect=BROWSER_ASPECT)
    obj = project(scene.object_position, camera, *WINDOW)[0]
    places = project(layout.places, camera, *WINDOW)
    ring = project(layout.places[1] + [0.04, 0.0, 0.0], camera, *WINDOW)[0][0] - places[1][0]
    assert pixels_near(colour_mask(shot, "object"), obj, 40) > 1500  # the cube
    assert pixels_near(colour_mask(shot, "lit"), places[1], ring * 1.3) > 300  # place 2 lit: the object is there
    assert pixels_near(colour_mask(shot, "done"), places[0], ring * 1.3) > 300  # place 1 done
    assert pixels_near(colour_mask(shot, "lit"), places[0], ring * 1.1) == 0
    assert pixels_near(colour_mask(shot, "done"), places[2], ring * 1.1) == 0  # place 3 still to come
    for phalanx in project(scene.rendered.centre[scene.touching], camera, *WINDOW):  # the hand, highlighted
        assert pixels_near(colour_mask(shot, "highlight"), phalanx, 25) > 150


class Ticking:
    """A view's loop in a thread, as ``serve`` runs it; it keeps what each tick did to the playback
    (elapsed seconds, cursor before, cursor after, playing before) so a test can check the playback
    against the ticks themselves, not against a clock of its own."""

    def __init__(self, view: View):
        self.view, self.running = view, True
        self.ticks: list[tuple[float, float, float, bool]] = []
        self.ticked = threading.Condition()
        self.thread = threading.Thread(target=self.loop, daemon=True)
        self.thread.start()

    def loop(self) -> None:
        last = time.monotonic()
        while self.running:
            time.sleep(1 / 30)
            now = time.monotonic()
            before, playing = self.view.playback.seconds, self.view.playback.playing
            self.view.tick(now - last)
            with self.ticked:
                self.ticks.append((now - last, before, self.view.playback.seconds, playing))
                self.ticked.notify_all()
            last = now

    def wait_ticks(self, count: int) -> None:
        """Until ``count`` more ticks have run."""
        with self.ticked:
            target = len(self.ticks) + count
            assert self.ticked.wait_for(lambda: len(self.ticks) >= target or not self.thread.is_alive(), WAIT_S), \
                f"waited {WAIT_S:g} s for {count} ticks of the view; it ticked {len(self.ticks) - target + count}"

    def stop(self) -> None:
        self.running = False
        joined(self.thread, "the view's loop")


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium chromium-driver; "
                                           "pip install selenium)")
def test_replay_plays_pauses_seeks_and_changes_speed_and_hands_from_the_browser(logged_study):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    def click(driver, xpath):
        driver.execute_script("arguments[0].click()", driver.find_element(By.XPATH, xpath))

    def choose(driver, shown, option):
        click(driver, f"//input[@value='{shown}']")
        options = lambda: [o.text for o in driver.find_elements(By.XPATH, "//*[@role='option']")]  # noqa: E731
        wait_until(lambda: option in options(), f"the option {option!r} in the page's dropdown", seen=options,
                   going=going)
        click(driver, f"//*[@role='option'][normalize-space()='{option}']")

    def displayed(driver):
        return re.search(r"(\w+) · ([\d.]+) s", page_text(driver)).groups()

    with open_readonly(logged_study) as store:
        view = View(store, find_session(store, "P01"), "P01", port=free_port())
        view.start_at(0, 0.0)
        ticking = Ticking(view)
        going = ticking.thread.is_alive
        try:
            with chromium() as driver:
                open_page(driver, view.url, "attempts (drops)")
                assert displayed(driver) == ("manipulation", "0.0") and not view.playback.playing
                choose(driver, "1x", "0.5x")
                wait_until(lambda: view.playback.speed == 0.5, "the speed chosen in the page",
                           seen=lambda: view.playback, going=going)
                click(driver, "//button[normalize-space()='Play']")
                wait_until(lambda: view.playback.seconds > 0.3, "the replay to play", seen=lambda: view.playback,
                           going=going)
                click(driver, "//button[normalize-space()='Pause']")
                wait_until(lambda: not view.playback.playing, "the pause pressed in the page",
                           seen=lambda: view.playback, going=going)
                paused_at = view.playback.seconds
                played = [(elapsed, after - before) for elapsed, before, after, playing in ticking.ticks
                          if playing and after > before]
                assert played and all(moved == pytest.approx(0.5 * elapsed) for elapsed, moved in played)  # half speed
                ticking.wait_ticks(15)
                assert view.playback.seconds == paused_at
                # the page shows the time of the frame at or before the cursor (over 50 frames a second), to 0.1 s
                wait_until(lambda: paused_at - 0.05 - 1 / 50 <= float(displayed(driver)[1]) <= paused_at + 0.05,
                           f"the page to show the pause at {paused_at:.3f} s", seen=lambda: displayed(driver),
                           going=going)

                seek = next(box for box in driver.find_elements(By.CSS_SELECTOR, "input[type=text]")
                            if re.fullmatch(r"[\d.]+", box.get_attribute("value") or ""))
                seek.send_keys(Keys.CONTROL, "a")
                seek.send_keys("2.5", Keys.ENTER)
                wait_until(lambda: view.playback.seconds == 2.5, "the seek typed into the page",
                           seen=lambda: (view.playback, seek.get_attribute("value")), going=going)
                wait_until(lambda: displayed(driver) == ("maintenance", "2.5"), "the page to show the seek",
                           seen=lambda: displayed(driver), going=going)

                assert not view.drawer.tracked.visible
                choose(driver, "rendered", "both")
                wait_until(lambda: view.drawer.tracked.visible and view.drawer.rendered.visible,
                           "both hands drawn, as chosen in the page", going=going)
        finally:
            ticking.stop()
            view.close()


def test_a_seek_from_the_page_reaches_the_view_whatever_the_ticks_do_meanwhile(logged_study):
    """The race behind a hung browser test: viser takes the page's slider value on its event loop and
    runs a plain callback later, on its threads; a tick between the two put the cursor back on the
    slider, and the callback then read the tick's value. Here those threads are all kept busy until
    the ticks are done, so a seek read there would be lost every time."""
    import msgspec
    import viser
    from viser._messages import GuiUpdateMessage, ViewerCameraMessage
    from websockets.sync.client import connect

    def send(page, message) -> None:
        page.send(msgspec.msgpack.encode(message.as_serializable_dict()))

    with open_readonly(logged_study) as store:
        view = View(store, find_session(store, "P01"), "P01", port=free_port())
        view.start_at(0, 0.0)
        callbacks, release = view.server._thread_executor, threading.Event()
        try:
            port = view.server.get_port()
            with connect(f"ws://127.0.0.1:{port}", origin=f"http://127.0.0.1:{port}",
                         subprotocols=[f"viser-v{viser.__version__}"]) as page:
                # viser counts a page as connected once it says where its camera is
                send(page, ViewerCameraMessage((1.0, 0.0, 0.0, 0.0), (0.0, 0.3, 0.5), 0.7, 0.01, 10.0, 800, 1200,
                                               (0.0, 0.2, 0.0), (0.0, 1.0, 0.0)))
                wait_until(lambda: view.server.get_clients(), "the page to connect")
                busy = [callbacks.submit(release.wait, WAIT_S) for _ in range(callbacks._max_workers)]
                send(page, GuiUpdateMessage(view.time_slider._impl.uuid, {"value": 2.5}))
                wait_until(lambda: view.time_slider.value == 2.5, "viser to take the page's seek",
                           seen=lambda: view.time_slider.value)
                for _ in range(3):
                    view.tick(0.0)
                assert view.playback.seconds == 2.5 and not view.playback.playing and not view.playback.follow
                release.set()
                for task in busy:
                    task.result(WAIT_S)
                view.tick(0.0)
                assert view.playback.seconds == 2.5
        finally:
            release.set()
            view.close()


def test_the_view_is_served_on_this_machine_only(logged_study):
    with open_readonly(logged_study) as store:
        view = View(store, find_session(store, "P01"), "P01", port=free_port())
        try:
            assert view.server.get_host() == "127.0.0.1"
            with urllib.request.urlopen(view.url) as page:
                assert page.status == 200
            port = view.server.get_port()
            addresses = {info[4][0] for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)}
            for address in addresses - {"127.0.0.1", "127.0.1.1"}:
                with pytest.raises(OSError):
                    socket.create_connection((address, port), timeout=2).close()
        finally:
            view.close()


def test_a_live_view_waits_for_the_session_follows_it_and_moves_on_to_its_next_task(tmp_path):
    folder = new_study(tmp_path / "study")
    gate = threading.Semaphore(0)
    with open_readonly(folder) as store:
        view = View(store, None, None, port=free_port())
        try:
            view.tick(0.0)
            assert "waiting for a session to start" in view.hud.content
            waiting = threading.Semaphore(0)
            writer = gated_session(folder, gate, waiting)

            def seen():
                view.poll()
                view.tick(0.0)

            shown = []  # (task index, frames read, what the display says) each time the session waits on the gate
            while True:
                wait_until(lambda: waiting.acquire(blocking=False) or not writer.is_alive(),
                           "the session to wait at the gate (or end)", seen=lambda: shown[-1:])
                if not writer.is_alive():
                    break
                seen()  # the session is held at the gate: everything it committed is there to read
                if view.track is not None and len(view.track.frames):
                    shown.append((view.track.run.task_index, len(view.track.frames), view.hud.content))
                gate.release()  # the session may commit its next batch
            joined(writer, "the session")
            seen()
            runs = store.db.execute("SELECT task_index, frames FROM task_runs ORDER BY id").fetchall()
        finally:
            view.close()
    tasks = [task for task, _, _ in shown]
    assert tasks == sorted(tasks) and set(tasks) == {0, 1}  # followed task 0, then moved on to task 1
    live = [text for _, _, text in shown if "*live*" in text]
    assert live and all("P01" in text and "attempts (drops): 0" in text for text in live)
    batch = store.protocol.frame_batch
    first = [n for task, n, _ in shown if task == 0]
    assert first[:3] == [batch, 2 * batch, 3 * batch]  # frames arrived batch by batch while the task ran
    assert view.track.run.task_index == 1 and len(view.track.frames) == runs[-1]["frames"]
    assert view.playback.follow and view.playback.seconds == view.track.duration  # on the newest frame
    assert "(completed)" in view.hud.content and "completed in" in view.hud.content


def test_the_view_refuses_a_websocket_from_another_page_and_serves_its_own(logged_study):
    import viser
    import websockets
    from websockets.sync.client import connect

    with open_readonly(logged_study) as store:
        view = View(store, find_session(store, "P01"), "P01", port=free_port())
        try:
            port = view.server.get_port()
            protocol = [f"viser-v{viser.__version__}"]
            for origin in ("http://evil.example", f"http://127.0.0.1:{port + 1}", None):
                with connect(f"ws://127.0.0.1:{port}", origin=origin, subprotocols=protocol) as foreign:
                    with pytest.raises(websockets.ConnectionClosed) as closed:
                        foreign.recv()  # nothing arrives: the view closes the connection first
                    assert closed.value.rcvd.code == 1008 and f"Origin {origin!r}" in closed.value.rcvd.reason
            rebound = f"rebound.example:{port}"  # a name another site made point here (DNS rebinding)
            with connect(f"ws://{rebound}", sock=socket.create_connection(("127.0.0.1", port)),
                         origin=f"http://{rebound}", subprotocols=protocol) as page:
                with pytest.raises(websockets.ConnectionClosed) as closed:
                    page.recv()
                assert closed.value.rcvd.reason == f"Host {rebound!r} is not this view's page"
            for host in ("127.0.0.1", "localhost"):
                with connect(f"ws://{host}:{port}", origin=f"http://{host}:{port}", subprotocols=protocol) as own:
                    assert len(own.recv()) > 0  # the view's own page gets the scene
        finally:
            view.close()


def test_the_view_command_says_what_is_missing_before_serving(logged_study, tmp_path):
    run = CliRunner().invoke
    assert "Usage: microg view" in run(main, ["view", "--help"], prog_name="microg").output
    result = run(main, ["view"])
    assert result.exit_code == 2 and "Missing argument 'STUDY_DIR'" in result.output
    result = run(main, ["view", str(tmp_path / "nothing")])
    assert result.exit_code == 1 and f"no study in {tmp_path / 'nothing'}" in result.output
    result = run(main, ["view", str(logged_study), "--session", "P02"])
    assert result.exit_code == 1 and "no participant or session 'P02'" in result.output
    result = run(main, ["view", str(logged_study), "--session", "P01", "--task", "4", "--port", str(free_port())])
    assert result.exit_code == 1 and "has no logged task 4" in result.output
