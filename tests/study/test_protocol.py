"""The shipped protocols state the paper's study; bad protocol files fail naming file, key and value."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from microg.paths import INSTRUMENTS, PROTOCOLS
from microg.skeleton import JUMP_DISTANCE
from microg.study.protocol import ProtocolError, load_protocol
from microg.study.questionnaire import questions
from microg.study.store import plan_tasks

PAPER = PROTOCOLS / "paper.toml"

# The questionnaire as the paper words it (section 4.3, "Evaluation Metrics").
PAPER_ITEMS = {
    "naturalness": ("How natural did the sensation of the average task completion experience feel?",
                    "Extremely unnatural", "Extremely natural"),
    "efficiency": ("How would you rate the efficiency of the average task completion experience?",
                   "Extremely inefficient", "Extremely efficient"),
}


def test_the_paper_protocol_states_the_papers_study():
    p = load_protocol(PAPER)
    assert p.total_participants == 30 and p.balance == "gender" and p.age_range == (18, 30)
    assert {(g.code, g.size, g.training) for g in p.groups} == {("V", 15, True), ("B", 15, False)}
    assert [o.code for o in p.objects] == ["C", "F", "L"]
    assert p.order == "latin_square"
    assert p.task.hold_s == 3.0 and len(p.task.places) == 3
    assert p.gravity == (0.0, -9.81, 0.0)
    assert [(s.name, s.interaction) for s in p.phases] == [("stage1", "impulse_penetration"), ("stage2", "soft_hand")]
    assert p.interactions == ("impulse_penetration", "soft_hand")
    assert p.training.groups == ("V",) and p.training.interaction == "impulse_penetration"
    q = p.instruments["paper"]
    assert {i.response.describe() for i in q.items} == {"0-10"}
    assert {i.id: (i.text, *(words for _, words in i.words)) for i in q.items} == PAPER_ITEMS
    assert [ph.name for ph in p.timeline] == ["orientation", "instructions", "training", "stage1", "stage2",
                                              "questionnaire"]
    # (paper) each item asked once about each interaction model, after both phases
    assert [(a.interaction, a.item.id, a.administration) for a in questions(p, p.timeline[-1])] == [
        ("impulse_penetration", "naturalness", "questionnaire"), ("impulse_penetration", "efficiency", "questionnaire"),
        ("soft_hand", "naturalness", "questionnaire"), ("soft_hand", "efficiency", "questionnaire")]
    assert sum(ph.minutes for ph in p.timeline) <= 40 == p.duration_minutes
    assert [ph.name for ph in p.phases_for("B")] == ["orientation", "instructions", "stage1", "stage2",
                                                     "questionnaire"]


def test_the_paper_protocols_veterans_train_on_four_ball_tasks_of_their_own_time_limit():
    """Issue 28: the training runs ``tasks`` tasks through its objects in turn, each judged by the
    task's rules with the training's ``timeout_s``; the phases keep the task table's."""
    p = load_protocol(PAPER)
    assert p.training.object_names == ("ball",) * 4
    assert p.rules("training").timeout_s == 90.0 and p.rules("training").places == p.task.places
    assert p.rules("stage1") is p.task and p.task.timeout_s == 240.0
    planned = plan_tasks(p, "V", ("cube", "flat_cuboid", "long_cuboid"))
    assert [(t.phase, t.object, t.order_position) for t in planned[:5]] == [
        ("training", "ball", 1), ("training", "ball", 2), ("training", "ball", 3), ("training", "ball", 4),
        ("stage1", "cube", 1)]
    assert [t.phase for t in plan_tasks(p, "B", ("cube", "flat_cuboid", "long_cuboid"))][:1] == ["stage1"]


def test_a_training_goes_through_its_objects_in_turn(tmp_path):
    path = tmp_path / "two.toml"
    path.write_text(PAPER.read_text().replace('objects = ["ball"]', 'objects = ["ball", "cube"]')
                    .replace("tasks = 4", "tasks = 3"))
    assert load_protocol(path).training.object_names == ("ball", "cube", "ball")


def test_the_microgravity_variant_differs_only_in_gravity_and_support():
    paper, micro = load_protocol(PAPER), load_protocol(PROTOCOLS / "paper-microgravity.toml")
    assert micro.gravity == (0.0, 0.0, 0.0) and micro.table_height is None and paper.table_height == 0.15
    assert micro.task.places == paper.task.places and micro.groups == paper.groups
    assert micro.instruments == paper.instruments and micro.sha256 != paper.sha256


