"""The frame log's codecs: what a session logs reads back bit for bit, batches of the old codec read
beside new ones, and damage to a new batch is found."""

from __future__ import annotations

import functools
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main
from microg.paths import LEAP_RECORDINGS
from microg.study import framelog
from microg.study.export import export_study, read_tables
from microg.study.store import open_study

from .conftest import PROTOCOLS


def run(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result.output


def logging_batches(monkeypatch) -> dict[int, list[np.ndarray]]:
    """Every batch a session hands the store from now on, by task run, as it was handed over."""
    handed: dict[int, list[np.ndarray]] = {}
    insert = framelog.insert

    def keep(db, run_id, first, frames):
        handed.setdefault(run_id, []).append(frames.copy())
        return insert(db, run_id, first, frames)

    monkeypatch.setattr(framelog, "insert", keep)
    return handed


def stored_codecs(study: Path) -> set[str]:
    with sqlite3.connect(study / "study.db") as db:
        return {framelog.codec_of(blob) for (blob,) in db.execute("SELECT data FROM frames")}


def assert_read_back(study: Path, handed: dict[int, list[np.ndarray]]) -> np.ndarray:
    """Every run's logged frames, read from the store, are the frames the session handed it, to the
    bit; each batch also goes through each codec and back unchanged. Returns them all."""
    with open_study(study, readonly=True) as store:
        for run_id, batches in handed.items():
            assert framelog.read(store.db, run_id).tobytes() == np.concatenate(batches).tobytes()
    for codec in framelog.CODECS:
        for batch in (b for batches in handed.values() for b in batches):
            assert framelog.decode(framelog.encode(batch, codec), len(batch)).tobytes() == batch.tobytes(), codec
    return np.concatenate([b for batches in handed.values() for b in batches])


def test_a_real_recording_replayed_through_a_session_reads_back_bit_for_bit(tmp_path, monkeypatch):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "quick.toml", "--seed", "3")
    run("participant", "add", study, "--id", "P01", "--gender", "female", "--age", "24", "--handedness", "right",
        "--mr-experience", "yes")
    manifest = tmp_path / "replay.toml"
    manifest.write_text('align = "grasp"\n' + "".join(
        f'[[task]]\nobject = "{name}"\nrecording = "{LEAP_RECORDINGS / recording}"\n'
        for name, recording in (("cube", "grab.json.gz"), ("flat_cuboid", "HandSplay-110fps.json.gz"),
                                ("long_cuboid", "pinch.json.gz"), ("ball", "wave.json.gz"))))
    handed = logging_batches(monkeypatch)
    run("session", "run", study, "--participant", "P01", "--input", f"replay:{manifest}", "--quiet")
    frames = assert_read_back(study, handed)
    assert stored_codecs(study) == {framelog.CODEC}
    assert frames["tracked"].any() and not frames["tracked"].all(), "a hand tracked, and one the codec leaves out"
    assert_hands_in_four_bytes(study)


def test_a_simulated_run_reads_back_bit_for_bit(tmp_path, monkeypatch):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "tiny.toml", "--seed", "5")
    run("participant", "add", study, "--id", "P01", "--gender", "male", "--age", "22", "--handedness", "right",
        "--mr-experience", "no")
    handed = logging_batches(monkeypatch)
    run("session", "run", study, "--participant", "P01", "--input", "simulated:veteran", "--questionnaire", "skip",
        "--quiet")
    frames = assert_read_back(study, handed)
    assert stored_codecs(study) == {framelog.CODEC} and frames["tracked"].any() and frames["grasped"].any()
    assert_hands_in_four_bytes(study)


