"""The export's codebook: every column of every table it writes, described from the declarations
that make the tables (``microg.schema.Column``), so that the description cannot drift from the data.

A table is a name and a tuple of ``Column``; ``write_codebook`` takes the tables an export wrote
and writes, beside them:

- ``codebook.csv``: one row per column of each table (``HEADER``: table, column, type, unit,
  allowed values or range, meaning, source), in the tables' column order;
- ``dataset_description.json``: the export's description in Psych-DS's form (schema.org's
  ``Dataset`` in JSON-LD: ``name``, ``description``, and ``variableMeasured``, one ``PropertyValue``
  per column name with its meaning, unit, range, allowed values and source).

Values that come from the study's own protocol (group codes, phases, interaction models, objects,
instruments: ``Column.levels``) are listed from the protocol at each export (``study_levels``).
Before writing, each table's written columns are checked against its declaration
(``check_columns``): a table whose file has a column the declaration lacks, or the other way
round, stops the export naming both. The Motion-BIDS folder (``bids/``) is a dataset of its own with
its own ``dataset_description.json`` (BIDS's) and column descriptions in BIDS's sidecars; the files
here describe the export's own tables.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq

from microg import __version__
from microg.schema import Column
from microg.task import KINDS

from .protocol import Protocol

CODEBOOK = "codebook.csv"
DESCRIPTION = "dataset_description.json"
HEADER = ("table", "column", "type", "unit", "allowed", "meaning", "source")
TYPES = {"string": "text", "Int64": "integer", "int64": "integer", "float64": "number", "bool": "true/false",
         "boolean": "true/false"}
"""A declared dtype as the codebook names it."""
SCHEMA_ORG = "http://schema.org/"
"""The namespace Psych-DS requires of ``dataset_description.json`` (its validator's spelling)."""
TRUTH = ("True", "False")
"""How the export's CSV writes a true/false column's values."""


def study_levels(protocol: Protocol, interactions: Sequence[str] = ()) -> dict[str, dict[str, str]]:
    """The study's own lists of values (``Column.levels``), each value with what it means, from the
    protocol; ``interactions``: interaction models the study's tasks ran with besides the protocol's
    (a re-simulated study's)."""
    training = protocol.training
    objects = protocol.objects + (training.objects if training else ())
    labels = {phase.interaction: phase.label for phase in protocol.phases}
    if training:
        labels.setdefault(training.interaction, "training")
    for interaction in interactions:
        labels.setdefault(interaction, interaction)
    phases = {"training": f"training ({training.kind} tasks), for group(s) {', '.join(training.groups)}"} \
        if training else {}
    phases |= {phase.name: f"{phase.kind} tasks with {phase.interaction}" for phase in protocol.phases}
    kinds = list(dict.fromkeys(KINDS[protocol.kind(phase)] for phase in phases))
    return {
        "groups": {group.code: group.name for group in protocol.groups},
        "phases": phases,
        "interactions": labels,
        "objects": {o.code: o.name for o in objects},
        "object_names": {o.name: o.name if o.code == o.name else f"code {o.code}" for o in objects},
        "instruments": {key: instrument.title for key, instrument in protocol.instruments.items()},
        "kinds": {kind.name: kind.title for kind in kinds},
        "sessions": {plan.name: f"{', '.join(plan.phases) or 'no tasks'}; {plan.after_days} day(s) after the "
                     "previous session" for plan in protocol.sessions},
        "stages": {stage.name: stage.text for kind in kinds for stage in kind.stages},
    }


def allowed_values(column: Column, levels: Mapping[str, Mapping[str, str]]) -> dict[str, str]:
    """The values a column may take, each with what it means (the value itself where the
    declaration says no more); empty for a column whose values are open or a range."""
    if column.levels:
        return dict(levels.get(column.levels, {}))
    if column.values:
        return {value: value for value in column.values}
    if column.dtype in ("bool", "boolean"):
        return {value: value for value in TRUTH}
    return {}


def _number(value: float) -> str:
    return f"{value:g}"


def allowed_text(column: Column, levels: Mapping[str, Mapping[str, str]]) -> str:
    """The codebook's ``allowed`` cell: the values (``V: veterans; B: beginners``) or the range
    (``0 to 10``, ``>= 0``); empty for any."""
    values = allowed_values(column, levels)
    if values:
        return "; ".join(value if meaning == value else f"{value}: {meaning}" for value, meaning in values.items())
    if column.minimum is not None and column.maximum is not None:
        return f"{_number(column.minimum)} to {_number(column.maximum)}"
    if column.minimum is not None:
        return f">= {_number(column.minimum)}"
    if column.maximum is not None:
        return f"<= {_number(column.maximum)}"
    return ""


def codebook(tables: Mapping[str, Sequence[Column]], levels: Mapping[str, Mapping[str, str]] | None = None
             ) -> pd.DataFrame:
    """One row per column of each table (``HEADER``), in the tables' order and their columns' order.

    Parameters
    ----------
    tables : mapping of str to sequence of Column
        Each table's name and its declared columns.
    levels : mapping, optional
        The study's own lists (``study_levels``) for columns that take their values from it.

    Returns
    -------
    pandas.DataFrame
        Columns ``HEADER``.

    Examples
    --------
    >>> from microg.schema import Column
from microg.task import KINDS
    >>> from microg.study.codebook import codebook
    >>> codebook({"trials": (Column("time_s", "float64", "completion time", unit="s", minimum=0,
    ...                             source="the session log"),)})[["column", "type", "unit", "allowed"]]
       column    type unit allowed
    0  time_s  number    s    >= 0
    """
    levels = levels or {}
    rows = [(table, c.name, TYPES[c.dtype], c.unit, allowed_text(c, levels), c.description, c.source)
            for table, columns in tables.items() for c in columns]
    return pd.DataFrame(rows, columns=list(HEADER))


def _variable(name: str, described: list[tuple[str, Column]], levels: Mapping[str, Mapping[str, str]]) -> dict:
    """One ``PropertyValue`` for a column name found in one or more tables: its meaning (each
    table's, where they differ), and the unit, range, values and source the tables agree on."""
    meanings = {column.description for _, column in described}
    description = described[0][1].description if len(meanings) == 1 else \
        "; ".join(f"in {table}: {column.description}" for table, column in described)
    variable = {"@type": "PropertyValue", "name": name,
                "description": f"{description} (table{'s' if len(described) > 1 else ''}: "
                               f"{', '.join(table for table, _ in described)})"}

    def agreed(value):
        return {value(column) for _, column in described} == {value(described[0][1])}

    first = described[0][1]
    if first.unit and agreed(lambda c: c.unit):
        variable["unitText"] = first.unit
    if first.minimum is not None and agreed(lambda c: c.minimum):
        variable["minValue"] = first.minimum
    if first.maximum is not None and agreed(lambda c: c.maximum):
        variable["maxValue"] = first.maximum
    values = allowed_values(first, levels)
    if values and all(allowed_values(c, levels) == values for _, c in described):
        variable["valueReference"] = [{"@type": "DefinedTerm", "termCode": value, "name": meaning}
                                      for value, meaning in values.items()]
    if first.source and agreed(lambda c: c.source):
        variable["measurementTechnique"] = first.source
    return variable


def dataset_description(tables: Mapping[str, Sequence[Column]], *, name: str, description: str,
                        levels: Mapping[str, Mapping[str, str]] | None = None, authors: Sequence[str] = (),
                        license: str = "") -> dict:
    """The export's ``dataset_description.json`` in Psych-DS's form: schema.org's ``Dataset`` with
    ``name``, ``description`` and ``variableMeasured`` (one ``PropertyValue`` per column name of
    every table), and ``author`` and ``license`` where the protocol's ``[dataset]`` gives them."""
    levels = levels or {}
    by_name: dict[str, list[tuple[str, Column]]] = {}
    for table, columns in tables.items():
        for column in columns:
            by_name.setdefault(column.name, []).append((table, column))
    about = {"@context": SCHEMA_ORG, "@type": "Dataset", "name": name, "description": description,
             "variableMeasured": [_variable(n, described, levels) for n, described in by_name.items()]}
    if authors:
        about["author"] = [{"@type": "Person", "name": author} for author in authors]
    if license:
        about["license"] = license
    return about


def written_columns(folder: Path, table: str) -> list[str]:
    """The columns of a table as written in ``folder``: its Parquet file's schema, else its CSV
    file's header."""
    if (folder / f"{table}.parquet").exists():
        return list(pq.read_schema(folder / f"{table}.parquet").names)
    return pd.read_csv(folder / f"{table}.csv", nrows=0).columns.tolist()


def check_columns(folder: Path, tables: Mapping[str, Sequence[Column]]) -> None:
    """Refuse a table whose written columns are not its declared ones, in order (``ValueError``
    naming the table and the columns that differ)."""
    for table, columns in tables.items():
        declared, written = [c.name for c in columns], written_columns(folder, table)
        if declared != written:
            raise ValueError(f"{folder / table}: written columns {written} are not the declared ones {declared} "
                             f"(undeclared: {sorted(set(written) - set(declared))}, not written: "
                             f"{sorted(set(declared) - set(written))}); declare every column in microg.schema")


def write_codebook(folder: Path, tables: Mapping[str, Sequence[Column]], *, study: str, protocol: Protocol,
                   interactions: Sequence[str] = ()) -> list[Path]:
    """``codebook.csv`` and ``dataset_description.json`` for the ``tables`` written in ``folder``
    (checked against their declarations first, ``check_columns``); returns the two paths."""
    check_columns(folder, tables)
    levels = study_levels(protocol, interactions)
    codebook(tables, levels).to_csv(folder / CODEBOOK, index=False)
    listed = "; ".join(f"{table} ({', '.join(p.name for p in sorted(folder.glob(f'{table}.*')))})" for table in tables)
    about = protocol.dataset
    description = (f"Tables of the user study {study!r} (protocol: {protocol.title or protocol.name}), exported by "
                   f"microg {__version__}: {listed}. {CODEBOOK} describes every column, as variableMeasured does "
                   "here; instruments/ holds the questionnaires' files"
                   + ("; bids/ holds the hand-tracking data as a Motion-BIDS dataset with its own "
                      "dataset_description.json." if (folder / "bids").is_dir() else "."))
    (folder / DESCRIPTION).write_text(json.dumps(dataset_description(
        tables, name=f"{study}: {protocol.title}" if protocol.title else study, description=description,
        levels=levels, authors=about.authors, license=about.license), indent=2), encoding="utf-8")
    return [folder / CODEBOOK, folder / DESCRIPTION]