def test_a_protocols_jump_distance_is_the_tracking_guards_and_the_physics(tmp_path):
    """One jump distance for both places that apply the jump rule (``microg.skeleton.is_jump``):
    the tracking guard and every scene the protocol makes (the world's frame intake)."""
    paper = load_protocol(PAPER)
    assert paper.guard.jump_distance == paper.scene("cube", "impulse_penetration").jump_distance == JUMP_DISTANCE
    mine = load_protocol(edited(tmp_path, "tracking_rate = 110.0", "tracking_rate = 110.0\njump_distance = 0.05"))
    assert mine.guard.jump_distance == 0.05
    assert {mine.scene(o.name, interaction).jump_distance for o in mine.objects
            for interaction in mine.interactions} == {0.05}


def test_the_protocol_digest_depends_on_content_not_on_where_the_file_is(tmp_path):
    copy = tmp_path / "paper.toml"
    copy.write_text(PAPER.read_text())
    assert load_protocol(copy).sha256 == load_protocol(PAPER).sha256
    copy.write_text(PAPER.read_text().replace("hold_s = 3.0", "hold_s = 3.5"))
    assert load_protocol(copy).sha256 != load_protocol(PAPER).sha256


def edited(tmp_path: Path, old: str, new: str, name: str = "bad.toml") -> Path:
    text = PAPER.read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


BAD = [
    # (replace this, with this, the message must contain these)
    ("hold_s = 3.0", "hold_s = -3", ["task.hold_s", "-3", "positive"]),
    ("hold_s = 3.0", 'hold_s = "three"', ["task.hold_s", "'three'"]),
    ('interaction = "soft_hand"', 'interaction = "clap"', ["phases[1].interaction", "'clap'", "impulse_penetration"]),
    ("size = 15\ntraining = false", "size = 14\ntraining = false", ["participants.total", "30", "add up to 29"]),
    ('order = "latin_square"', 'order = "random"', ["objects.order", "'random'", "permutation"]),
    ("place_radius = 0.04", "place_radius = 0.04\nplace_radiuss = 0.05", ["unknown key task.place_radiuss"]),
    ('names = ["cube", "flat_cuboid", "long_cuboid"]', 'names = ["cube", "teapot"]', ["'teapot'", "no object file"]),
    ("    [0.12, 0.18, 0.0],\n]", "    [0.12, 0.18, 0.9],\n]", ["task.places[2]", "[0.12, 0.18, 0.9]", "workspace"]),
    ("minutes = 12\n\n[[timeline]]\nphase = \"stage2\"", "minutes = 30\n\n[[timeline]]\nphase = \"stage2\"",
     ["duration_minutes", "40", "58 minutes"]),
    ("timeout_s = 240.0", "timeout_s = 300.0", ["'stage1'", "minutes = 12", "timeout_s = 15 minutes"]),
    ('phase = "stage2"', 'phase = "debriefing"', ["timeline[4].phase", "'debriefing'"]),
    ('instruments = ["paper"]', 'instruments = ["paper", "ssq2"]',
     ["timeline[5].instruments = ['paper', 'ssq2']", "no instrument 'ssq2'", "shipped: ['ipq', 'paper'"]),
    ('about = "each"', 'about = "stage3"', ["timeline[5].about = 'stage3'", "['each', 'stage1', 'stage2']"]),
    ('phase = "questionnaire"', 'phase = "stage1"', ["timeline[5].phase = 'stage1'", "a name of its own"]),
    ('instruments = ["paper"]', 'instruments = ["paper", "paper"]', ["instrument 'paper' appears twice"]),
    ("gravity = [0.0, -9.81, 0.0]", "gravity = [0.0, -9.81]", ["scene.gravity", "[0.0, -9.81]", "3 finite numbers"]),
    ('code = "V"', 'code = "V-1"', ["groups[0].code", "'V-1'", "letters and digits"]),
    ("age_range = [18, 30]", "age_range = [30, 18]", ["participants.age_range", "[30, 18]"]),
    ('name = "paper"\n', "", ["missing key name"]),
    ("hold_s = 3.0", "hold_s = 3.0 3", ["not valid TOML"]),
    ('interaction = "soft_hand"', 'interaction = "impulse_penetration"',
     ["phases[1].interaction", "'impulse_penetration'", "phases[0] runs this interaction model already"]),
    ('label = "System 2"', 'label = "System 1"', ["phases", "'System 1'", "appears twice"]),
    ('name = "stage1"', 'name = "stäge1"', ["phases[0].name", "'stäge1'", "ASCII letters and digits"]),
    ('code = "B"', 'code = "v"', ["groups", "['V', 'v']", "appears twice"]),
    ("table_height = 0.15", "table_height = 0.59",
     ["scene.table_height = 0.59", "cube stands on the table", "outside the workspace"]),
    ("table_height = 0.15", "table_height = 0.3",
     ["task.places[0] = [-0.04, 0.26, 0.0]", "table_height = 0.3", "can never reach this place"]),
    ("tracking_rate = 110.0", 'tracking_rate = "fast"', ["tracking_rate = 'fast'", "positive number"]),
    ("grasp_settle_s = 0.1", "grasp_settle_s = -0.1", ["task.grasp_settle_s", "-0.1", "non-negative"]),
    ('label = "System 2"', 'label = "System 2"\nadded_latency_ms = -5', ["phases[1].added_latency_ms = -5",
                                                                       "non-negative number (ms)"]),
    ('label = "System 2"', 'label = "System 2"\nadded_latency_ms = 1500', ["phases[1].added_latency_ms = 1500",
                                                                         "at most 1000 (ms)"]),
    ('label = "System 2"', 'label = "System 2"\nadded_latency_ms = "50ms"', ["phases[1].added_latency_ms = '50ms'"]),
    ("tasks = 4", "tasks = 0", ["training.tasks = 0", "whole number >= 1"]),
    ("timeout_s = 90.0", "timeout_s = 5.0",
     ["training.timeout_s = 5.0", "must exceed the 3 holds of task.hold_s = 9 s"]),
    ("tasks = 4", "tasks = 5", ["'training'", "minutes = 6", "5 x training.timeout_s = 7.5 minutes"]),
    ("tracking_rate = 110.0", "tracking_rate = 110.0\njump_distance = 1e9",
     ["scene.jump_distance = 1000000000.0", "must be at most 10 (m)"]),  # a guard that never sees a jump
    ("tracking_rate = 110.0", "tracking_rate = 110.0\njump_distance = -0.1",
     ["scene.jump_distance = -0.1", "must be a positive number (m)"]),
]


