"""Task kinds in the protocol: chosen per phase (or for the training), each kind's numbers in its own
table of ``[task]``, bad kinds and numbers refused naming file, key and value."""

from __future__ import annotations

import math

import numpy as np
import pytest

from microg.paths import PROTOCOLS
from microg.sim.rotation import quat_to_matrix
from microg.study.protocol import load_protocol, protocol_from_resolved

from .test_protocol import assert_refused

MICRO = PROTOCOLS / "paper-microgravity.toml"
KINDS = """
[task.catch]
launch_speed = 0.4
toward = [0.0, 0.18, 0.1]
spin = [0.0, 1.5, 0.0]
hold_s = 0.8

[task.stop_spin]
spin_axis = [0.0, 2.0, 0.0]
spin_rate = 4.0
rest_omega = 0.3

[[phases]]
name = "catching"
interaction = "impulse_penetration"
label = "System 1"
kind = "catch"

[[phases]]
name = "stopping"
interaction = "soft_hand"
label = "System 2"
kind = "stop_spin"

[[timeline]]
phase = "training"
minutes = 6

[[timeline]]
phase = "catching"
minutes = 12

[[timeline]]
phase = "stopping"
minutes = 12
"""


def kinds_protocol(tmp_path, extra: str = KINDS, name: str = "kinds.toml"):
    path = tmp_path / name
    path.write_text(f'extends = "{MICRO}"\nname = "kinds"\n{extra}')
    return path


def test_each_phase_runs_its_kind_with_the_numbers_of_its_table(tmp_path):
    p = load_protocol(kinds_protocol(tmp_path))
    assert [(ph.name, ph.kind) for ph in p.phases] == [("catching", "catch"), ("stopping", "stop_spin")]
    assert p.kind("training") == p.training.kind == "pick_and_place"
    assert p.rules("training").kind == "pick_and_place" and p.rules("catching").kind == "catch"
    assert p.rules("catching") is p.rules("catching") and p.rules("training") is p.rules("training")
    # toward a point: the launch's direction is the unit vector from the start to it
    start, toward = np.array(p.task.start), np.array([0.0, 0.18, 0.1])
    expected = (toward - start) / np.linalg.norm(toward - start)
    assert np.allclose(p.task.catch.direction, expected) and p.task.catch.hold_s == 0.8
    velocity, spin = p.start_motion("catch")
    assert np.allclose(velocity, 0.4 * expected) and spin == (0.0, 1.5, 0.0)
    assert p.task.stop_spin.spin_axis == (0.0, 1.0, 0.0) and p.task.stop_spin.rest_speed == 0.02
    assert p.start_motion("pick_and_place") == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def test_a_stop_spins_axis_is_the_objects_own_turned_by_the_start_orientation(tmp_path):
    half = math.sqrt(0.5)  # a quarter turn about z takes the object's y axis to -x
    extra = KINDS.replace("[task.catch]", f"[task]\nstart_orientation = [{half}, 0.0, 0.0, {half}]\n\n[task.catch]")
    p = load_protocol(kinds_protocol(tmp_path, extra))
    _, spin = p.start_motion("stop_spin")
    turned = quat_to_matrix(np.array([half, 0.0, 0.0, half])) @ np.array([0.0, 4.0, 0.0])
    assert np.allclose(spin, turned) and np.allclose(spin, [-4.0, 0.0, 0.0])


def test_the_stored_protocol_keeps_the_kinds(tmp_path):
    p = load_protocol(kinds_protocol(tmp_path))
    again = protocol_from_resolved(p.resolved, "study.db")
    assert again.phases == p.phases and again.task == p.task and again.sha256 == p.sha256


def test_a_protocol_without_kinds_is_a_pick_and_place_as_before():
    p = load_protocol(MICRO)
    assert p.task.kind == "pick_and_place" and p.task.catch is None and p.task.stop_spin is None
    assert {ph.kind for ph in p.phases} == {"pick_and_place"} and all(p.rules(ph.name) is p.task for ph in p.phases)


