"""``microg hands``: import, info, filter-report and record, as a user runs them."""

import importlib.util

import pandas as pd
import pytest
from click.testing import CliRunner

from microg.hands import load_recording, write_recording
from microg.cli import main


def run(*args):
    return CliRunner().invoke(main, ["hands", *map(str, args)], catch_exceptions=False)


def test_import_then_info_then_filter_report(recordings, tmp_path):
    converted = tmp_path / "grab.arrows"
    result = run("import", recordings / "grab.json.gz", "--out", converted)
    assert result.exit_code == 0, result.output
    assert "374 frames" in result.output
    assert load_recording(converted).frames == load_recording(recordings / "grab.json.gz").frames

    again = run("import", recordings / "grab.json.gz", "--out", converted)
    assert again.exit_code == 1 and "already exists" in again.output

    info = run("info", converted)
    assert info.exit_code == 0, info.output
    for expected in ("leapjs:grab.json.gz", "complete", "frames        374", "5 intervals over 1.5x",
                     "timestamps strictly increase", "right         tracked in 374 frames, 1 track(s)",
                     "unknown"):
        assert expected in info.output

    plot, csv = tmp_path / "img" / "grab.png", tmp_path / "grab.csv"
    report = run("filter-report", converted, "--plot", plot, "--csv", csv)
    assert report.exit_code == 0, report.output
    table = pd.read_csv(csv)
    assert list(table["window"]) == list(range(1, 8))
    assert 0.8 < table.set_index("window")["lag_frames"][3] < 1.3
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"
    assert report.output.count("\n") >= 9


def test_info_tells_a_truncated_file(tmp_path):
    from tests.hands.test_recording import INFO, awkward_frames

    path = tmp_path / "cut.arrows"
    write_recording(path, INFO, awkward_frames(30))
    path.write_bytes(path.read_bytes()[:-500])
    result = run("info", path)
    assert result.exit_code == 0, result.output
    assert "TRUNCATED" in result.output and "complete frames kept" in result.output


def test_a_file_that_is_no_recording_gets_a_clear_error(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("shopping list")
    result = run("info", path)
    assert result.exit_code == 1
    assert "notes.txt: neither a microg hand recording" in result.output


def test_windows_must_be_positive_sizes(recordings):
    result = CliRunner().invoke(main, ["hands", "filter-report", str(recordings / "wave.json.gz"), "--windows", "0-3"])
    assert result.exit_code == 2 and "window sizes >= 1" in result.output


@pytest.mark.skipif(importlib.util.find_spec("leap") is not None, reason="a 'leap' module is installed here")
def test_record_without_the_sdk_says_what_is_missing(tmp_path):
    result = run("record", "--out", tmp_path / "live.arrows", "--duration", 1)
    assert result.exit_code == 1
    assert "Ultraleap's hand-tracking software" in result.output and 'pip install ".[leap]"' in result.output
    assert not (tmp_path / "live.arrows").exists()


def test_every_verb_has_help():
    for verb in ("import", "info", "filter-report", "record"):
        result = run(verb, "--help")
        assert result.exit_code == 0 and "Usage:" in result.output
