"""The headset mode in a real browser under Meta's WebXR emulation runtime (iwer, injected by the
test, never part of the page): entering the immersive session, placing the workspace, an emulated
hand that closes on the cube and carries it through the places as ``--input webxr`` (the session's
own guard, filter, physics and log), the questionnaire answered in 3D by poking and by pinching,
and the session logged and exported like any other."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from microg.bench import display as bench
from microg.hands import load_recording
from microg.hands.webxr import XR_JOINTS, WebXRSource, hand_from_webxr
from microg.study import framelog
from microg.study.assignment import Participant
from microg.study.export import export_study, read_tables, run_frames, run_list
from microg.study.inputs import open_inputs
from microg.study.protocol import load_protocol
from microg.study.session import EventLog, Outputs, WallClock, run_session
from microg.study.store import Event, create_study, open_study
from microg.view.display import DisplayOperator, DisplayRater, ParticipantDisplay
from tests.study.conftest import PROTOCOLS, scripted_inputs

from .browser import MISSING

needs_headset = pytest.mark.skipif(bool(MISSING) or not bench.IWER.exists(),
                                   reason=f"needs {MISSING or 'iwer'} (apt-get install chromium chromium-driver; "
                                          "pip install selenium; npm ci)")
WINDOW = (480, 360)
WORK_S = 300.0
"""A generous bound for a browser, a session and a hand on a loaded machine: every wait below ends
on an event; this only keeps a broken run from hanging."""

WIDEN = 0.7
"""The open hand: iwer's relaxed pose moved this much further away from its pinch pose, so that
thumb and index open wider than the 6 cm cube (iwer's relaxed hand is a little narrower)."""
CLOSED = 0.475
"""The pinch value at which thumb and index squeeze the cube a few millimetres."""
GRIP_OUT = 0.02
"""m: the cube sits this much further out than the middle of thumb and index, off the hand's web."""
OPEN_HAND = f"""
(() => {{
  const poses = window.emulatedHeadset.hands.right[IWER.P_HAND_INPUT].poses;  // both hands share them
  const open = {{ jointTransforms: {{}} }};
  for (const [joint, {{ offsetMatrix, radius }}] of Object.entries(poses.default.jointTransforms)) {{
    const m = new Float32Array(offsetMatrix), pinch = poses.pinch.jointTransforms[joint].offsetMatrix;
    for (const i of [12, 13, 14]) m[i] += {WIDEN} * (m[i] - pinch[i]);
    open.jointTransforms[joint] = {{ offsetMatrix: m, radius }};
  }}
  poses.open = open;
  for (const hand of Object.values(window.emulatedHeadset.hands)) hand.poseId = "open";
  window.emulatedHeadset.hands.left.connected = false;
}})();
"""
"""The test's hand: open wider than iwer's relaxed pose, closing into iwer's pinch; the right hand only."""
POSE_DATA = """
const names = Object.keys(window.emulatedHeadset.hands.right[IWER.P_HAND_INPUT].poses.open.jointTransforms);
const poses = window.emulatedHeadset.hands.right[IWER.P_HAND_INPUT].poses;
const part = (pose, f) => names.map((joint) => f(pose.jointTransforms[joint]));
return { names, open: part(poses.open, (j) => Array.from(j.offsetMatrix.slice(12, 15))),
         pinch: part(poses.pinch, (j) => Array.from(j.offsetMatrix.slice(12, 15))),
         open_radii: part(poses.open, (j) => j.radius), pinch_radii: part(poses.pinch, (j) => j.radius) };
"""


class EmulatedHand:
    """The emulated right hand's geometry (iwer's poses, read from the page): its joints in its own
    frame for a pinch value, and where on the hand the cube goes."""

    def __init__(self, data: dict):
        assert tuple(data["names"]) == XR_JOINTS  # iwer's poses list the joints in WebXR's order
        mirror = np.array([-1.0, 1.0, 1.0])  # iwer mirrors its left-hand poses for the right hand
        self.open, self.pinch = np.asarray(data["open"]) * mirror, np.asarray(data["pinch"]) * mirror
        self.open_radii, self.pinch_radii = np.asarray(data["open_radii"]), np.asarray(data["pinch_radii"])

    def local(self, pinch: float):
        """(25, 3) joints and (25,) radii in the hand's own frame (iwer blends the two poses)."""
        return (1 - pinch) * self.open + pinch * self.pinch, (1 - pinch) * self.open_radii + pinch * self.pinch_radii

    def grip(self, pinch: float) -> np.ndarray:
        """Between the thumb's distal phalanx and the index's distal joint: where the cube goes."""
        joints, radii = self.local(pinch)
        centres = hand_from_webxr("right", joints, radii).bone_centres
        return 0.5 * (centres[0, 3] + 0.5 * (centres[1, 2] + centres[1, 3]))

    def grasp_rotation(self) -> tuple[Rotation, np.ndarray]:
        """The hand turned so that thumb and index close along the workspace's x, the hand coming
        down from above (its web up); and the hand's outward direction (local frame)."""
        joints, radii = self.local(0.0)
        centres = hand_from_webxr("right", joints, radii).bone_centres
        across = 0.5 * (centres[1, 2] + centres[1, 3]) - centres[0, 3]
        across /= np.linalg.norm(across)
        out = self.grip(0.0) - 0.5 * (joints[2] + joints[6])
        out -= across * (out @ across)
        out /= np.linalg.norm(out)
        rotation, _ = Rotation.align_vectors([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0]], [across, out])
        return rotation, out