@pytest.mark.parametrize("old, new, expected", [
    ('kind = "catch"', 'kind = "juggle"', ["phases[0].kind = 'juggle'",
                                           "['pick_and_place', 'catch', 'stop_spin', 'send', 'handover']"]),
    ("launch_speed = 0.4", "launch_speed = -0.4", ["task.catch.launch_speed = -0.4", "positive number (m/s)"]),
    ("launch_speed = 0.4", 'launch_speed = "fast"', ["task.catch.launch_speed = 'fast'", "(m/s)"]),
    ("launch_speed = 0.4", "launch_speed = 40", ["task.catch.launch_speed = 40", "at most 10 (m/s)"]),
    ("toward = [0.0, 0.18, 0.1]", "toward = [0.0, 0.18, 0.9]", ["task.catch.toward = [0.0, 0.18, 0.9]", "workspace"]),
    ("toward = [0.0, 0.18, 0.1]", "toward = [0.0, 0.18, 0.1]\ndirection = [1, 0, 0]", ["task.catch.direction = [1, 0, 0]",
                                                                                  "not both"]),
    ("toward = [0.0, 0.18, 0.1]", "direction = [0, 0, 0]", ["task.catch.direction = [0, 0, 0]", "no direction"]),
    ("hold_s = 0.8", "hold_s = 300", ["task.catch.hold_s = 300", "shorter than task.timeout_s = 240 s"]),
    ("spin_rate = 4.0", "spin_rate = 0", ["task.stop_spin.spin_rate = 0", "positive number (rad/s)"]),
    ("rest_omega = 0.3", "rest_omega = 5.0", ["task.stop_spin.rest_omega = 5.0", "below spin_rate = 4 rad/s"]),
    ("spin_axis = [0.0, 2.0, 0.0]", "spin_axis = [0.0, 2.0]", ["task.stop_spin.spin_axis = [0.0, 2.0]", "3 finite"]),
    ("rest_omega = 0.3", "rest_omega = 0.3\nrest_omga = 1", ["unknown key task.stop_spin.rest_omga"]),
    ("[task.stop_spin]\nspin_axis = [0.0, 2.0, 0.0]\nspin_rate = 4.0\nrest_omega = 0.3\n", "",
     ["phases[1].kind = 'stop_spin'", "add a [task.stop_spin] table"]),
], ids=["unknown kind", "negative speed", "speed not a number", "speed too high", "toward outside", "both",
        "zero direction", "hold too long", "no spin", "rest above spin", "axis of two", "unknown key", "no table"])
def test_bad_kinds_and_numbers_are_refused_naming_file_key_and_value(tmp_path, old, new, expected):
    assert old in KINDS, old
    assert_refused(kinds_protocol(tmp_path, KINDS.replace(old, new, 1)), expected)


def test_a_default_kind_in_the_task_table_needs_its_numbers_too(tmp_path):
    extra = '[task]\nkind = "catch"\n'
    assert_refused(kinds_protocol(tmp_path, extra), ["task.kind = 'catch'", "add a [task.catch] table"])


SEND = """
[task.send]
target = [0.1, 0.2, 0.05]
radius = 0.03
arrival_s = 2.0

[[phases]]
name = "sending"
interaction = "impulse_penetration"
label = "System 1"
kind = "send"

[[phases]]
name = "placing"
interaction = "soft_hand"
label = "System 2"

[[timeline]]
phase = "training"
minutes = 6

[[timeline]]
phase = "sending"
minutes = 12

[[timeline]]
phase = "placing"
minutes = 12
"""


def test_a_send_phase_has_its_target_zone_and_starts_the_object_at_rest(tmp_path):
    p = load_protocol(kinds_protocol(tmp_path, SEND))
    assert p.kind("sending") == "send" and p.rules("sending").kind == "send"
    assert p.task.send.target == (0.1, 0.2, 0.05) and p.task.send.radius == 0.03 and p.task.send.arrival_s == 2.0
    assert p.start_motion("send") == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    again = protocol_from_resolved(p.resolved, "study.db")
    assert again.task == p.task


@pytest.mark.parametrize("old, new, expected", [
    ("radius = 0.03", "radius = -0.03", ["task.send.radius = -0.03", "positive number (m)"]),
    ("radius = 0.03", "radius = 30", ["task.send.radius = 30", "at most 10 (m)"]),
    ("target = [0.1, 0.2, 0.05]", "target = [0.1, 0.2, 5.0]", ["task.send.target = [0.1, 0.2, 5.0]", "workspace"]),
    ("target = [0.1, 0.2, 0.05]", "target = [0.1, 0.2]", ["task.send.target = [0.1, 0.2]", "3 finite"]),
    ("target = [0.1, 0.2, 0.05]", "target = [-0.12, 0.19, 0.0]",
     ["task.send.target = [-0.12, 0.19, 0.0]", "0.01 m from task.start = [-0.12, 0.18, 0.0]", "start in the zone"]),
    ("arrival_s = 2.0", 'arrival_s = "soon"', ["task.send.arrival_s = 'soon'", "(seconds)"]),
    ("arrival_s = 2.0", "arrival_s = 300", ["task.send.arrival_s = 300", "shorter than task.timeout_s = 240 s"]),
    ("arrival_s = 2.0", "arrival_s = 2.0\narival = 1", ["unknown key task.send.arival"]),
    ("[task.send]\ntarget = [0.1, 0.2, 0.05]\nradius = 0.03\narrival_s = 2.0\n", "",
     ["phases[0].kind = 'send'", "add a [task.send] table"]),
], ids=["negative radius", "radius too large", "target outside", "target of two", "start in the zone",
        "arrival not a number", "arrival too long", "unknown key", "no table"])