def assert_hands_in_four_bytes(study: Path) -> None:
    """Every stored batch keeps its tracked hands' 8-byte numbers in 4 bytes: they entered at the
    tracker's precision (``microg.skeleton.TRACKER_FLOAT``)."""
    with sqlite3.connect(study / "study.db") as db:
        for count, blob in db.execute("SELECT count, data FROM frames"):
            frames = framelog.decode(blob, count)
            narrowed = framelog.BLOSC_PREFIX[framelog.CODEC].unpack_from(blob)[2]
            sides = [s for s in range(len(framelog.SIDES)) if frames["tracked"][:, s].any()]
            expected = sum(1 << i for i, span in enumerate(framelog.NARROWABLE) for s in sides
                           if span in framelog.HAND_SPANS[s])
            assert narrowed == expected, (count, narrowed, expected)


def some_frames(n: int = 40) -> np.ndarray:
    """Frames whose hands come and go within the batch; their values random to the last bit."""
    rng = np.random.default_rng(7)
    frames = np.frombuffer(rng.bytes(n * framelog.FRAME.itemsize), dtype=framelog.FRAME).copy()
    frames["tracked"] = [[i % 3 == 0, 5 <= i < 30] for i in range(n)]
    for field in framelog.HAND_FIELDS:
        frames[field][~frames["tracked"]] = np.nan
    for field in ("stage", "place", "place_lit", "grasped", "held"):
        frames[field] = rng.integers(0, 2, n)
    return frames


@pytest.mark.parametrize("change", ["as written", "untracked zero", "untracked other NaN", "all tracked",
                                    "none tracked", "one frame", "no frames", "tracker precision",
                                    "one number beyond it"])
def test_every_bit_of_a_batch_comes_back(change):
    frames = some_frames()
    if change in ("tracker precision", "one number beyond it"):
        for field in ("joints", "widths", "palm_position", "palm_orientation"):
            with np.errstate(over="ignore"):
                frames[field] = frames[field].astype(np.float32)
        if change == "one number beyond it":
            frames["joints"][3, 0, 2, 1, 0] = 0.1  # not a float32 number: the left joints stay 8 bytes
        narrowed = framelog.BLOSC_PREFIX[framelog.CODEC].unpack_from(framelog.encode(frames))[2]
        kept_whole = {0} if change == "one number beyond it" else set()
        assert {i for i in range(len(framelog.NARROWABLE)) if not narrowed >> i & 1} == kept_whole
    if change == "untracked zero":  # an untracked hand that is not what frames_of writes is kept as it is
        frames["joints"][~frames["tracked"]] = 0.0
    elif change == "untracked other NaN":
        frames["rendered"][~frames["tracked"]] = np.frombuffer(b"\x01\x00\xc0\xff", "<f4")[0]
    elif change == "all tracked":
        frames["tracked"] = True
    elif change == "none tracked":
        frames["tracked"] = False
        for field in framelog.HAND_FIELDS:
            frames[field] = np.nan
    elif change == "one frame":
        frames = frames[5:6]
    elif change == "no frames":
        frames = frames[:0]
    blob = framelog.encode(frames)
    assert framelog.codec_of(blob) == framelog.CODEC
    assert framelog.decode(blob, len(frames)).tobytes() == frames.tobytes()
    shuffled = frames[::-1]  # not contiguous in memory
    assert framelog.decode(framelog.encode(shuffled), len(frames)).tobytes() == shuffled.tobytes()