def assert_refused(path, expected: list[str]) -> None:
    """Loading ``path`` fails with a message that starts with the file and says each of ``expected``."""
    with pytest.raises(ProtocolError) as error:
        load_protocol(path)
    message = str(error.value)
    assert message.startswith(str(path)), message
    for part in expected:
        assert part in message, (part, message)


@pytest.mark.parametrize("old, new, expected", [
    ("[[phases]]", "[[stages]]", ["`[[stages]]` is now `[[phases]]`"]),
    ('interaction = "soft_hand"', 'system = "soft_hand"', ["phases[1].system is now phases[1].interaction"]),
    ('groups = ["V"]\ninteraction =', 'groups = ["V"]\nsystem =', ["training.system is now training.interaction"]),
], ids=["stages", "phase system", "training system"])
def test_an_older_protocol_is_told_what_its_keys_became(tmp_path, old, new, expected):
    """Issue 12: ``[[stages]]`` became ``[[phases]]`` and ``system`` became ``interaction``; a file
    written before says so, naming the file."""
    path = tmp_path / "old.toml"
    path.write_text(PAPER.read_text().replace(old, new))
    assert_refused(path, expected)


@pytest.mark.parametrize("old, new, expected", BAD, ids=[b[2][0] for b in BAD])
def test_a_bad_protocol_is_rejected_naming_file_key_and_value(tmp_path, old, new, expected):
    path = edited(tmp_path, old, new)
    assert_refused(path, expected)


def test_a_phase_adds_display_latency_only_where_it_says_so(tmp_path):
    """Issue 24: ``added_latency_ms`` of a phase, 0 unless given (and for the training)."""
    paper = load_protocol(PAPER)
    assert [p.added_latency_ms for p in paper.phases] == [0.0, 0.0]
    delayed = load_protocol(edited(tmp_path, 'label = "System 2"', 'label = "System 2"\nadded_latency_ms = 50'))
    assert [delayed.added_latency_ms(name) for name in ("training", "stage1", "stage2")] == [0.0, 0.0, 50.0]
    assert delayed.sha256 != paper.sha256