def test_bad_send_numbers_are_refused_naming_file_key_and_value(tmp_path, old, new, expected):
    assert old in SEND, old
    assert_refused(kinds_protocol(tmp_path, SEND.replace(old, new, 1)), expected)


def test_the_skills_protocol_trains_catching_and_tests_three_kinds_with_one_interaction_model():
    """Two phases may run one interaction model with different task kinds (the report compares
    interaction models within a kind); they share its label, and ``about = "each"`` asks about the
    model once."""
    p = load_protocol(PROTOCOLS / "microgravity-skills.toml")
    assert p.training.kind == "catch" and [o.name for o in p.training.objects] == ["cube"]
    assert [(ph.name, ph.interaction, ph.kind, ph.label) for ph in p.phases] == [
        ("stopping", "impulse_penetration", "stop_spin", "System 1"),
        ("sending", "impulse_penetration", "send", "System 1"),
        ("passing", "impulse_penetration", "handover", "System 1")]
    asked = next(ph for ph in p.timeline if ph.instruments)
    assert [a.interaction for a in p.about(asked)] == ["impulse_penetration"]
    assert p.simulation_problems() == [] and sum(ph.minutes for ph in p.timeline) <= p.duration_minutes


TWO_KINDS = KINDS.replace('interaction = "soft_hand"', 'interaction = "impulse_penetration"')


@pytest.mark.parametrize("text, expected", [
    (TWO_KINDS.replace('kind = "stop_spin"', 'kind = "catch"').replace("System 2", "System 1"),
     ["phases[1].interaction = 'impulse_penetration'",
      "phases[0] runs this interaction model already with the same task kind (catch)"]),
    (TWO_KINDS, ["phases[1].label = 'System 2'", "phases[0] runs the same interaction model and is labelled "
                                                "'System 1'"]),
])
def test_phases_of_one_interaction_model_need_different_kinds_and_one_label(tmp_path, text, expected):
    assert_refused(kinds_protocol(tmp_path, text), expected)


HANDOVER = SEND.replace('''[task.send]
target = [0.1, 0.2, 0.05]
radius = 0.03
arrival_s = 2.0''', '''[task.handover]
first_hand = "left"
place = [0.1, 0.2, 0.05]
radius = 0.04
hold_s = 1.5''').replace("sending", "passing").replace('kind = "send"', 'kind = "handover"')


def test_a_handover_phase_has_its_hand_and_place_and_simulated_participants_play_it(tmp_path):
    """A handover phase reads its hand and place; simulated participants play it with both hands."""
    p = load_protocol(kinds_protocol(tmp_path, HANDOVER))
    assert p.kind("passing") == "handover" and p.rules("passing").kind == "handover"
    h = p.task.handover
    assert (h.first_hand, h.place, h.radius, h.hold_s) == ("left", (0.1, 0.2, 0.05), 0.04, 1.5)
    assert p.start_motion("handover") == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert protocol_from_resolved(p.resolved, "study.db").task == p.task
    assert p.simulation_problems() == []


@pytest.mark.parametrize("old, new, expected", [
    ('first_hand = "left"', 'first_hand = "both"', ["task.handover.first_hand = 'both'", "['left', 'right']"]),
    ("place = [0.1, 0.2, 0.05]", "place = [0.1, 0.2, 5.0]", ["task.handover.place = [0.1, 0.2, 5.0]", "workspace"]),
    ("radius = 0.04", "radius = 0", ["task.handover.radius = 0", "positive number (m)"]),
    ("hold_s = 1.5", "hold_s = 500", ["task.handover.hold_s = 500", "shorter than task.timeout_s = 240 s"]),
    ("hold_s = 1.5", "hold_s = 1.5\nhand = 1", ["unknown key task.handover.hand"]),
], ids=["no such hand", "place outside", "zero radius", "hold too long", "unknown key"])
def test_bad_handover_numbers_are_refused_naming_file_key_and_value(tmp_path, old, new, expected):
    assert old in HANDOVER, old
    assert_refused(kinds_protocol(tmp_path, HANDOVER.replace(old, new, 1)), expected)
