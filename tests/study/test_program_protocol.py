"""A training program's protocol (issue 43): its sessions, criteria and staircases read as written,
and each mistake refused naming the file, the key and the value, before anything is written."""

from __future__ import annotations

from pathlib import Path

import pytest

from microg.paths import protocol_file
from microg.study.protocol import ONE_SESSION, ProtocolError, load_protocol
from microg.study.store import plan_tasks

PROGRAM = protocol_file("microgravity-training")


def edited(tmp_path: Path, old: str, new: str) -> Path:
    text = PROGRAM.read_text()
    assert old in text, old
    path = tmp_path / "program.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_the_shipped_program_reads_as_written():
    program = load_protocol(PROGRAM)
    assert program.program and [s.name for s in program.sessions] == ["pretest", "train1", "train2", "train3",
                                                                      "posttest", "retention"]
    assert [s.after_days for s in program.sessions] == [0, 1, 1, 1, 1, 7]
    assert [s.within_days for s in program.sessions] == [None, 1, 1, 1, 1, 2]
    train = program.phase("trainpaper")
    assert (train.until.time_s, train.until.attempts, train.until.consecutive, train.max_tasks) == (45.0, 0, 2, 12)
    stairs = program.phase("catchpaper").staircase
    assert (stairs.parameter, stairs.start, stairs.factor, stairs.rule, stairs.minimum, stairs.maximum) == (
        "catch.speed", 0.1, 1.5, "2-down-1-up", 0.05, 0.6)
    assert program.rules("catchpaper", 0.3).catch.launch_speed == 0.3
    assert program.rules("catchpaper").catch.launch_speed == 0.1
    assert program.phase("catchpaper").cycle == ("cube",) and program.phase("trainpaper").cycle == ()
    # group P trains with the paper's model, S with the baseline; the SSQ only after the post-test
    assert [p.name for p in program.phases_for("S", "train3")] == ["trainbase", "catchbase"]
    assert [p.name for p in program.phases_for("P", "posttest")] == ["test", "symptoms"]
    # a phase trained to a criterion plans no task ahead: it keeps max_tasks indexes for them
    assert plan_tasks(program, "P", ("cube", "flat_cuboid", "long_cuboid"), "train3") == []


def test_a_protocol_without_sessions_is_one_session_running_every_phase():
    paper = load_protocol(protocol_file("paper"))
    assert not paper.program and [s.name for s in paper.sessions] == [ONE_SESSION]
    assert [p.name for p in paper.phases_for("V")] == [p.name for p in paper.phases_for("V", ONE_SESSION)]


@pytest.mark.parametrize("old, new, expected", [
    ('phases = ["test"]\nafter_days = 0', 'phases = ["tset"]\nafter_days = 0',
     ["sessions[0].phases = ['tset']", "names phase 'tset'"]),
    ("after_days = 7", "after_days = -7", ["sessions[5].after_days = -7"]),
    ("after_days = 7", "after_days = 1.5", ["sessions[5].after_days = 1.5"]),
    ("within_days = 2", "within_days = -1", ["sessions[5].within_days = -1"]),
    ("max_tasks = 12", "", ["phases[1].until", "add max_tasks = N"]),
    ('parameter = "catch.speed", start = 0.1, factor = 1.5, rule = "2-down-1-up", min = 0.05',
     'parameter = "catch.spin", start = 0.1, factor = 1.5, rule = "2-down-1-up", min = 0.05',
     ["phases[3].staircase.parameter = 'catch.spin'", "catch.speed"]),
    ('rule = "2-down-1-up", min = 0.05', 'rule = "2-up-1-down", min = 0.05',
     ["phases[3].staircase.rule = '2-up-1-down'"]),
    ("min = 0.05, max = 0.6 }", "min = 0.7, max = 0.6 }", ["phases[3].staircase.min = 0.7", "below max = 0.6"]),
    ("start = 0.1, factor", "start = 0.9, factor", ["phases[3].staircase.start = 0.9", "within min = 0.05 .. max = 0.6"]),
    ('objects = ["cube"]', 'objects = ["sphere"]', ["phases[3].objects = ['sphere']", "names object 'sphere'"]),
], ids=["unknown phase", "negative after_days", "fractional after_days", "negative window", "criterion without bound",
        "unknown parameter", "unknown rule", "min above max", "start outside", "unknown object"])
def test_a_mistake_in_a_program_is_refused_naming_file_key_and_value(tmp_path, old, new, expected):
    path = edited(tmp_path, old, new)
    with pytest.raises(ProtocolError) as refused:
        load_protocol(path)
    message = str(refused.value)
    assert message.startswith(str(path)) and all(part in message for part in expected), message