def test_a_blob_that_is_not_whole_is_an_error_that_says_so():
    frames = some_frames()
    blob = framelog.encode(frames)
    with pytest.raises(ValueError, match="blosc: does not decompress"):
        framelog.decode(blob[:len(blob) // 2], len(frames))
    with pytest.raises(ValueError, match=r"blosc: \d+ words, (too few for|not the \d+ of) 41 frames"):
        framelog.decode(blob, len(frames) + 1)
    with pytest.raises(ValueError, match=r"starts with b'\\x00mgf', the tag of no codec this microg reads \(zstd, "
                                         r"blosc, blosc32\): written by a newer microg, or damaged"):
        framelog.decode(b"\x00mgf" + blob[4:], len(frames))


@pytest.mark.parametrize("old_codec", ["zstd", "blosc"])
def test_a_study_with_old_codec_batches_opens_checks_exports_and_resimulates_as_before(tmp_path, monkeypatch,
                                                                                       old_codec):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "tiny.toml", "--seed", "5")
    for participant in ("P01", "P02"):
        run("participant", "add", study, "--id", participant, "--gender", "male", "--age", "22", "--handedness",
            "right", "--mr-experience", "no")
    handed = logging_batches(monkeypatch)
    with monkeypatch.context() as old:  # P01's session as an earlier microg wrote it
        old.setattr(framelog, "encode", functools.partial(framelog.encode, codec=old_codec))
        run("session", "run", study, "--participant", "P01", "--input", "simulated:veteran", "--questionnaire",
            "skip", "--quiet")
    assert stored_codecs(study) == {old_codec}
    with sqlite3.connect(study / "study.db") as db:
        blob = db.execute("SELECT data FROM frames LIMIT 1").fetchone()[0]
    assert old_codec != "zstd" or blob[:4] == b"\x28\xb5\x2f\xfd", "the oldest batches are plain zstd frames"
    run("session", "run", study, "--participant", "P02", "--input", "simulated:veteran", "--questionnaire", "skip",
        "--quiet")
    assert stored_codecs(study) == {old_codec, framelog.CODEC}
    assert_read_back(study, handed)
    assert "sound" in run("study", "check", study)

    export_study(study, tmp_path / "export", bids=False, progress=False, say=lambda text: None)
    assert set(read_tables(tmp_path / "export")[0].participant) == {"P01", "P02"}
    table = pd.read_parquet(tmp_path / "export" / "frames.parquet")
    for run_id, batches in handed.items():  # both codecs' runs export the frames as they were logged
        exported = table[table.run_id == run_id]
        for column, values in framelog.frame_columns(np.concatenate(batches)).items():
            np.testing.assert_array_equal(exported[column].to_numpy(), values, err_msg=column)

    run("session", "resimulate", study, "--all", "--label", "same", "--quiet")
    columns = ["participant", "phase", "interaction", "object", "status", "completed", "time_s", "attempts"]
    assert read_tables(study / "resimulated" / "same")[0][columns].equals(read_tables(study)[0][columns])


def test_study_check_finds_a_damaged_new_batch(tmp_path):
    study = tmp_path / "study"
    run("study", "init", study, "--protocol", PROTOCOLS / "tiny.toml", "--seed", "5")
    run("participant", "add", study, "--id", "P01", "--gender", "male", "--age", "22", "--handedness", "right",
        "--mr-experience", "no")
    run("session", "run", study, "--participant", "P01", "--input", "simulated:veteran", "--questionnaire", "skip",
        "--quiet")
    with sqlite3.connect(study / "study.db", isolation_level=None) as db:
        run_id, first, count, t_first, t_last, blob = db.execute(
            "SELECT run_id, first, count, t_first, t_last, data FROM frames ORDER BY run_id, first LIMIT 1").fetchone()
        assert framelog.codec_of(blob) == framelog.CODEC
        flipped = bytearray(blob)
        flipped[len(blob) // 2] ^= 0x10
        cut = blob[:len(blob) - 9]  # sound by a checksum made for it: found when it is decoded
        forged = framelog.checksum(run_id, first=first, count=count, t_first=t_first, t_last=t_last, blob=cut)
        db.execute("DROP TRIGGER frames_no_update")
        db.execute("UPDATE frames SET data = ? WHERE run_id = ? AND first = ?", (bytes(flipped), run_id, first))
    result = CliRunner().invoke(main, ["study", "check", str(study)])
    assert result.exit_code == 1 and "does not match its checksum" in result.output
    with sqlite3.connect(study / "study.db", isolation_level=None) as db:
        db.execute("UPDATE frames SET data = ?, checksum = ? WHERE run_id = ? AND first = ?", (cut, forged, run_id,
                                                                                              first))
    result = CliRunner().invoke(main, ["study", "check", str(study)])
    assert result.exit_code == 1 and "matches its checksum but does not decode (blosc:" in result.output