def transform(anchor, point) -> np.ndarray:
    """A workspace point in the XR space."""
    return (np.asarray(anchor).reshape(4, 4) @ np.append(point, 1.0))[:3]


def key(position, rotation: Rotation, pinch: float, frames: int, until: str | None = None) -> dict:
    return {"position": [float(v) for v in position], "quaternion": rotation.as_quat().tolist(),
            "pinch": float(pinch), "frames": frames, **({"until": until} if until else {})}


def grasp_path(hand: EmulatedHand, anchor, start, places, palm) -> list[dict]:
    """From the placement pose: up and round to above the cube, down around it, close, carry it
    through each place (waiting there until the place is done), open and withdraw."""
    yaw = Rotation.from_matrix(np.asarray(anchor).reshape(4, 4)[:3, :3])
    turned, out = hand.grasp_rotation()
    rotation = yaw * turned

    def at(point, pinch):  # the hand's pose that puts the cube's place in its grip at ``point``
        return transform(anchor, point) - rotation.apply(hand.grip(pinch) + GRIP_OUT * out)

    start, up, near = np.asarray(start), np.array([0.0, 0.14, 0.0]), np.array([0.0, 0.0, 0.25])
    keys = [key(palm, Rotation.identity(), 0.0, 0), key(at(start + up + near, 0.0), rotation, 0.0, 40),
            key(at(start + up, 0.0), rotation, 0.0, 30), key(at(start, 0.0), rotation, 0.0, 30),
            key(at(start, CLOSED), rotation, CLOSED, 40)]
    for k, place in enumerate(places):
        keys.append(key(at(np.asarray(place), CLOSED), rotation, CLOSED, 40, f"microg.latest.place > {k}"))
    last = np.asarray(places[-1])
    keys += [key(at(last, 0.0), rotation, 0.0, 20), key(at(last + up, 0.0), rotation, 0.0, 20)]
    return keys


def poke_path(hand: EmulatedHand, button: dict, answered: int, rest) -> list[dict]:
    """The index fingertip from ``rest`` to just in front of the button, onto its face until the
    answer is accepted, and back out."""
    tip = hand.local(0.0)[0][9]
    centre, normal = np.asarray(button["centre"]), np.asarray(button["normal"])
    place = lambda point: point - tip  # the hand unrotated: its fingertip at ``point``
    return [key(place(rest), Rotation.identity(), 0.0, 20), key(place(centre + 0.05 * normal), Rotation.identity(), 0.0, 30),
            key(place(centre - 0.004 * normal), Rotation.identity(), 0.0, 10, f"microg.answered > {answered}"),
            key(place(centre + 0.05 * normal), Rotation.identity(), 0.0, 10)]


