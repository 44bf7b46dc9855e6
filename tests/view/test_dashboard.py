"""The researcher's dashboard in a real browser, over a study that sessions write while it reads:
running sessions move, then end; its numbers are the export's; other pages and a wrong token are
refused; a damaged store says so; and its reading leaves a session's logged frame rate as it was."""

from __future__ import annotations

import contextlib
import json
import re
import ssl
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.study.assignment import Participant
from microg.study.export import trials_table
from microg.study.inputs import PacedInputs, ScriptedInputs
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import create_study, open_study
from microg.view.dashboard import Dashboard

from tests.study.conftest import PROTOCOLS, answers, scripted_inputs
from tests.study.scripted import Gated, ScriptedPinch, pinch_keyframes
from tests.study.test_integrity import DAMAGED_BATCH, damage_frames_page
from tests.waiting import WAIT_S, ended, joined, line_reader, next_item, wait_until

from .browser import MISSING, chromium, page_text

needs_browser = pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium "
                                                         "chromium-driver; pip install selenium)")
WINDOW = (1280, 1000)
LAN = "127.0.0.2"
"""A loopback address that is not 127.0.0.1: the rules for a LAN address apply, no traffic leaves the machine."""


def enrol(folder, people, protocol: str = "tiny") -> None:
    with create_study(folder, load_protocol(PROTOCOLS / f"{protocol}.toml"), 7) as store:
        for pid, gender in people:
            store.add_participant(Participant(pid, gender, 24, "right", True))


def run_one(folder, pid: str, inputs, **kwargs) -> None:
    """``pid``'s whole session from ``inputs``, answered with the paper's four ratings."""
    with open_study(folder) as store:
        session = store.create_session(pid, input_spec=inputs.spec, simulated=True, clock="simulation")
        run_session(store, session.id, inputs, clock=SimulationClock(), rater=answers("7", "6", "3", "4"), **kwargs)


def in_thread(target, *args) -> threading.Thread:
    thread = threading.Thread(target=target, args=args, daemon=True)
    thread.start()
    return thread


def wait(driver, script: str, what: str, *args):
    """The first truthy value of ``script`` in the page, polled; fails after ``WAIT_S`` naming ``what``."""
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(driver, WAIT_S, poll_frequency=0.1).until(
        lambda d: d.execute_script(script, *args), f"waited {WAIT_S:g} s for {what}; the page showed: "
                                                   f"{page_text(driver)[:3000]}")


SHOWN = """
const row = document.querySelector(`tr[data-participant="${arguments[0]}"][data-session]`);
if (!row) return null;
const task = row.querySelector('.progress').textContent.match(/task (\\d+) of (\\d+)/);
const frames = row.querySelector('.frames');
const done = row.querySelector('.where').textContent.match(/(\\d+) of (\\d+) tasks/);
return {status: row.dataset.status, task: task && +task[1], frames: frames && +frames.textContent,
        done: +done[1], tasks: +done[2], updates: window.microg.updates};
"""
"""What the page shows of a participant's session: its status, the running task and its frames logged."""


def shown(driver, pid: str) -> dict | None:
    return driver.execute_script(SHOWN, pid)


def moving(driver, pid: str, before: dict) -> dict | None:
    """The session as shown once its running task is further on than ``before`` (a later task, or more frames)."""
    now = shown(driver, pid)
    return now if now and now["status"] == "running" and now["task"] is not None and \
        (now["task"], now["frames"]) > (before["task"], before["frames"]) else None


def handshake(url: str, origin: str, context: ssl.SSLContext | None = None) -> tuple[int, dict | None]:
    """The HTTP status a WebSocket handshake from a page of ``origin`` gets, and the first message after it."""
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    try:
        with connect(url, origin=origin, open_timeout=WAIT_S, ssl=context) as page:
            return 101, json.loads(page.recv(timeout=WAIT_S))
    except InvalidStatus as error:
        return error.response.status_code, None


def http_status(url: str, context: ssl.SSLContext | None = None) -> int:
    try:
        with urllib.request.urlopen(url, timeout=WAIT_S, context=context) as answer:
            return answer.status
    except urllib.error.HTTPError as error:
        return error.code


