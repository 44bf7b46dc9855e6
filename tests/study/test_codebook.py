"""The export's codebook and Psych-DS description: every column of every exported table described,
nothing described that is not there, the values in the tables within what the codebook allows, and
``dataset_description.json`` meeting Psych-DS's rules for it.

No Psych-DS validator installs from the registries the project uses (the validator is not on npm or
PyPI; the R package ``psychds`` that bundles it is on CRAN only), so the description is checked
against the rules of Psych-DS's schema as the standard states them (``PSYCHDS_*`` below).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from microg.schema import Column
from microg.study.assignment import Participant
from microg.study.codebook import CODEBOOK, DESCRIPTION, HEADER, check_columns, codebook, study_levels
from microg.study.export import export_study, table_declarations
from microg.study.protocol import load_protocol
from microg.study.session import SimulationClock, run_session
from microg.study.store import create_study

from .conftest import PROTOCOLS, answers, scripted_inputs

PSYCHDS_CONTEXTS = ("http://schema.org/", "https://schema.org/", "http://schema.org", "https://schema.org")
"""``@context``: the required fields "must use the schema.org namespace" (Psych-DS's rules, metadata file)."""
PSYCHDS_TYPES = ("Dataset", "https://schema.org/Dataset", "http://schema.org/Dataset")
"""``@type`` (or ``type``): "Dataset or https://schema.org/Dataset"."""
PSYCHDS_REQUIRED = ("name", "description", "variableMeasured")
"""The fields the compiled metadata requires (Psych-DS's schema, ``CompiledMetadata.fields``)."""
SCHEMA_ORG_PROPERTIES = {
    "Dataset": {"name", "description", "variableMeasured", "author", "license"},
    "PropertyValue": {"name", "description", "unitText", "minValue", "maxValue", "valueReference",
                      "measurementTechnique"},
    "DefinedTerm": {"name", "termCode"},
    "Person": {"name"},
}
"""The schema.org properties of each type that the description uses (schema.org's vocabulary): any
other key would not be linked data (Psych-DS's warning INVALID_SCHEMAORG_PROPERTY)."""


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """One study with one finished session, exported with every table in both formats."""
    folder = tmp_path_factory.mktemp("codebook")
    store = create_study(folder / "study", load_protocol(PROTOCOLS / "tiny.toml"), 1)
    store.add_participant(Participant("P01", "female", 24, "right", True))
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    run_session(store, session.id, scripted_inputs(), clock=SimulationClock(), rater=answers("7", "6", "3", "4"))
    export_study(store.dir, folder / "export", frames_csv=True, progress=False)
    store.close()
    return folder / "export"


def exported_tables(out) -> set[str]:
    """The names of the tables at the export's root (its CSV and Parquet files but the codebook)."""
    return {p.stem for p in out.iterdir() if p.suffix in (".csv", ".parquet") and p.name != CODEBOOK}


def test_every_column_of_every_exported_table_has_a_codebook_row_and_no_row_names_another(export):
    book = pd.read_csv(export / CODEBOOK, keep_default_na=False)
    assert tuple(book.columns) == HEADER
    assert set(book.table) == exported_tables(export) == {"trials", "progression", "questionnaire", "answers", "scores",
                                                          "frames"}
    for table, rows in book.groupby("table", sort=False):
        csv = pd.read_csv(export / f"{table}.csv", nrows=0).columns.tolist()
        parquet = pq.read_schema(export / f"{table}.parquet").names
        assert rows.column.tolist() == csv == parquet, table
    assert (book.meaning != "").all() and (book.source != "").all() and (book.type != "").all()
    assert not book.duplicated(["table", "column"]).any()


def test_the_codebook_says_what_the_tables_hold(export):
    """Each column's type is the type written, and every value written is among the allowed
    values or within the range the codebook gives."""
    book = pd.read_csv(export / CODEBOOK, keep_default_na=False)
    kinds = {"text": lambda t: pa.types.is_string(t) or pa.types.is_large_string(t), "integer": pa.types.is_integer,
             "number": pa.types.is_floating, "true/false": pa.types.is_boolean}
    checked = set()
    for table, rows in book.groupby("table", sort=False):
        data = pq.read_table(export / f"{table}.parquet")
        for row in rows.itertuples(index=False):
            field = data.schema.field(row.column).type
            field = field.value_type if pa.types.is_dictionary(field) else field
            assert kinds[row.type](field) or pa.types.is_null(field), (table, row.column, field)
            values = data.column(row.column).to_pandas().dropna()
            values = values[values.astype(str) != ""]
            if not len(values) or not row.allowed:
                continue
            checked.add((table, row.column))
            if row.type in ("integer", "number"):
                low, _, high = row.allowed.partition(" to ")
                if row.allowed.startswith(">= "):
                    low, high = row.allowed[3:], "inf"
                assert float(low) <= values.min() and values.max() <= float(high), (table, row.column, row.allowed)
            else:
                allowed = {part.split(": ")[0] for part in row.allowed.split("; ")}
                assert set(values.astype(str)) <= allowed, (table, row.column, row.allowed)
    assert {("trials", "group"), ("trials", "status"), ("trials", "time_s"), ("questionnaire", "rating"),
            ("answers", "source"), ("frames", "stage"), ("frames", "touching"), ("frames", "qw"),
            ("frames", "place"), ("frames", "place_timer")} <= checked


def test_the_study_s_own_values_are_listed_with_their_meanings(export):
    book = pd.read_csv(export / CODEBOOK, keep_default_na=False).set_index(["table", "column"])
    assert book.loc[("trials", "group"), "allowed"] == "V: veteran; B: beginner"
    assert book.loc[("trials", "interaction"), "allowed"] == "impulse_penetration: System 1; soft_hand: System 2"
    assert book.loc[("trials", "object"), "allowed"].startswith("C: cube")
    assert book.loc[("frames", "right_index_tip_x"), "unit"] == "m"
    assert "tracker's frame" in book.loc[("frames", "right_index_tip_x"), "meaning"]
    assert book.loc[("trials", "started_at"), "unit"] == "s" and "session" in book.loc[("trials", "started_at"),
                                                                                         "meaning"]
    assert book.loc[("questionnaire", "rating"), "allowed"] == "0 to 10"


def _typed_objects(node, path="$"):
    """Every JSON object below ``node`` with where it is."""
    if isinstance(node, dict):
        yield path, node
        for key, value in node.items():
            yield from _typed_objects(value, f"{path}.{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _typed_objects(value, f"{path}[{i}]")


def test_dataset_description_meets_psych_ds_rules(export):
    raw = (export / DESCRIPTION).read_bytes()
    about = json.loads(raw.decode("utf-8"))
    assert about["@context"] in PSYCHDS_CONTEXTS
    assert about.get("@type", about.get("type")) in PSYCHDS_TYPES
    for field in PSYCHDS_REQUIRED:
        assert about.get(field), field
    assert isinstance(about["name"], str) and isinstance(about["description"], str)
    variables = about["variableMeasured"]
    assert isinstance(variables, list)
    names = [v if isinstance(v, str) else v["name"] for v in variables]
    assert all(isinstance(v, str) or v["@type"] == "PropertyValue" for v in variables)
    assert len(names) == len(set(names))
    # containsAllColumns and columnsMatchMetadata: every column header of every data file is listed
    headers = {c for table in exported_tables(export) for c in pd.read_csv(export / f"{table}.csv", nrows=0).columns}
    assert headers <= set(names) and set(names) <= headers
    for path, node in _typed_objects(about):
        if path == "$":
            kind = "Dataset"
        else:
            assert "@type" in node, path  # OBJECT_TYPE_MISSING
            kind = node["@type"]
        assert set(k for k in node if not k.startswith("@")) <= SCHEMA_ORG_PROPERTIES[kind], path
    assert [a["name"] for a in about["author"]] == ["A. Researcher", "B. Researcher"] and about["license"] == "CC0"
    assert "BIDSVersion" in json.loads((export / "bids" / DESCRIPTION).read_text())  # Motion-BIDS keeps its own


def test_psych_ds_variables_carry_the_codebook(export):
    about = json.loads((export / DESCRIPTION).read_text())
    by_name = {v["name"]: v for v in about["variableMeasured"]}
    assert by_name["time_s"]["unitText"] == "s" and by_name["time_s"]["minValue"] == 0
    assert by_name["rating"]["minValue"] == 0 and by_name["rating"]["maxValue"] == 10
    assert [t["termCode"] for t in by_name["group"]["valueReference"]] == ["V", "B"]
    assert by_name["qw"]["minValue"] == -1 and by_name["qw"]["maxValue"] == 1
    # a name with another meaning in another table says each
    assert "in trials: the object's code" in by_name["object"]["description"]
    assert "in frames: the object's name" in by_name["object"]["description"]


def test_an_export_without_frames_describes_only_what_it_wrote(export, tmp_path):
    study = export.parent / "study"
    out = tmp_path / "export"
    export_study(study, out, formats=("csv",), frames=False, bids=False, progress=False)
    book = pd.read_csv(out / CODEBOOK)
    assert set(book.table) == exported_tables(out) == {"trials", "progression", "questionnaire", "answers", "scores"}
    about = json.loads((out / DESCRIPTION).read_text())
    assert "right_index_tip_x" not in {v["name"] for v in about["variableMeasured"]}
    assert "bids/" not in about["description"]


def test_a_written_column_without_a_declaration_stops_the_codebook(tmp_path):
    declared = {"progression": (Column("participant", "string", "participant id", source="enrolment"),
                                Column("session_index", "Int64", "the session's number", minimum=1,
                                       source="the session log"))}
    pd.DataFrame({"participant": ["P01"], "session_index": [1]}).to_csv(tmp_path / "progression.csv", index=False)
    check_columns(tmp_path, declared)
    assert codebook(declared).column.tolist() == ["participant", "session_index"]  # a table joins by declaration
    pd.DataFrame({"participant": ["P01"], "session_index": [1], "difficulty": [2]}).to_csv(
        tmp_path / "progression.csv", index=False)
    with pytest.raises(ValueError, match=r"undeclared: \['difficulty'\]"):
        check_columns(tmp_path, declared)


def test_every_declared_column_is_described_with_its_type_and_source():
    lists = study_levels(load_protocol(PROTOCOLS / "tiny.toml"))
    for table, columns in table_declarations().items():
        book = codebook({table: columns})
        assert len(book) == len(columns) and (book.meaning != "").all() and (book.source != "").all(), table
        for column in columns:
            assert column.unit in ("", "s", "min", "ms", "m", "m/s", "rad/s", "years"), (table, column.name)
            assert column.minimum is None or column.maximum is None or column.minimum < column.maximum
            assert not column.levels or lists[column.levels], (table, column.name, column.levels)
    assert np.isclose(dict((c.name, c) for c in table_declarations()["frames"])["touching"].maximum, 2.0 ** 40 - 1)