def pinch_path(button: dict, answered: int) -> list[dict]:
    """The hand 20 cm in front of the button pointing at it (its ray is its -z), then a pinch until
    the answer is accepted, then open."""
    centre, normal = np.asarray(button["centre"]), np.asarray(button["normal"])
    up = np.cross(normal, np.cross([0.0, 1.0, 0.0], normal))
    up /= np.linalg.norm(up)
    aim = Rotation.from_matrix(np.column_stack([np.cross(up, normal), up, normal]))
    where = centre + 0.2 * normal
    return [key(where, aim, 0.0, 20), key(where, aim, 1.0, 0, f"microg.answered > {answered}"), key(where, aim, 0.0, 2)]


def wait(driver, script: str):
    return bench.wait_for(driver, script, WORK_S)


def wait_until(condition, what: str):
    """Poll a condition on the server's side until it holds (bounded by WORK_S)."""
    deadline = time.monotonic() + WORK_S
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(what)
        time.sleep(0.02)


def play(driver, keys: list[dict]) -> None:
    """Play the keyframes on the right hand and wait until they are done."""
    driver.execute_script("window.handPlayer.play('right', arguments[0])", keys)
    wait(driver, "return window.handPlayer.done('right')")


class StageOneOnly:
    """The researcher runs the first phase's cube only (training and stage2 skipped)."""

    def present(self, phase) -> None:
        pass

    def ready(self, task) -> bool:
        return task.phase == "stage1"

    def finished(self, task, status, time_s) -> None:
        pass