def test_files_that_extend_each_other_in_a_circle_are_rejected(tmp_path):
    (tmp_path / "a.toml").write_text('extends = "b.toml"\n')
    (tmp_path / "b.toml").write_text('extends = "a.toml"\n')
    with pytest.raises(ProtocolError, match=re.escape("extend each other in a circle")):
        load_protocol(tmp_path / "a.toml")


def test_a_missing_protocol_file_is_named(tmp_path):
    with pytest.raises(ProtocolError, match=re.escape(str(tmp_path / "nope.toml"))):
        load_protocol(tmp_path / "nope.toml")


def test_an_extending_file_overrides_only_what_it_names(tmp_path):
    (tmp_path / "mine.toml").write_text(f'extends = "{PAPER}"\nname = "mine"\n[task]\nhold_s = 2.0\n')
    mine = load_protocol(tmp_path / "mine.toml")
    assert mine.name == "mine" and mine.task.hold_s == 2.0
    assert mine.task.places == load_protocol(PAPER).task.places


def test_a_protocol_that_is_not_utf8_is_named_with_the_byte(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(PAPER.read_text().replace("Reliability", "Fiabilité").encode("latin-1"))
    with pytest.raises(ProtocolError, match=re.escape(f"{path}: not UTF-8 text (byte 0xe9 at position")):
        load_protocol(path)


def protocol_with_objects(tmp_path: Path, objects: dict[str, str], names: list[str]) -> Path:
    """A protocol extending the paper's whose ``objects.names`` are ``names``, with object files
    ``objects`` (name -> text) next to it."""
    (tmp_path / "objects").mkdir()
    for name, text in objects.items():
        (tmp_path / "objects" / f"{name}.toml").write_text(text)
    path = tmp_path / "mine.toml"
    path.write_text(f'extends = "{PAPER}"\nname = "mine"\n[objects]\nnames = {names}\n')
    return path


BOX = 'name = "{name}"\ncode = "{code}"\nshape = "box"\nsize = [0.05, 0.05, 0.05]\nmass = {mass}\n'


@pytest.mark.parametrize("text, expected", [
    (BOX.format(name="brick", code="K", mass='"heavy"'), ["mass = 'heavy'", "positive number"]),
    (BOX.format(name="brick", code="K", mass="0.1") + "inertia = [1, 2]\n", ["inertia = [1, 2]"]),
    (BOX.format(name="brick", code="K", mass="0.1").replace("size = [0.05,", "size = [[0.05],"), ["size.x = [0.05]"]),
    (BOX.format(name="brick", code="", mass="0.1"), ["code = ''", "non-empty"]),
    ("mass = 0.1 0.2", ["not valid TOML"]),
])
def test_errors_about_an_object_file_name_the_object_file(tmp_path, text, expected):
    path = protocol_with_objects(tmp_path, {"brick": text}, ["cube", "brick"])
    with pytest.raises(ProtocolError) as error:
        load_protocol(path)
    message = str(error.value)
    assert message.startswith(str(tmp_path / "objects" / "brick.toml")), message
    for part in expected:
        assert part in message, (part, message)


def test_an_object_file_that_is_not_utf8_is_named(tmp_path):
    path = protocol_with_objects(tmp_path, {}, ["cube", "brick"])
    (tmp_path / "objects" / "brick.toml").write_bytes(BOX.format(name="brïck", code="K", mass="0.1").encode("latin-1"))
    with pytest.raises(ProtocolError, match=re.escape(f"{tmp_path / 'objects' / 'brick.toml'}: not UTF-8 text")):
        load_protocol(path)


@pytest.mark.parametrize("name, code, expected", [
    ("cube2", "C", "objects 'cube' and 'cube2' have the same code 'C'"),
    ("cube2", "c", "objects 'cube' and 'cube2' have the same code 'c'"),
    ("ball", "C", "objects 'cube' and 'ball' have the same code 'C'"),  # also the training's object
])
def test_two_objects_of_a_study_never_share_a_code(tmp_path, name, code, expected):
    path = protocol_with_objects(tmp_path, {name: BOX.format(name=name, code=code, mass="0.1")}, ["cube", name])
    with pytest.raises(ProtocolError, match=re.escape(expected)):
        load_protocol(path)


def test_what_only_simulated_participants_need_is_reported_not_refused(tmp_path):
    path = edited(tmp_path, 'simulated_profile = "practice"', 'simulated_profile = "expert"')
    (tmp_path / "instruments").mkdir()  # the study's own version of the paper's items takes the shipped one's place
    (tmp_path / "instruments" / "paper.toml").write_text(
        (INSTRUMENTS / "paper.toml").read_text().replace('id = "efficiency"', 'id = "comfort"')
        .replace('items = ["efficiency"]', 'items = ["comfort"]'))
    protocol = load_protocol(path)  # a study with live participants can use it
    assert [i.id for i in protocol.instruments["paper"].items] == ["naturalness", "comfort"]
    problems = protocol.simulation_problems()
    assert problems == [
        f"{path}: groups[0].simulated_profile = 'expert': simulated participants play a population file "
        "(FILE.toml) or one of ['practice', 'literature', 'beginner', 'veteran'] (the default is the group's name)",
        f"{path}: timeline[5].instruments = ['paper']: paper: the rating model of simulated participants rates only "
        "['efficiency', 'naturalness'], not ['comfort']"]
    assert load_protocol(PAPER).simulation_problems() == []


def test_a_groups_population_file_that_is_not_toml_is_refused_by_name(tmp_path):
    (tmp_path / "pilot.toml").write_text("mean == 3\n")
    path = edited(tmp_path, 'simulated_profile = "practice"', 'simulated_profile = "pilot.toml"')
    with pytest.raises(ProtocolError, match=re.escape(f"{path}: groups[0].simulated_profile = 'pilot.toml': ")) as error:
        load_protocol(path)
    assert "cannot be read as TOML" in str(error.value)


def test_a_group_plays_a_population_shipped_with_microg_by_its_name(tmp_path):
    from microg.paths import POPULATIONS
    from microg.participant import default_population, read_population

    protocol = load_protocol(edited(tmp_path, 'simulated_profile = "practice"', 'simulated_profile = "literature"'))
    literature = read_population(POPULATIONS / "literature.toml")
    assert protocol.groups[0].player.parameters == literature.parameters
    assert protocol.groups[1].player.parameters == default_population().parameters != literature.parameters


def test_the_vr_protocol_asks_the_questionnaires_of_vr_research_in_its_timeline():
    vr, paper = load_protocol(PROTOCOLS / "paper-vr.toml"), load_protocol(PAPER)
    assert (vr.phases, vr.objects, vr.task, vr.groups) == (paper.phases, paper.objects, paper.task, paper.groups)
    asked = [(ph.name, ph.instruments, ph.administration, [a.interaction if a else "" for a in vr.about(ph)])
             for ph in vr.phases_for("V") if ph.instruments]
    assert asked == [("pre", ("ssq",), "pre", [""]),
                     ("after_stage1", ("ipq", "tlx"), "after", ["impulse_penetration"]),
                     ("post", ("ssq",), "post", [""]),
                     ("after_stage2", ("ipq", "tlx"), "after", ["soft_hand"]),
                     ("questionnaire", ("paper",), "questionnaire", ["impulse_penetration", "soft_hand"]),
                     ("end", ("sus",), "end", ["impulse_penetration", "soft_hand"])]
    names = [ph.name for ph in vr.phases_for("V")]
    assert names.index("pre") < names.index("training") and names.index("post") == names.index("stage2") + 1
    assert vr.instruments["paper"] == paper.instruments["paper"]
    assert sum(ph.minutes for ph in vr.timeline) <= vr.duration_minutes == 60
    tlx = [q for q in questions(vr, vr.timeline[5]) if q.instrument.id == "tlx"]
    assert len(tlx) == 21 and {q.label for q in tlx} == {"System 1"}


def test_a_study_keeps_its_instruments_whatever_happens_to_the_files_later(tmp_path):
    """The instrument files' texts are kept with the protocol, as the object files are."""
    from microg.study.protocol import protocol_from_resolved

    vr = load_protocol(PROTOCOLS / "paper-vr.toml")
    kept = protocol_from_resolved(vr.resolved, "study.db")
    assert kept.instruments == vr.instruments and kept.timeline == vr.timeline
    assert sorted(vr.resolved["instrument_files"]) == ["ipq", "paper", "ssq", "sus", "tlx"]


def asking(tmp_path, entries: str, name: str = "mine.toml") -> Path:
    """The paper's protocol with ``entries`` (TOML timeline tables) added at the end of its timeline."""
    path = tmp_path / name
    path.write_text(PAPER.read_text().replace("[logging]", entries + "\n[logging]")
                    .replace("duration_minutes = 40", "duration_minutes = 50"))
    return path


@pytest.mark.parametrize("entries, expected", [
    ('[[timeline]]\nphase = "post"\ninstruments = ["paper"]\nabout = "stage2"\nadministration = "questionnaire"\n'
     'minutes = 0.5\n', ["timeline[6].administration = 'questionnaire'", "timeline[5] asks paper"]),
    ('[[timeline]]\nphase = "questionnaire"\ninstruments = ["ssq"]\nminutes = 0.5\n',
     ["timeline = [", "phase 'questionnaire' appears twice"]),
    ('[[timeline]]\nphase = "post"\ninstruments = []\nminutes = 0.5\n', ["timeline[6].instruments = []"]),
    ('[[timeline]]\nphase = "post"\ninstruments = ["ssq"]\nadministration = "po st"\nminutes = 0.5\n',
     ["timeline[6].administration = 'po st'", "letters, digits and _"]),
    ('[[timeline]]\nphase = "post-1"\ninstruments = ["ssq"]\nminutes = 0.5\n',
     ["timeline[6].phase = 'post-1'", "letters, digits and _"]),
])
def test_a_questionnaire_placed_wrong_in_the_timeline_is_refused(tmp_path, entries, expected):
    path = asking(tmp_path, entries)
    assert_refused(path, expected)


def test_a_questionnaire_about_a_phase_must_come_after_it(tmp_path):
    text = PAPER.read_text().replace('[[timeline]]\nphase = "stage1"', '[[timeline]]\nphase = "early"\n'
                                     'instruments = ["ipq"]\nabout = "stage1"\nminutes = 1\n\n'
                                     '[[timeline]]\nphase = "stage1"')
    path = tmp_path / "early.toml"
    path.write_text(text.replace("minutes = 12", "minutes = 11", 1))
    assert_refused(path, ["timeline[3].about = 'stage1'", "before it has run"])


def test_an_older_protocols_questionnaire_table_is_told_where_it_went(tmp_path):
    path = tmp_path / "old.toml"
    path.write_text(PAPER.read_text() + '\n[questionnaire]\nscale_min = 0\nscale_max = 10\n')
    assert_refused(path, ["[questionnaire] is now an instrument file", "instruments/NAME.toml",
                          'instruments = ["NAME"], about = "each"'])


def test_a_bad_instrument_file_of_the_study_is_named_with_its_key(tmp_path):
    (tmp_path / "instruments").mkdir()
    bad = tmp_path / "instruments" / "comfort.toml"
    bad.write_text('title = "Comfort"\nsource = "lab"\n[responses.r]\nmin = 1\nmax = 7\n'
                   '[[items]]\nid = "c1"\ntext = "Comfy?"\nresponse = "r"\n'
                   '[[scales]]\nname = "comfort"\nitems = ["c1", "c9"]\nscore = "mean"\n')
    path = asking(tmp_path, '[[timeline]]\nphase = "end"\ninstruments = ["comfort"]\nminutes = 0.5\n')
    with pytest.raises(ProtocolError) as error:
        load_protocol(path)
    assert str(error.value).startswith(f"{bad}: scales[0].items = ['c1', 'c9']: names item 'c9'"), str(error.value)


def test_each_section_has_its_reader_and_valid_protocols_read_as_before():
    """Issue 12: one small reader per section; the shipped protocols give the same digest as the
    single ``_build`` did (the digest is over their merged content, so it changes with any key)."""
    from microg.study import protocol as module

    readers = [name for name in dir(module) if name.startswith("_read_") and name not in ("_read_text", "_read_toml")]
    assert {"_read_scene", "_read_participants", "_read_groups", "_read_objects", "_read_task", "_read_phases",
            "_read_training", "_read_instruments", "_read_timeline", "_read_display", "_read_dataset"} <= set(readers)
    import inspect
    assert all(len(inspect.getsource(getattr(module, name)).splitlines()) <= 45 for name in readers)
    assert len(inspect.getsource(module._build).splitlines()) <= 45
