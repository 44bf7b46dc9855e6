"""The participant's view in a real browser: served by the session, drawn where the physics puts
things, lighting the places, and answering the questionnaire on the page."""

from __future__ import annotations

import asyncio
import io
import threading

import numpy as np
import pytest
from PIL import Image

from microg.bench.display import IWER, emulate_headset, enter_and_place
from microg.study import framelog
from microg.study.inputs import PacedInputs
from microg.study.protocol import load_protocol
from microg.study.session import Outputs, SimulationClock, Unattended, run_session
from microg.study.assignment import Participant
from microg.study.export import trials_table
from microg.study.store import Event, create_study, open_study
from microg.view.display import DisplayOperator, DisplayRater, ParticipantDisplay

from tests.study.conftest import PROTOCOLS, scripted_inputs

from .browser import MISSING, chromium, page_text
from .conftest import colour_mask, new_study, pixels_near

needs_browser = pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium "
                                                         "chromium-driver; pip install selenium)")
WINDOW = (1000, 700)
WORK_S = 300.0
"""A generous bound for a tiny session on a loaded machine: the waits below end on events, this
only keeps a broken run from hanging."""


class GatedSink:
    """The display taking each frame once ``gate`` is open (a test holds the session still)."""

    def __init__(self, display: ParticipantDisplay, gate: threading.Event):
        self.display, self.gate = display, gate

    def take(self, moment) -> None:
        self.gate.wait(WORK_S)
        self.display.take(moment)


def session_with_display(folder, display: ParticipantDisplay, gate: threading.Event) -> threading.Thread:
    """P01's session, paced at real time, shown on ``display``, answered on its page; each frame
    waits for ``gate`` to be open."""
    def run():
        with open_study(folder) as store:
            session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")

            def rejected(question, text, message):
                store.log(session.id, [Event(0.0, "answer_rejected", {"item": question.item.id, "answer": text})])

            run_session(store, session.id, PacedInputs(scripted_inputs(), speed=1.0), clock=SimulationClock(),
                        operator=DisplayOperator(display, Unattended()), rater=DisplayRater(display, rejected),
                        outputs=Outputs(sinks=(GatedSink(display, gate),)))

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def wait(driver, script: str, what: str = ""):
    """The first truthy value of ``script`` in the page, polled; fails after ``WORK_S`` naming ``what``
    it waited for (the script itself when not given)."""
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(driver, WORK_S, poll_frequency=0.05).until(
        lambda d: d.execute_script(script), f"waited {WORK_S:g} s for {what or script}")