def headset_study(tmp_path):
    """The tiny protocol (the cube in microgravity, 0.5 s holds) with time for a browser's hand."""
    protocol_file = tmp_path / "headset.toml"
    protocol_file.write_text(f'extends = "{(PROTOCOLS / "tiny.toml").resolve()}"\nname = "headset"\n\n'
                             "[task]\ntimeout_s = 240.0\n")
    folder = tmp_path / "study"
    with create_study(folder, load_protocol(protocol_file), seed=1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
    return folder, load_protocol(protocol_file)


def session_in_background(folder, display: ParticipantDisplay, failures: list) -> threading.Thread:
    """P01's session with the hands from the page (``--input webxr``), the page's events logged
    with it by ``microg session run``'s logger."""
    def run():
        try:
            with open_study(folder) as store:
                inputs = open_inputs("webxr", webxr=display.hands)
                session = store.create_session("P01", input_spec=inputs.spec, simulated=inputs.simulated, clock=inputs.clock)
                clock = WallClock()
                display.on_event = EventLog(store, session.id, clock).emit

                def rejected(question, text, message):
                    store.log(session.id, [Event(clock.now(), "answer_rejected", {"answer": text})])

                try:
                    run_session(store, session.id, inputs, clock=clock, operator=DisplayOperator(display, StageOneOnly()),
                                rater=DisplayRater(display, rejected), outputs=Outputs(sinks=(display,)))
                finally:
                    inputs.close()
        except BaseException as error:  # the test reports it
            failures.append(error)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@needs_headset
def test_a_headset_hand_places_the_workspace_carries_the_cube_through_the_places_and_answers(tmp_path):
    folder, protocol = headset_study(tmp_path)
    failures: list[BaseException] = []
    # Every frame the page sends reaches the physics, however loaded the machine: this test checks
    # the carry, not how a session stays live when it falls behind (tested below, with a short backlog).
    source = WebXRSource(protocol.tracking_rate, backlog_s=WORK_S)
    with ParticipantDisplay(protocol, hands=source) as display, bench.chromium(WINDOW) as driver:
        bench.emulate_headset(driver)
        driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": OPEN_HAND})
        driver.get(display.url)
        session = session_in_background(folder, display, failures)

        # Entering: an immersive-ar session with hand tracking, the placement step first.
        wait(driver, "return document.getElementById('enter-xr')")
        assert driver.execute_script("return window.microg.xr.mode") == "immersive-ar"
        palm_at = (0.05, 1.0, -0.45)
        anchor = bench.enter_and_place(driver, palm_at)
        features, blend = driver.execute_script("const session = window.emulatedHeadset.activeSession; "
                                                "return [session.enabledFeatures, session.environmentBlendMode]")
        assert "hand-tracking" in features and blend == "alpha-blend"  # passthrough
        assert driver.execute_script("return window.microg.xr.space") == "local-floor"

        # Placement: the palm (the middle of the metacarpals) marks the workspace's mark point, the
        # fingers its -z, y stays up; the session holds the same anchor.
        hand = EmulatedHand(driver.execute_script(POSE_DATA))
        joints = hand.local(0.0)[0] + palm_at
        palm = 0.5 * (joints[[5, 10, 15, 20]] + joints[[6, 11, 16, 21]]).mean(axis=0)
        mark = driver.execute_script("return window.microg.layout.mark")
        assert np.allclose(transform(anchor, mark), palm, atol=1e-4)
        matrix = np.asarray(anchor).reshape(4, 4)
        assert np.allclose(matrix[:3, 1], [0, 1, 0]) and np.allclose(matrix[:3, :3].T @ matrix[:3, :3], np.eye(3))
        forward = joints[[6, 11, 16, 21]].mean(axis=0) - joints[0]
        assert np.dot(-matrix[[0, 2], 2], forward[[0, 2]]) / np.linalg.norm(forward[[0, 2]]) == pytest.approx(1.0)
        wait_until(lambda: display.placement is not None, "the session got the placement")
        assert np.allclose(display.placement, anchor)

        # The hand closes on the cube and carries it through the places, through the session, once
        # the session's physics runs the task (its first frame: a cold start compiles it first).
        wait(driver, "return window.microg.latest")
        start, _ = protocol.start_pose("cube")
        play(driver, grasp_path(hand, anchor, start, protocol.task.places, palm_at))
        assert not failures

        # The questionnaire in 3D: three answers poked with the index fingertip, one pinched.
        rest = transform(anchor, np.asarray(mark) + [0.0, 0.35, 0.4])
        for answered, (value, how) in enumerate(((7, "poke"), (6, "poke"), (3, "pinch"), (4, "poke"))):
            button = wait(driver, f"return !document.getElementById('question').hidden "
                                  f"&& window.microg.answered === {answered} && window.microg.xr.button({value})")
            play(driver, poke_path(hand, button, answered, rest) if how == "poke" else pinch_path(button, answered))
        session.join(WORK_S)
        assert not session.is_alive() and not failures
        pressed = driver.execute_script("return window.microg.xr.pressed")

    assert pressed == [7, 6, 3, 4]
    with open_study(folder) as store:
        session_id = store.session_of("P01").id
        events = store.events(session_id)
        placements = [e.data for e in events if e.kind == "display_placement"]
        assert len(placements) == 1 and np.allclose(placements[0]["anchor"], anchor)
        assert placements[0]["mode"] == "immersive-ar" and placements[0]["hand"] == "right"
        clocks = [e.data for e in events if e.kind == "display_clock"]
        assert clocks and all(np.isfinite(c["offset_ms"]) and c["spread_ms"] >= 0 for c in clocks)
        assert sorted(store.answers(session_id).values()) == [3, 4, 6, 7]

        task = next(t for t in store.tasks(session_id) if t.phase == "stage1")
        cube = next(r for r in store.runs(session_id) if r.task_index == task.index)
        assert cube.status == "completed"
        done = [e.data["place"] for e in store.events(session_id, cube.id) if e.kind == "place_done"]
        assert done == list(range(len(protocol.task.places)))
        frames = framelog.read(store.db, cube.id)
        right = frames["tracked"][:, 1]
        assert right.all(), "every frame of the run has the headset's right hand"
        # The mapping: widths from the joint radii, the thumb's zero-length metacarpal, the hand in
        # the workspace frame (holding the cube, its grip within reach of the object's centre).
        radii = hand.local(CLOSED)[1]
        grasped = frames[frames["held"]]
        assert len(grasped) and np.allclose(grasped["widths"][:, 1, 1, 3], radii[8] + radii[9], atol=2e-5)
        assert np.allclose(frames["joints"][:, 1, 0, 0], frames["joints"][:, 1, 0, 1])
        index_dip = grasped["joints"][:, 1, 1, 3]
        assert np.linalg.norm(index_dip - grasped["position"], axis=1).max() < 0.08
        # Stamped as the page measured them, counted from the headset's first frame (its clock rebased
        # once, at the input), in order.
        assert np.all(np.diff(frames["t"]) > 0) and 0 <= frames["t"][0] < frames["t"][-1] < WORK_S
        assert next(r for r in run_list(store) if r["run_id"] == cube.id)["source"] == "webxr"

    out = tmp_path / "export"
    export_study(folder, out, progress=False, say=lambda text: None)
    trials, answers = read_tables(out)
    row = trials[(trials["participant"] == "P01") & (trials["phase"] == "stage1")]
    assert list(row["status"]) == ["completed"] and len(answers) == 4
    with open_study(folder) as store:
        assert len(run_frames(store, cube.id)) == len(frames)


class NoTasks:
    """The researcher skips every task: the session is its questionnaire."""

    def present(self, phase) -> None:
        pass

    def ready(self, task) -> bool:
        return False

    def finished(self, task, status, time_s) -> None:
        pass


def press_path(hand: EmulatedHand, button: dict, answered: int) -> list[dict]:
    """The index fingertip to just in front of the button, onto its face until the answer is
    accepted, and back in front of it (the next poke starts from there)."""
    tip = hand.local(0.0)[0][9]
    centre, normal = np.asarray(button["centre"]), np.asarray(button["normal"])
    place = lambda point: point - tip  # the hand unrotated: its fingertip at ``point``
    return [key(place(centre + 0.04 * normal), Rotation.identity(), 0.0, 15),
            key(place(centre - 0.004 * normal), Rotation.identity(), 0.0, 8, f"microg.answered > {answered}"),
            key(place(centre + 0.04 * normal), Rotation.identity(), 0.0, 6)]


@needs_headset
@pytest.mark.slow
def test_in_the_headset_the_ssq_is_answered_by_poking_buttons_that_carry_its_words(tmp_path):
    protocol_file = tmp_path / "ssq.toml"
    protocol_file.write_text(f'extends = "{(PROTOCOLS / "tiny.toml").resolve()}"\nname = "ssq"\n\n'
                             '[[timeline]]\nphase = "pre"\ninstruments = ["ssq"]\nminutes = 2\n\n'
                             '[[timeline]]\nphase = "training"\nminutes = 6\n\n[[timeline]]\nphase = "stage1"\n'
                             'minutes = 12\n\n[[timeline]]\nphase = "stage2"\nminutes = 12\n')
    protocol = load_protocol(protocol_file)
    folder = tmp_path / "study"
    with create_study(folder, protocol, seed=1) as store:
        store.add_participant(Participant("P01", "female", 24, "right", True))
    values = [k % 4 for k in range(16)]
    failures: list[BaseException] = []
    with ParticipantDisplay(protocol) as display, bench.chromium(WINDOW) as driver:
        def run():
            try:
                with open_study(folder) as store:
                    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="wall")
                    run_session(store, session.id, scripted_inputs(), clock=WallClock(),
                                operator=DisplayOperator(display, NoTasks()), rater=DisplayRater(display),
                                outputs=Outputs(sinks=(display,)))
            except BaseException as error:  # the test reports it
                failures.append(error)

        bench.emulate_headset(driver)
        driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": OPEN_HAND})
        driver.get(display.url)
        session = threading.Thread(target=run, daemon=True)
        session.start()
        bench.enter_and_place(driver, (0.05, 1.0, -0.45))
        hand = EmulatedHand(driver.execute_script(POSE_DATA))
        words = wait(driver, "return !document.getElementById('question').hidden && window.microg.xr.button(0) "
                             "&& window.microg.xr.answers()")
        assert words == [[0, "None"], [1, "Slight"], [2, "Moderate"], [3, "Severe"]]  # each button its words
        for answered, value in enumerate(values):
            button = wait(driver, f"return !document.getElementById('question').hidden "
                                  f"&& window.microg.answered === {answered} && window.microg.xr.button({value})")
            play(driver, press_path(hand, button, answered))
        session.join(WORK_S)
        assert not session.is_alive() and not failures, failures
        pressed = driver.execute_script("return window.microg.xr.pressed")

    assert pressed == values
    with open_study(folder) as store:
        answers = store.answers(store.session_of("P01").id)
    assert list(answers) == [("ssq", "pre", "", f"ssq{k:02d}") for k in range(1, 17)]
    assert list(answers.values()) == values


