"""The browser view: what headless Chromium sees of it, that it serves this machine only, and
that a live view follows a session that another thread is writing."""

from __future__ import annotations

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
from .conftest import colour_mask, free_port, new_study, pixels_near, project, session_in_background

WINDOW = (1200, 800)


def start_view(*arguments: str) -> tuple[subprocess.Popen, str]:
    """``microg view ARGUMENTS`` in its own process, and what it announces (the address first)."""
    process = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "view",
                                *arguments], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in process.stdout], daemon=True).start()
    announced = ""
    try:
        while "Ctrl-C to stop" not in announced:
            announced += lines.get(timeout=60)
    except queue.Empty:
        process.kill()
        raise AssertionError(f"microg view did not announce itself: {announced!r} {process.stderr.read()}") from None
    process.announced_lines = lines
    return process, announced


def stop_view(process: subprocess.Popen) -> str:
    """Ctrl-C for the view; what it printed after its announcement."""
    process.send_signal(signal.SIGINT)
    process.wait(timeout=30)
    time.sleep(0.1)
    printed = []
    while not process.announced_lines.empty():
        printed.append(process.announced_lines.get())
    return "".join(printed)


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium chromium-driver; "
                                           "pip install selenium)")
def test_the_view_in_a_browser_draws_the_hand_the_object_and_the_places(logged_study, tmp_path):
    with open_readonly(logged_study) as store:
        track = read_track(store, find_run(store, find_session(store, "P01"), 0))
        layout = task_layout(store.protocol, track.run.object)
    index = next(m.index for m in key_moments(track, 3) if m.label == "place 2")
    scene = track.scene(index, 3)
    process, announced = start_view("--study", str(logged_study), "--session", "P01", "--task", "0", "--at",
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
    """A view's loop in a thread, as ``serve`` runs it."""

    def __init__(self, view: View):
        self.view, self.running = view, True
        self.thread = threading.Thread(target=self.loop, daemon=True)
        self.thread.start()

    def loop(self) -> None:
        last = time.monotonic()
        while self.running:
            time.sleep(1 / 30)
            now = time.monotonic()
            self.view.tick(now - last)
            last = now

    def stop(self) -> None:
        self.running = False
        self.thread.join(10)


def wait_until(condition, timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


@pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium chromium-driver; "
                                           "pip install selenium)")
def test_replay_plays_pauses_seeks_and_changes_speed_and_hands_from_the_browser(logged_study):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    def click(driver, xpath):
        driver.execute_script("arguments[0].click()", driver.find_element(By.XPATH, xpath))

    def choose(driver, shown, option):
        click(driver, f"//input[@value='{shown}']")
        wait_until(lambda: any(o.text == option for o in driver.find_elements(By.XPATH, "//*[@role='option']")))
        click(driver, f"//*[@role='option'][normalize-space()='{option}']")

    def displayed(driver):
        return re.search(r"(\w+) · ([\d.]+) s", page_text(driver)).groups()

    with open_readonly(logged_study) as store:
        view = View(store, find_session(store, "P01"), "P01", free_port())
        view.start_at(0, 0.0)
        ticking = Ticking(view)
        try:
            with chromium() as driver:
                open_page(driver, view.url, "attempts (drops)")
                assert displayed(driver) == ("manipulation", "0.0") and not view.playback.playing
                choose(driver, "1x", "0.5x")
                wait_until(lambda: view.playback.speed == 0.5)
                started = time.monotonic()
                click(driver, "//button[normalize-space()='Play']")
                wait_until(lambda: view.playback.seconds > 0.3)
                click(driver, "//button[normalize-space()='Pause']")
                wait_until(lambda: not view.playback.playing)
                paused_at, elapsed = view.playback.seconds, time.monotonic() - started
                assert 0.3 < paused_at <= 0.5 * elapsed + 0.1  # half speed
                time.sleep(0.5)
                assert view.playback.seconds == paused_at
                wait_until(lambda: float(displayed(driver)[1]) == round(paused_at, 1))

                seek = next(box for box in driver.find_elements(By.CSS_SELECTOR, "input[type=text]")
                            if re.fullmatch(r"[\d.]+", box.get_attribute("value") or ""))
                seek.send_keys(Keys.CONTROL, "a")
                seek.send_keys("2.5", Keys.ENTER)
                wait_until(lambda: view.playback.seconds == 2.5)
                wait_until(lambda: displayed(driver) == ("maintenance", "2.5"))

                assert not view.drawer.tracked.visible
                choose(driver, "rendered", "both")
                wait_until(lambda: view.drawer.tracked.visible and view.drawer.rendered.visible)
        finally:
            ticking.stop()
            view.close()


def test_the_view_is_served_on_this_machine_only(logged_study):
    with open_readonly(logged_study) as store:
        view = View(store, find_session(store, "P01"), "P01", free_port())
        try:
            assert view.server.get_host() == "127.0.0.1"
            with urllib.request.urlopen(view.url, timeout=10) as page:
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
    with open_readonly(folder) as store:
        view = View(store, None, None, free_port())
        try:
            view.tick(0.0)
            assert "waiting for a session to start" in view.hud.content
            writer = session_in_background(folder, pace=0.002)
            shown = []  # (task index, frames read, what the display says) at each tick
            deadline = time.monotonic() + 60
            while writer.is_alive() or (view.session is not None and view.session.status == "running"):
                assert time.monotonic() < deadline
                time.sleep(0.05)
                view.tick(0.05)
                if view.track is not None and view.track.rows:
                    shown.append((view.track.run.task_index, len(view.track.rows), view.hud.content))
            time.sleep(0.3)
            view.tick(0.3)
            runs = store.db.execute("SELECT task_index, frames FROM task_runs ORDER BY id").fetchall()
        finally:
            view.close()
    tasks = [task for task, _, _ in shown]
    assert tasks == sorted(tasks) and set(tasks) == {0, 1}  # followed task 0, then moved on to task 1
    live = [text for _, _, text in shown if "*live*" in text]
    assert live and all("P01" in text and "attempts (drops): 0" in text for text in live)
    first = [n for task, n, _ in shown if task == 0]
    assert len(set(first)) >= 3  # frames arrived batch by batch while the task ran
    assert view.track.run.task_index == 1 and len(view.track.rows) == runs[-1]["frames"]
    assert view.playback.follow and view.playback.seconds == view.track.duration  # on the newest frame
    assert "(completed)" in view.hud.content and "completed in" in view.hud.content


def test_the_view_command_says_what_is_missing_before_serving(logged_study, tmp_path):
    run = CliRunner().invoke
    assert "Usage: microg view" in run(main, ["view", "--help"], prog_name="microg").output
    assert "Usage: microg view export" in run(main, ["view", "export", "--help"], prog_name="microg").output
    result = run(main, ["view"])
    assert result.exit_code == 2 and "give --study DIR" in result.output
    result = run(main, ["view", "--study", str(tmp_path / "nothing")])
    assert result.exit_code == 1 and f"no study in {tmp_path / 'nothing'}" in result.output
    result = run(main, ["view", "--study", str(logged_study), "--session", "P02"])
    assert result.exit_code == 1 and "no participant or session 'P02'" in result.output
    result = run(main, ["view", "--study", str(logged_study), "--session", "P01", "--task", "4", "--port",
                        str(free_port())])
    assert result.exit_code == 1 and "has no logged task 4" in result.output