def picture_at(driver, level: dict) -> np.ndarray:
    """A screenshot of the picture held still, drawn at ``level`` ({scale, antialias}) once the
    page has drawn it there (its drawing buffer is the viewport times the scale) and shown it
    unchanged for two animation frames."""
    driver.execute_script("window.microg.quality.fix(arguments[0])", level)
    drawn = wait(driver, "const p = window.microg.picture; return p.level === window.microg.quality.level "
                         "&& [p.width, p.height, p.frame];")
    size = np.array(driver.execute_script("return [innerWidth, innerHeight]"))
    assert np.array_equal(drawn[:2], np.floor(size * level["scale"])), (level, drawn)
    # still: no new picture for two animation frames (a new renderer may draw more than once at its level)
    wait(driver, "const m = window.microg, p = m.picture; "
                 "if (!m.still || m.still.frame !== p.frame) { m.still = {frame: p.frame, at: m.animationFrames}; "
                 "return false; } return p.level === m.quality.level && m.animationFrames > m.still.at + 1;",
         f"the picture drawn at {level} to stay unchanged for two animation frames")
    return np.asarray(Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB"))


@needs_browser
def test_the_participant_sees_the_task_where_the_physics_puts_it_and_answers_on_the_page(tmp_path):
    from selenium.webdriver.common.by import By

    folder = new_study(tmp_path / "study")
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    events = []
    with ParticipantDisplay(protocol, on_event=lambda kind, data: events.append((kind, data))) as display, \
            chromium(WINDOW) as driver:
        assert display.url.startswith("http://127.0.0.1:")
        driver.get(display.url)
        wait(driver, "return document.body.innerText.includes('Waiting for the session')")
        gate = threading.Event()
        gate.set()
        session = session_with_display(folder, display, gate)

        # A place lights up when the object arrives there, held: hold the picture and the session
        # still then (no next task's scene), and draw the picture at the best level, the lowest
        # resolution, and with antialiasing (a new renderer).
        drawn = wait(driver, "const d = window.microg.drawn; if (d && d.lit && d.hands.length) "
                             "{ window.microg.hold = true; return d; } return null;")
        gate.clear()
        project = lambda point: driver.execute_script("return window.microg.project(...arguments)", *point)
        obj = project(drawn["object"][:3])
        place = np.asarray(wait(driver, "return window.microg.scene")["places"][drawn["place"]])
        ring = np.hypot(*np.subtract(project(place + [0.04, 0, 0]), project(place)))
        hand = drawn["hands"][0]
        touching = [np.add(s, e) / 2 for s, e, t in zip(hand["start"], hand["end"], hand["touching"]) if t]
        assert touching, "the drawn hand holds the object: some phalanx touches it"
        ladder = driver.execute_script("return window.microg.quality.levels")
        for level in (ladder[0], ladder[-1], {"scale": 0.6, "antialias": True}):
            picture = picture_at(driver, level)
            assert pixels_near(colour_mask(picture, "object"), obj, 25) > 400, level
            assert pixels_near(colour_mask(picture, "lit"), project(place), ring * 1.3) > 150, level
            for centre in touching:
                assert pixels_near(colour_mask(picture, "highlight"), project(centre), 20) > 40, level
        assert "Place" in page_text(driver) and "lit" in page_text(driver)
        driver.execute_script("window.microg.quality.release(); window.microg.hold = false")
        gate.set()

        # The questionnaire on the page: an answer off the scale is refused and logged, then one counts.
        wait(driver, "return window.microg.question && !document.getElementById('question').hidden")
        body = driver.find_element(By.TAG_NAME, "body")
        body.send_keys("99\n")
        wait(driver, "return document.getElementById('question-note').classList.contains('rejected')")
        assert "off the scale" in page_text(driver)
        for answered, rating in enumerate(("7", "6", "3", "4"), start=1):
            wait(driver, f"return window.microg.answered === {answered - 1} "
                         "&& !document.getElementById('question').hidden")
            driver.find_element(By.CSS_SELECTOR, f"#scale button[data-value='{rating}']").click()
            wait(driver, f"return window.microg.answered === {answered}")
        session.join(WORK_S)
        assert not session.is_alive()
    # the session heard of each level the page drew at, with its drawing buffer's size
    levels = {(data["render_scale"], data["render_width"]) for kind, data in events if kind == "display_quality"}
    assert {(0.25, 250), (0.6, 600)} <= levels

    with open_study(folder) as store:
        session_id = store.session_of("P01").id
        assert store.session(session_id).status == "completed"
        assert sorted(store.answers(session_id).values()) == [3, 4, 6, 7]
        assert [e.data["answer"] for e in store.events(session_id) if e.kind == "answer_rejected"] == ["99"]
        # what the page drew is the physics' outcome for that frame, as the log keeps it
        run = next(r for r in store.runs(session_id) if r.task_index == next(
            t.index for t in store.tasks(session_id) if t.object == "cube"))
        frames = framelog.read(store.db, run.id)
        row = frames[np.flatnonzero(frames["t"] == drawn["t"])]
        assert len(row) == 1
        assert np.allclose(row["position"][0], drawn["object"][:3], atol=2e-6)


class OnePhase(Unattended):
    """Runs the tasks of one phase and skips the others (a short session)."""

    def __init__(self, phase: str):
        self.phase = phase

    def ready(self, task) -> bool:
        return task.phase == self.phase


CLOCK_DRIFT_MS = 10.0


@needs_browser
def test_a_phase_with_added_latency_shows_no_frame_before_it_is_due(tmp_path):
    """Issue 24: the page draws each frame of a phase with ``added_latency_ms`` no earlier than its
    physics was ready plus that much, by the page's own reports (its clock synced to the session's:
    within half the quickest ping round trip and the offsets' spread); the session logs the setting."""
    path = tmp_path / "delayed.toml"
    path.write_text(f'extends = "{PROTOCOLS / "tiny.toml"}"\nname = "delayed"\n'
                    '[[phases]]\nname = "stage1"\ninteraction = "impulse_penetration"\nlabel = "System 1"\n'
                    'added_latency_ms = 150\n'
                    '[[phases]]\nname = "stage2"\ninteraction = "soft_hand"\nlabel = "System 2"\n')
    protocol = load_protocol(path)
    with create_study(tmp_path / "study", protocol, seed=1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
    events = []
    with ParticipantDisplay(protocol, on_event=lambda kind, data: events.append((kind, data))) as display, \
            chromium(WINDOW) as driver:
        driver.get(display.url + "?latency=1")
        wait(driver, "return window.microg.clock")

        def run():
            with open_study(tmp_path / "study") as store:
                session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
                run_session(store, session.id, PacedInputs(scripted_inputs(), speed=2.0), clock=SimulationClock(),
                            operator=DisplayOperator(display, OnePhase("stage1")), outputs=Outputs(sinks=(display,)))

        session = threading.Thread(target=run, daemon=True)
        session.start()
        session.join(WORK_S)
        assert not session.is_alive(), f"the session did not end within {WORK_S:g} s"
        clock = display.clock
    shown = [d for d in display.drawn if d["due_ms"] is not None]
    assert len(shown) > 10, f"the page drew {len(shown)} frames of the delayed phase: {list(display.drawn)[-3:]}"
    # the clocks were lined up once, before the phase: allow them 10 ms of drift over the run (2 ms
    # seen on a quiet machine), far below the 150 ms the frames are held (without the hold they
    # are drawn about 150 ms before due)
    slack = clock["rtt_ms"] / 2 + clock["spread_ms"] + CLOCK_DRIFT_MS
    early = [d for d in shown if d["drawn_ms"] < d["due_ms"] - slack]
    assert not early, (f"{len(early)} of {len(shown)} frames drawn before due (clock slack {slack:.2f} ms), e.g. "
                       f"{early[0]}")
    assert [(d["phase"], d["added_latency_ms"]) for kind, d in events if kind == "display_latency"] == [
        ("stage1", 150.0)]
    # the trials table carries it: latency can be a factor of the analysis
    with open_study(tmp_path / "study") as store:
        trials = trials_table(store)
    assert {p: set(t["added_latency_ms"]) for p, t in trials.groupby("phase")} == {
        p: {150.0 if p == "stage1" else 0.0} for p in trials["phase"]}


def refused(url: str, origin: str) -> bool:
    """True when the server refuses a WebSocket from a page of ``origin``."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import InvalidStatus

    async def attempt():
        try:
            async with connect(url, origin=origin, open_timeout=WORK_S):
                return False
        except InvalidStatus as error:
            return error.response.status_code == 403

    return asyncio.run(attempt())


def test_the_participant_page_refuses_a_foreign_origin(tmp_path):
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    with ParticipantDisplay(protocol) as display:
        ws = f"ws://127.0.0.1:{display.port}/ws"
        assert refused(ws, "http://evil.example")
        assert refused(ws, f"http://127.0.0.1:{display.port + 1}")
        assert not refused(ws, f"http://127.0.0.1:{display.port}")


@needs_browser
def test_a_mesh_object_is_drawn_from_its_own_triangles(tmp_path):
    from microg.study.store import PlannedTask
    from microg.view.scene import task_layout

    protocol = load_protocol(PROTOCOLS / "quick-mallet.toml")
    mallet = protocol.objects[0]
    layout = task_layout(protocol, mallet.name)
    with ParticipantDisplay(protocol) as display, chromium(WINDOW) as driver:
        driver.get(display.url)
        wait(driver, "return document.body.innerText.includes('Waiting for the session')")
        display.get_ready(PlannedTask(0, protocol.phases[0].name, protocol.phases[0].interaction, mallet.name,
                                      mallet.code, 1))
        drawn = wait(driver, "const o = window.microg.workspace.object; return o && window.microg.scene "
                             "&& {triangles: o.geometry.attributes.position.count / 3, "
                             "position: o.position.toArray()};")
        picture = np.asarray(Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB"))
        project = lambda point: driver.execute_script("return window.microg.project(...arguments)", *point)
        assert drawn["triangles"] == len(layout.surface[1]) == len(mallet.spec.mesh.faces)
        assert np.allclose(drawn["position"], layout.start)
        # the T's ends are drawn: object pixels near each vertex the camera sees farthest apart
        corners = layout.start + layout.surface[0]
        pixels = np.array([project(c) for c in corners])
        ends = corners[[np.argmin(pixels[:, 0]), np.argmax(pixels[:, 0])]]
        for end in ends:
            assert pixels_near(colour_mask(picture, "object"), project(end), 12) > 20


@needs_browser
def test_the_participant_sees_a_sends_target_zone_and_no_place(tmp_path):
    from microg.paths import PROTOCOLS as SHIPPED
    from microg.study.store import PlannedTask
    from microg.view.scene import task_layout

    protocol = load_protocol(SHIPPED / "microgravity-skills.toml")
    layout = task_layout(protocol, "cube", "sending")
    with ParticipantDisplay(protocol) as display, chromium(WINDOW) as driver:
        driver.get(display.url)
        wait(driver, "return document.body.innerText.includes('Waiting for the session')")
        display.get_ready(PlannedTask(3, "sending", "impulse_penetration", "cube", "C", 1))
        scene = wait(driver, "const s = window.microg.scene; return s && s.kind === 'send' && s;")
        picture = np.asarray(Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB"))
        project = lambda point: driver.execute_script("return window.microg.project(...arguments)", *point)
        centre = project(layout.target)
        side = project(layout.target + [layout.target_radius, 0, 0])
    assert scene["places"] == [] and scene["target"]["centre"] == layout.target.tolist()
    reach = 1.3 * np.hypot(*np.subtract(side, centre))
    zone = colour_mask(picture, "target")
    assert pixels_near(zone, centre, reach) > 150 and zone.sum() == pixels_near(zone, centre, reach)


@needs_browser
def test_the_participant_page_of_a_handover_knows_which_hand_takes_the_object(tmp_path):
    from microg.study.store import PlannedTask

    protocol = load_protocol(PROTOCOLS / "handover.toml")
    with ParticipantDisplay(protocol) as display, chromium(WINDOW) as driver:
        driver.get(display.url)
        wait(driver, "return document.body.innerText.includes('Waiting for the session')")
        display.get_ready(PlannedTask(0, "passing", "impulse_penetration", "cube", "C", 1))
        scene = wait(driver, "const s = window.microg.scene; return s && s.kind === 'handover' && s;")
    assert scene["first_hand"] == protocol.task.handover.first_hand == "right"
    assert scene["target"]["centre"] == list(protocol.task.handover.place) and scene["places"] == []


@pytest.mark.slow
@needs_browser
@pytest.mark.skipif(not IWER.exists(), reason=f"needs iwer (WebXR emulation: npm ci), missing at {IWER}")
def test_a_headset_draws_the_best_level_and_leaving_it_the_screen_draws_at_its_own_again(tmp_path):
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    with ParticipantDisplay(protocol) as display, chromium(WINDOW) as driver:
        emulate_headset(driver)
        driver.get(display.url)
        screen = {"scale": 0.5, "antialias": False}
        driver.execute_script("window.microg.quality.fix(arguments[0])", screen)
        enter_and_place(driver)
        best = driver.execute_script("return window.microg.quality.levels[0]")
        assert driver.execute_script("return window.microg.quality.level") == best
        driver.execute_script("window.emulatedHeadset.activeSession.end()")
        wait(driver, "return window.microg.xr.step === 'off' && !window.microg.renderer.xr.isPresenting")
        picture = wait(driver, "window.microg.dirty = true; const p = window.microg.picture; "
                               "return p.level === window.microg.quality.level && [p.level, p.width, p.height]")
        assert picture == [screen, WINDOW[0] * 0.5, WINDOW[1] * 0.5]


@needs_browser
def test_a_trainee_reads_under_a_tasks_cue_how_far_they_are_from_the_criterion(tmp_path):
    """A phase trained to a criterion: after the task's cue the page adds what the session says of
    the criterion (``Operator.progressed``: "One more clean task in a row")."""
    from microg.paths import protocol_file
    from microg.study.progression import FinishedTask, progress
    from microg.study.store import PlannedTask

    protocol = load_protocol(protocol_file("microgravity-training"))
    said = progress(protocol.phase("trainpaper").until, [FinishedTask("C", True, 20.0, 0)]).describe()
    with ParticipantDisplay(protocol) as display, chromium(WINDOW) as driver:
        driver.get(display.url)
        wait(driver, "return document.body.innerText.includes('Waiting for the session')")
        task = PlannedTask(0, "trainpaper", "impulse_penetration", "cube", "C", 1)
        display.get_ready(task)
        display.task_started(task)
        display.task_finished(task, "completed", 20.0)
        display.progressed(said)
        shown = wait(driver, f"const m = document.getElementById('message-text').textContent; "
                             f"return m.includes({said!r}) && m;", "the criterion's progress under the cue")
    assert said == "One more clean task in a row" and shown.startswith("Completed in 20.0 s")