@needs_headset
def test_without_passthrough_the_page_offers_a_virtual_reality_session(tmp_path):
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    vr_only = "Object.assign({}, IWER.metaQuest3, { supportedSessionModes: ['inline', 'immersive-vr'] })"
    with ParticipantDisplay(protocol) as display, bench.chromium(WINDOW) as driver:
        bench.emulate_headset(driver, device=vr_only)
        driver.get(display.url)
        wait(driver, "return document.getElementById('enter-xr')")
        assert driver.execute_script("return window.microg.xr.mode") == "immersive-vr"
        driver.find_element("id", "enter-xr").click()
        wait(driver, "return window.microg.xr.step === 'placing'")
        assert driver.execute_script("return window.emulatedHeadset.activeSession.environmentBlendMode") == "opaque"


@needs_headset
def test_hands_record_with_webxr_serves_the_page_and_records_the_headsets_hand(tmp_path):
    out = tmp_path / "headset.arrows"
    command = [sys.executable, "-c", "from microg.cli import main; main()", "hands", "record", "--input", "webxr",
               "--out", str(out), "--frames", "40", "--protocol", str(PROTOCOLS / "tiny.toml")]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        lines = iter(process.stdout.readline, "")
        url = next(line for line in lines if line.startswith("participant view: ")).split(": ", 1)[1].strip()
        with bench.chromium(WINDOW) as driver:
            bench.emulate_headset(driver)
            driver.get(url)
            bench.enter_and_place(driver)
            mark = driver.execute_script("return window.microg.layout.mark")
            said = process.communicate(timeout=WORK_S)[0]
        assert process.returncode == 0, said
    finally:
        process.kill()
    assert "display_placement: " in said and "display_clock: " in said and "40 frames" in said
    recording = load_recording(out)
    assert recording.info.source == "webxr" and len(recording.frames) == 40
    assert np.all(np.diff([frame.timestamp for frame in recording.frames]) > 0)
    # Both emulated hands, in the workspace frame: the right palm, back where it was when it pinched,
    # on the point it marked.
    assert all({h.side for h in frame.hands} == {"left", "right"} for frame in recording.frames)
    assert np.allclose(recording.frames[-1].hand("right").palm_position, mark, atol=1e-4)


