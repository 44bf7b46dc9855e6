"""Project-wide rules: every verb of ``microg`` explains itself; dependencies point one way."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from microg.cli import main


def verbs(group: click.Group, prefix=()):
    for name, command in group.commands.items():
        yield prefix + (name,)
        if isinstance(command, click.Group):
            yield from verbs(command, prefix + (name,))


@pytest.mark.parametrize("verb", list(verbs(main)), ids=" ".join)
def test_every_verb_has_help(verb):
    result = CliRunner().invoke(main, [*verb, "--help"], prog_name="microg")
    assert result.exit_code == 0, result.output
    assert f"Usage: microg {' '.join(verb)}" in result.output


def test_the_main_verbs_are_there():
    names = {" ".join(v) for v in verbs(main)}
    assert {"demo", "sim demo", "hands import", "hands info", "hands filter-report", "hands record", "study init",
            "participant add", "session run", "session resume", "export", "report", "view",
            "bench accuracy", "bench peers", "bench throughput"} <= names


def test_dependencies_point_one_way():
    """import-linter's contracts in pyproject.toml: each room of the pipeline imports only the rooms before it."""
    root = Path(__file__).resolve().parents[1]
    result = subprocess.run([str(Path(sys.executable).with_name("lint-imports"))], cwd=root, capture_output=True,
                            text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert " 0 broken" in result.stdout


def test_a_normal_install_ships_every_room_and_the_shipped_files():
    """pyproject.toml lists the packages by hand (protocols/ and data/ are mapped into the package):
    every folder of microg/ with Python in it must be on the list."""
    import tomllib

    root = Path(__file__).resolve().parents[1]
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    rooms = {"microg." + p.parent.relative_to(root / "microg").as_posix().replace("/", ".")
             for p in (root / "microg").rglob("__init__.py") if p.parent != root / "microg"}
    assert rooms | {"microg", "microg.protocols", "microg.protocols.objects", "microg.data"} == listed
