"""Protocol files and object files: any edit gives a protocol or a ProtocolError naming the file."""

from __future__ import annotations

import json
import tomllib

from hypothesis import HealthCheck, given, settings, strategies as st

from microg.paths import OBJECTS, PROTOCOLS
from microg.study.protocol import ProtocolError, load_protocol, protocol_from_resolved

from .strategies import FUZZ, edits, text_edits, toml_value, values

PAPER = load_protocol(PROTOCOLS / "paper.toml")
WHERE = "fuzzed.toml"


def build(resolved: dict) -> None:
    try:
        protocol_from_resolved(resolved, WHERE)
    except ProtocolError as error:
        assert str(error).startswith(WHERE) or ".toml" in str(error), error


@FUZZ
@given(edits({k: v for k, v in PAPER.resolved.items() if k not in ("object_files", "sources")}))
def test_any_edit_of_a_protocols_tables_is_read_or_refused_naming_the_file(data):
    build(dict(data, object_files=PAPER.resolved["object_files"]))


@FUZZ
@given(st.sampled_from(sorted(PAPER.resolved["object_files"])), st.data())
def test_any_edit_of_an_object_file_is_read_or_refused_naming_the_object_file(name, data):
    parsed = tomllib.loads(PAPER.resolved["object_files"][name])
    edited = data.draw(edits(parsed))
    lines = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in edited.items()]
    files = dict(PAPER.resolved["object_files"], **{name: "\n".join(lines)})
    try:
        protocol_from_resolved(dict(PAPER.resolved, object_files=files), WHERE)
    except ProtocolError as error:
        assert f"object file {name}.toml" in str(error) or str(error).startswith(WHERE), error


@FUZZ
@given(st.sampled_from(["paper.toml", "objects/cube.toml"]), st.data())
def test_any_edit_of_the_text_of_a_file_is_read_or_refused(tmp_path_factory, which, data):
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "objects").mkdir()
    for source in OBJECTS.glob("*.toml"):
        (folder / "objects" / source.name).write_text(source.read_text())
    (folder / "paper.toml").write_text((PROTOCOLS / "paper.toml").read_text())
    target = folder / which
    target.write_text(data.draw(text_edits(target.read_text())))
    try:
        load_protocol(folder / "paper.toml")
    except ProtocolError as error:
        assert str(error).startswith(str(folder)), error


@settings(FUZZ, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=200) | values.map(lambda v: toml_value({"name": v}).encode()))
def test_any_bytes_as_a_protocol_file_are_refused_naming_it(tmp_path, content):
    path = tmp_path / "bytes.toml"
    path.write_bytes(content)
    try:
        load_protocol(path)
    except ProtocolError as error:
        assert str(error).startswith(str(path)), error