def flat_hand(side: str = "right") -> tuple[np.ndarray, np.ndarray]:
    """A flat hand, palm down, fingers along -z, in WebXR's joint order: the wrist at the origin,
    each finger's five joints 2 cm apart from its metacarpal base 2 cm ahead of the wrist."""
    across = 1.0 if side == "left" else -1.0  # a right hand's thumb and index are on its -x side
    joints = [[0.0, 0.0, 0.0]] + [[across * 0.04, 0.0, -0.02 * k] for k in range(1, 5)]
    for finger in range(4):
        x = across * (0.0225 - 0.015 * finger)
        joints += [[x, 0.0, -0.02 - 0.02 * k] for k in range(5)]
    radii = np.linspace(0.012, 0.006, 25)
    return np.asarray(joints), radii


def test_webxr_joints_map_onto_the_skeleton():
    joints, radii = (values.astype(np.float32).astype(float) for values in flat_hand("right"))  # a Float32Array's
    hand = hand_from_webxr("right", joints, radii, track_id=4)
    # Fingers: WebXR's five joints in order; the thumb: its metacarpal joint twice (zero length).
    assert np.array_equal(hand.joints[1:].reshape(-1, 3), joints[5:])
    assert np.array_equal(hand.joints[0], joints[[1, 1, 2, 3, 4]])
    assert hand.bone_lengths[0, 0] == 0.0 and not hand.phalanx_mask[0, 0]
    # Widths: the sum of the radii at the bone's ends.
    assert hand.widths[1, 2] == pytest.approx(radii[7] + radii[8])
    assert hand.widths[0, 1] == pytest.approx(radii[1] + radii[2]) and hand.widths[0, 0] == pytest.approx(2 * radii[1])
    # Palm: the middle of the four metacarpals; oriented as Leap's: y out of the back of the hand
    # (-normal: up for a hand palm down), z toward the wrist (-direction).
    assert np.allclose(hand.palm_position, [0.0, 0.0, -0.03])
    basis = Rotation.from_quat(np.roll(hand.palm_orientation, -1)).as_matrix()
    assert np.allclose(basis[:, 1], [0, 1, 0]) and np.allclose(basis[:, 2], [0, 0, 1])
    assert hand.track_id == 4
    left = hand_from_webxr("left", *flat_hand("left"))
    assert np.allclose(Rotation.from_quat(np.roll(left.palm_orientation, -1)).as_matrix()[:, 1], [0, 1, 0])