@needs_browser
def test_two_sessions_run_live_on_the_dashboard_then_end_and_its_numbers_are_the_exports(tmp_path):
    folder = tmp_path / "study"
    enrol(folder, [("P01", "female"), ("P02", "male"), ("P03", "female"), ("P04", "male"), ("P05", "female")])
    for pid, script in (("P03", {}), ("P04", {"drop_at_place": 1}), ("P05", {})):
        run_one(folder, pid, scripted_inputs(**script))
    with open_study(folder) as store:
        store.withdraw("P05", "moved away")

    with open_study(folder, readonly=True) as store, Dashboard(store) as board, chromium(WINDOW) as driver:
        driver.get(board.url)
        wait(driver, "return window.microg.updates > 0", "the first overview")
        assert "Participants and sessions" in page_text(driver)
        # P01 paced at real time; P02 unpaced, but held after each frame batch until the test lets it on
        paced = in_thread(run_one, folder, "P01", PacedInputs(scripted_inputs(), 1.0))
        gate = threading.Semaphore(0)
        held = in_thread(run_one, folder, "P02", ScriptedInputs(
            lambda plan, seed: Gated(pinch_keyframes(plan), gate, store.protocol.frame_batch)))

        first = {}
        for pid in ("P01", "P02"):
            first[pid] = wait_until(lambda: (s := shown(driver, pid)) and s["status"] == "running" and s["frames"] and s,
                                    f"{pid}'s session shown running with frames logged",
                                    seen=lambda: shown(driver, pid))
        later = wait_until(lambda: moving(driver, "P01", first["P01"]), "P01's task shown further on",
                           seen=lambda: (first["P01"], shown(driver, "P01")), going=paced.is_alive)
        gate.release(3)  # three more batches of P02's
        wait_until(lambda: moving(driver, "P02", first["P02"]), "P02's task shown further on",
                   seen=lambda: (first["P02"], shown(driver, "P02")), going=held.is_alive)
        assert later["status"] == "running"
        gate.release(1_000_000)
        joined(paced, "P01's paced session")
        joined(held, "P02's session")
        for pid in ("P01", "P02"):
            done = wait_until(lambda: (s := shown(driver, pid)) and s["status"] != "running" and s,
                              f"{pid}'s session shown ended", seen=lambda: shown(driver, pid))
            assert done["done"] == done["tasks"] and done["status"] in ("completed", "incomplete"), done

        with open_study(folder, readonly=True) as fresh:
            trials = trials_table(fresh)
        kept = trials[~trials["withdrawn"]]
        people = kept.drop_duplicates("participant")
        for group, members in people.groupby("group"):
            row = driver.execute_script("const r = document.querySelector(`#enrolment tr[data-group='${arguments[0]}']`);"
                                        " return [r.querySelector('.active').textContent, r.querySelector('.by')"
                                        ".textContent];", group)
            by = ", ".join(f"{g} {n}" for g, n in sorted(members["gender"].value_counts().items()))
            assert row == [str(len(members)), by], group
        measured = kept[kept["attempts"].notna()]
        means = measured.groupby(["phase", "group", "object"])[["time_s", "attempts"]].mean()
        rows = driver.execute_script("return [...document.querySelectorAll('#means tbody tr')].map(r => "
                                     "[r.dataset.phase, r.dataset.group, r.dataset.object, "
                                     "r.querySelector('.time').textContent, r.querySelector('.attempts').textContent])")
        assert {tuple(r[:3]) for r in rows} == set(means.index)
        for phase, group, obj, time_s, attempts in rows:
            expected = means.loc[(phase, group, obj)]
            assert time_s == ("–" if pd.isna(expected["time_s"]) else f"{expected['time_s']:.2f}")
            assert attempts == f"{expected['attempts']:.2f}"
        assert any(r[4] != "0.00" for r in rows)  # P04's drop is in a mean
        assert driver.execute_script("return document.querySelectorAll('#results canvas').length") == \
            2 * measured["phase"].nunique()

        # the view of a session, from its row
        session = int(trials.loc[trials["participant"] == "P03", "session_id"].iloc[0])
        driver.execute_script("document.querySelector(`button.view[data-session='${arguments[0]}']`).click()", session)
        view = wait(driver, "const v = window.microg.views[arguments[0]]; return v && (v.url || v.why) && v;",
                    "the address of the session's view", session)
        assert view.get("url", "").startswith("http://127.0.0.1:"), view
        assert http_status(view["url"]) == 200
        page = driver.current_window_handle
        driver.switch_to.window(next(handle for handle in driver.window_handles if handle != page))
        wait_until(lambda: driver.current_url.rstrip("/") == view["url"].rstrip("/"),
                   "the tab the click opened to go to the view", seen=lambda: driver.current_url)
        driver.close()  # the view's page draws in 3D: not on this machine's two cores for the rest of the test
        driver.switch_to.window(page)

        # other pages and a wrong token are refused; the page's own origin with the token is served
        own, ws = f"http://127.0.0.1:{board.server.port}", f"ws://127.0.0.1:{board.server.port}/ws"
        token = board.server.token
        status, message = handshake(f"{ws}?token={token}", own)
        assert status == 101 and message["type"] == "overview" and message["study"]["name"] == store.name
        assert handshake(f"{ws}?token={token}", "http://evil.example")[0] == 403
        assert handshake(f"{ws}?token={token}", f"http://127.0.0.1:{board.server.port + 1}")[0] == 403
        assert handshake(f"{ws}?token={token[:-1]}x", own)[0] == 403
        assert handshake(ws, own)[0] == 403
        assert http_status(f"{own}/report?token=wrong") == 403