def message(t: float, *hands) -> dict:
    return {"type": "hands", "t": t, "hands": [
        {"side": side, "track": 1, "joints": joints.tolist(), "radii": radii.tolist()} for side, joints, radii in hands]}


def test_webxr_frames_are_stamped_on_the_sessions_clock_and_bad_ones_refused():
    joints, radii = flat_hand()
    source = WebXRSource(110.0, backlog_s=0.055)
    clock = {"offset_ms": 250.0, "rtt_ms": 1.0, "spread_ms": 0.2}
    source.receive(message(1000.0, ("right", joints, radii)), None)  # before the page's clock is synced
    source.receive(message(1000.0, ("right", joints, radii * 10.0)), clock)  # fingers 10 cm thick: no hand
    source.receive(message(1010.0, ("right", joints[:20], radii)), clock)  # 20 joints: no hand
    source.receive({"type": "hands", "t": "soon", "hands": []}, clock)
    assert source.refused == 4
    frames = [source.next_frame(), source.next_frame()]
    # on the session's clock (page time + offset), from the first frame's: 1000 ms + 250 ms
    assert [f.timestamp for f in frames] == [0.0, 0.01] and [f.hands for f in frames] == [(), ()]
    assert source.last_read == 1010.0  # the page's read time of the frame handed out last
    for k in range(8):  # the session falls behind: only frames within 0.055 s of the newest wait
        source.receive(message(1020.0 + 10 * k, ("right", joints, radii)), clock)
    assert source.frames_dropped == 2 and source.next_frame().timestamp == pytest.approx(0.04)
    assert source.next_frame().hand("right") is not None
    assert source.frame_rate == pytest.approx(100.0)
    source.close()
    for _ in range(4):
        source.next_frame()
    assert source.next_frame() is None