@needs_browser
def test_a_store_damaged_under_the_dashboard_is_said_so_as_soon_as_a_writer_finds_it(tmp_path):
    folder = tmp_path / "study"
    enrol(folder, [("P01", "female")], protocol="tiny-long-batches")
    run_one(folder, "P01", scripted_inputs())
    add = ("participant", "add", str(folder), "--gender", "male", "--age", "30", "--handedness", "left",
           "--mr-experience", "no")
    assert CliRunner().invoke(main, [*add, "--id", "P02"]).exit_code == 0  # a writer's check vouches for the file
    with open_study(folder, readonly=True, accept_damaged=True) as store, Dashboard(store) as board, \
            chromium(WINDOW) as driver:
        driver.get(board.url)
        wait(driver, "return window.microg.updates > 0", "the first overview")
        integrity = driver.find_element("id", "integrity")
        assert integrity.get_attribute("class") == "integrity sound" and integrity.text.startswith("Sound: last check")
        damage_frames_page(folder, "overflow")
        refused = CliRunner().invoke(main, [*add, "--id", "P03"])
        assert refused.exit_code == 1 and "the study is damaged" in refused.output
        wait(driver, "return document.getElementById('integrity').classList.contains('damaged')",
             "the page to say the study is damaged")
        said = driver.find_element("id", "integrity").text
        assert said.startswith("The study is damaged (1 problem") and DAMAGED_BATCH.search(said), said
        assert f"microg study check {folder}" in said

    with open_study(folder, readonly=True, accept_damaged=True) as store, Dashboard(store) as board, \
            chromium(WINDOW) as driver:  # opened damaged: its own check on open finds it
        assert store.problems
        driver.get(board.url)
        wait(driver, "return document.getElementById('integrity').classList.contains('damaged')",
             "the page of a study opened damaged to say so")
        assert DAMAGED_BATCH.search(driver.find_element("id", "integrity").text)


class Tracker:
    """A live tracker at ``RATE`` frames a second of the wall clock, showing the scripted pinch: each
    frame is the hand at the tracker's time, and a frame the session was too late to take is gone (the
    tracker hands out its newest), so a session held up logs fewer frames per second of their times."""

    def __init__(self, keyframes):
        self.pinch, self.description = ScriptedPinch(keyframes), "tracked scripted pinch"
        self.origin: float | None = None

    def next_frame(self, observation=None):
        from tests.study.scripted import RATE

        now = time.monotonic()
        if self.origin is None:
            self.origin = now
        tick = max(self.pinch.index, int((now - self.origin) * RATE))  # the newest; never one twice
        due = self.origin + tick / RATE
        if due > now:
            time.sleep(due - now)
        self.pinch.index = tick
        return self.pinch.next_frame(observation)

    def close(self) -> None:
        pass


def stored(folder, sql: str, *args) -> list:
    """Rows of a query on the study's database, read-only (no check on open: a test reading while a session runs)."""
    import sqlite3

    with contextlib.closing(sqlite3.connect(f"file:{folder / 'study.db'}?mode=ro", uri=True)) as db:
        return db.execute(sql, args).fetchall()


def logged_rate(folder, pid: str) -> float:
    """Frames per second of the frames' own times, over the runs of ``pid``'s session, from the store."""
    runs = stored(folder, "SELECT SUM(f.count), MAX(f.t_last) - MIN(f.t_first) FROM frames f JOIN task_runs r "
                          "ON r.id = f.run_id JOIN sessions s ON s.id = r.session_id WHERE s.participant_id = ? "
                          "GROUP BY f.run_id", pid)
    return sum(n - 1 for n, _ in runs) / sum(span for _, span in runs)


def test_the_dashboard_reading_leaves_a_sessions_logged_frame_rate_as_it_was(tmp_path):
    """Three sessions from a live-like tracker at 110 Hz (``Tracker``): alone, then with the dashboard
    reading the study twice a second and a page connected, then (the control) with another program
    holding the database's write lock for three seconds in the middle of a task. The frame rate
    each logged (from the store's frame times) with the dashboard is within 10 % of the lower of the
    tracker's rate and the rate logged alone; the control's is not, so the measure would see a
    session held up."""
    from websockets.sync.client import connect

    from tests.study.scripted import RATE

    folder = tmp_path / "study"
    enrol(folder, [("P01", "female"), ("P02", "female"), ("P03", "female")])
    tracked = lambda: ScriptedInputs(lambda plan, seed: Tracker(pinch_keyframes(plan)), spec="tracked")
    run_one(folder, "P01", tracked())
    alone = logged_rate(folder, "P01")

    with open_study(folder, readonly=True) as store, Dashboard(store) as board:
        port = board.server.port
        with connect(f"ws://127.0.0.1:{port}/ws?token={board.server.token}", origin=f"http://127.0.0.1:{port}",
                     open_timeout=WAIT_S) as page:
            received = []
            reader = in_thread(lambda: [received.append(json.loads(m)) for m in page])
            run_one(folder, "P02", tracked())
            wait_until(lambda: any(s["participant"] == "P02" and s["status"] != "running" for m in received[-3:]
                                   for s in m["sessions"]), "the page to get P02's session ended",
                       seen=lambda: len(received))
        reader.join(WAIT_S)
    read = logged_rate(folder, "P02")
    running = [m for m in received if any(s["running"] for s in m["sessions"])]
    assert len(running) >= 5  # the dashboard read and pushed while the session ran

    def hold_the_lock() -> None:
        import sqlite3

        wait_until(lambda: query_frames(folder, "P03") >= 2 * 32, "P03's first task to log frames")
        db = sqlite3.connect(folder / "study.db", isolation_level=None)
        db.execute("BEGIN IMMEDIATE")
        time.sleep(3.0)  # another program holding the lock: the session waits it out (nothing timed is asserted)
        db.execute("COMMIT")
        db.close()

    holder = in_thread(hold_the_lock)
    run_one(folder, "P03", tracked())
    joined(holder, "the lock holder")
    held = logged_rate(folder, "P03")
    reference = min(RATE, alone)
    print(f"frames logged per second: alone {alone:.2f}, with the dashboard reading {read:.2f}, "
          f"with the write lock held 3 s {held:.2f} (tracker {RATE:g})")
    assert read >= 0.9 * reference, (read, alone)
    assert held < 0.9 * reference, (held, alone)


def query_frames(folder, pid: str) -> int:
    return stored(folder, "SELECT COALESCE(SUM(f.count), 0) FROM frames f JOIN task_runs r ON r.id = f.run_id "
                          "JOIN sessions s ON s.id = r.session_id WHERE s.participant_id = ?", pid)[0][0]


def test_microg_dashboard_off_loopback_serves_over_https_with_the_studys_certificate_and_stops_on_sigterm(tmp_path):
    folder = tmp_path / "study"
    enrol(folder, [("P01", "female")])
    assert "--host" in CliRunner().invoke(main, ["dashboard", "--help"]).output
    child = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "dashboard", str(folder),
                              "--host", LAN], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        lines = line_reader(child.stdout)
        said = []
        while not (said and said[-1].startswith("Ctrl-C stops it")):
            line = next_item(lines, "the dashboard to say where it is", seen=lambda: said)
            assert line is not None, said
            said.append(line)
        url = next(re.search(r"dashboard: (\S+)", line).group(1) for line in said if line.startswith("dashboard: "))
        assert url.startswith(f"https://{LAN}:") and "?token=" in url
        assert any("HTTPS certificate SHA-256" in line for line in said)
        context = ssl.create_default_context(cafile=str(folder / "tls" / "cert.pem"))
        assert http_status(url, context) == 200
        origin, token = url.split("/?token=")
        status, message = handshake(f"wss://{origin.split('://')[1]}/ws?token={token}", origin, context)
        assert status == 101 and message["type"] == "overview" and message["participants"][0]["id"] == "P01"
        assert handshake(f"wss://{origin.split('://')[1]}/ws?token={token}", f"http://{LAN}:1", context)[0] == 403
    finally:
        child.terminate()
    assert ended(child, "microg dashboard after SIGTERM") == 0
    rest = []
    while (line := next_item(lines, "the dashboard's last words")) is not None:
        rest.append(line)
    assert rest[-1].strip() == "dashboard stopped", rest
