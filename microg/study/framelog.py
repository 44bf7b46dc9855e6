"""The frame log: what every frame of a task run leaves in the study's store, written and read here only.

A logged frame holds the task's state (stage, current place, its light and timer, grasped,
held), the phalanx slots touching the object (bit k = slot k, ``microg.skeleton.slot_name(k)``), the
object's pose and velocities, and for each hand side whether it was tracked, its track id, its
joints, bone widths and palm pose exactly as the physics received them, and its rendered
(god-object) phalanx centres. That is enough to draw a session again (``microg.view``), to
measure it (the rating model, exports) and to simulate it again (``hand_frames``).

Storage: the store commits frames a batch at a time (the protocol's ``logging.frame_batch``), so
a batch is one row. Its blob begins with the tag of the codec that wrote it (``CODECS``), so
batches of any codec read side by side in one study. New batches use ``blosc32``: each field's
values one channel after another (a joint's x over the batch side by side, where a smooth signal
changes little), as 4-byte words (an 8-byte number's low words apart from its high ones, a
1-byte field a word a value), an untracked hand's fields left out (they are NaN: reading writes
them back), then byte-shuffled and compressed with LZ4HC by Blosc (numcodecs); a hand field whose
every number in the batch is a float32 number is kept as 4-byte floats (a bit per side and field
says so). Hands enter the frame path at a tracker's precision, 32-bit floats
(``microg.skeleton.TRACKER_FLOAT``: the Leap's and WebXR's own), so that is every hand field but
where the tracking guard bridged a glitch (its straight line is float64). ``blosc``, the same
without that, wrote the batches before it, ``zstd`` (the columns side by side, compressed with
zstd) the ones before those. All are lossless: the hands are kept exactly as the physics received
them (float64 numbers, so a run simulates again bit for bit; a bone's width, constant over a
track, costs next to nothing compressed); what the physics computed (the object's state, the
rendered phalanges, timers) is kept as float32, 0.1 micrometre at arm's length. The joints are
most of a frame's bytes: a hand's noise reaches its last bits, which no lossless codec takes away
(``microg bench store`` measures where the bytes go). Each batch carries its checksum
(``checksum``: SHA-256 of its place in the run, its times and its blob, the codec's tag with it),
written with it and verified by every ``read``, so a damaged batch is never decoded as if it were
sound; the ledger (``microg.study.ledger``) chains the checksums with the rest of the log.
"""

from __future__ import annotations

import hashlib
import sqlite3
import struct
from typing import Iterator, NamedTuple, Sequence

import numpy as np
import pandas as pd
import pyarrow as pa
from numcodecs import Blosc

from microg.schema import FRAME_LOG, Column
from microg.skeleton import BONES, BONES_PER_HAND, DIGITS, N_BONES, N_DIGITS, SIDES, SLOTS, Hand, HandFrame, side_slots
from microg.task import KINDS, Kind, Moments

from .ledger import run_name

def stage_names() -> tuple[str, ...]:
    """A frame's ``stage`` is stored as its index here: every kind's stages, in the registry's order
    (``microg.task.KINDS``), each name once (so the codes of a study's frames stay as they were when a
    kind joins the registry)."""
    return tuple(dict.fromkeys(name for kind in KINDS.values() for name in kind.stage_names))
JOINTS = N_DIGITS * (N_BONES + 1)
FRAME = np.dtype([
    ("t", "<f8"), ("stage", "u1"), ("place", "u1"), ("place_lit", "?"), ("place_timer", "<f4"),
    ("grasped", "?"), ("held", "?"), ("touching", "<u8"),
    ("position", "<f4", 3), ("orientation", "<f4", 4), ("velocity", "<f4", 3), ("angular_velocity", "<f4", 3),
    ("tracked", "?", 2), ("track_id", "<u4", 2), ("joints", "<f8", (2, N_DIGITS, N_BONES + 1, 3)),
    ("widths", "<f8", (2, N_DIGITS, N_BONES)), ("palm_position", "<f8", (2, 3)),
    ("palm_orientation", "<f8", (2, 4)), ("rendered", "<f4", (2, N_DIGITS * N_BONES, 3)),
])
"""One logged frame; per-side fields are indexed left (0), right (1). Untracked: NaN, ``tracked`` False."""
HAND_FIELDS = ("joints", "widths", "palm_position", "palm_orientation", "rendered")
"""The per-side fields that are NaN where a hand was not tracked."""
CODECS = {"zstd": b"\x28\xb5\x2f\xfd", "blosc": b"MGF2", "blosc32": b"MGF3"}
"""Each codec's tag, the first bytes of its blobs (``zstd``'s is the zstd frame's own magic number:
its blobs were written before codecs had tags)."""
CODEC = "blosc32"
"""The codec ``encode`` writes new batches with."""


class Span(NamedTuple):
    """Fields side by side in a ``FRAME`` record whose elements are ``size`` bytes wide."""

    offset: int
    width: int
    size: int


def _spans(names: Sequence[str], side: int | None = None) -> tuple[Span, ...]:
    """The fields ``names`` (one side's half of per-side fields) as ``Span``s, fields of one
    element size that lie side by side joined."""
    spans: list[Span] = []
    for name in names:
        field, offset = FRAME.fields[name][:2]
        width = field.itemsize if side is None else field.itemsize // len(SIDES)
        offset += 0 if side is None else side * width
        if spans and spans[-1].offset + spans[-1].width == offset and spans[-1].size == field.base.itemsize:
            spans[-1] = spans[-1]._replace(width=spans[-1].width + width)
        else:
            spans.append(Span(offset, width, field.base.itemsize))
    return tuple(spans)


FRAME_SPANS = _spans([name for name in FRAME.names if name not in HAND_FIELDS])
"""The fields of the whole frame (``tracked`` among them, which says where the hands are)."""
HAND_SPANS = tuple(_spans(HAND_FIELDS, side) for side in range(len(SIDES)))
"""Each side's half of the hand fields."""


def _untracked() -> np.ndarray:
    record = np.zeros(1, dtype=FRAME)
    for field in HAND_FIELDS:
        record[field] = np.nan
    return record.view(np.uint8)


UNTRACKED = _untracked()
"""A record's bytes with every hand field NaN, as ``frames_of`` writes an untracked hand."""
TRACKED = FRAME.fields["tracked"][1]
BLOSC_PREFIX = {"blosc": struct.Struct("<4s?"), "blosc32": struct.Struct("<4s?B")}
"""Each Blosc codec's prefix: its tag, whether the untracked hands are left out (they were
``UNTRACKED``'s), and for ``blosc32`` the bits of the hand spans kept as 4-byte floats (``NARROWABLE``)."""
NARROWABLE = tuple(span for spans in HAND_SPANS for span in spans if span.size == 8)
"""The hands' 8-byte spans (each side's joints, widths, palm position and orientation), in the
order of ``blosc32``'s bits."""
BLOSC = Blosc(cname="lz4hc", clevel=2, shuffle=Blosc.SHUFFLE)
"""Byte-shuffled 4-byte words, then LZ4HC (Blosc's level 2). zstd in its place saved 3 % of the
bytes and took a third longer to decode, longer than the old codec (measured with ``microg bench
store``): the joints' noisy low bytes are stored as they are by either."""


def encode(frames: np.ndarray, codec: str = CODEC) -> bytes:
    """A batch of ``FRAME`` records as one blob, its codec's tag first (module docstring)."""
    if codec == "zstd":
        columns = b"".join(np.ascontiguousarray(frames[name]).tobytes() for name in FRAME.names)
        return pa.compress(columns, codec="zstd", asbytes=True)
    if codec not in BLOSC_PREFIX:
        raise ValueError(f"codec = {codec!r}: microg writes frame batches with one of {', '.join(CODECS)}")
    records = np.ascontiguousarray(frames).view(np.uint8).reshape(len(frames), FRAME.itemsize)
    tracked = records[:, TRACKED:TRACKED + len(SIDES)] != 0
    left_out = _untracked_as_written(records, tracked)
    parts = _parts(_kept(tracked) if left_out else [slice(None)] * len(SIDES), len(records))
    narrowed = _narrowable(records, parts) if codec == "blosc32" else 0
    words = np.empty(sum(_words(spans, count, narrowed) for _, spans, count in parts), "<i4")
    at = 0
    for rows, spans, count in parts:
        held = records if isinstance(rows, slice) else records[rows]
        for span in spans:
            if _narrow(span, narrowed):
                view = words[at:at + span.width // 8 * len(held)].view("<f4").reshape(-1, len(held))
                view[...] = _values(held, span)
            else:
                view = _view(held, span)
                words[at:at + view.size].reshape(view.shape)[...] = view
            at += view.size
    prefix = BLOSC_PREFIX[codec]
    head = prefix.pack(CODECS[codec], left_out, *((narrowed,) if codec == "blosc32" else ()))
    return head + (BLOSC.encode(words) if len(words) else b"")


def _values(records: np.ndarray, span: Span) -> np.ndarray:
    """A span of 8-byte floats in ``FRAME`` records' bytes as (channels, frames) float64, a view."""
    return np.ndarray((span.width // 8, len(records)), "<f8", records, span.offset, (8, FRAME.itemsize))


def _narrow(span: Span, narrowed: int) -> bool:
    """Whether ``blosc32`` stores the hand span as 4-byte floats (its bit in ``narrowed``)."""
    return span in NARROWABLE and bool(narrowed >> NARROWABLE.index(span) & 1)


def _narrowable(records: np.ndarray, parts) -> int:
    """The bits (``NARROWABLE``'s order) of the hand spans whose every stored value is a float32
    number, so that ``blosc32`` keeps all of its bits in 4 bytes (NaN's bits included)."""
    bits = 0
    for rows, spans, _ in parts:
        held = records if isinstance(rows, slice) else records[rows]
        for span in spans:
            if span in NARROWABLE and len(held):
                values = _values(held, span)
                with np.errstate(over="ignore"):  # a number beyond float32's range is not one
                    narrow = values.astype("<f4").astype("<f8")
                if np.array_equal(narrow.view("<i8"), values.view("<i8")):
                    bits |= 1 << NARROWABLE.index(span)
    return bits


def _untracked_as_written(records: np.ndarray, tracked: np.ndarray) -> bool:
    """Whether every untracked hand in the records is ``UNTRACKED``'s, so that ``blosc`` may leave
    it out and ``decode`` write it back."""
    for side, spans in enumerate(HAND_SPANS):
        untracked = ~tracked[:, side]
        rows = slice(None) if untracked.all() else untracked
        if untracked.any() and not all((records[rows, span.offset:span.offset + span.width]
                                        == UNTRACKED[span.offset:span.offset + span.width]).all() for span in spans):
            return False
    return True


def _kept(tracked: np.ndarray) -> list:
    """Per side, the frames whose hand fields ``blosc`` keeps when it leaves the untracked out."""
    everywhere = tracked.all(axis=0)
    return [slice(None) if everywhere[side] else np.flatnonzero(tracked[:, side]) for side in range(len(SIDES))]


def _parts(kept: Sequence, count: int) -> list[tuple[slice | np.ndarray, tuple[Span, ...], int]]:
    """(frames, spans, how many frames) in the order ``blosc`` stores them: the whole frame's
    fields over every frame, then each side's hand fields over the frames ``kept``."""
    parts = [(slice(None), FRAME_SPANS, count)] + [(rows, spans, count if isinstance(rows, slice) else len(rows))
                                                   for rows, spans in zip(kept, HAND_SPANS)]
    return [part for part in parts if part[2]]


def _words(spans: Sequence[Span], count: int, narrowed: int = 0) -> int:
    """How many 4-byte words ``blosc`` stores for the spans over ``count`` frames (a 1-byte
    element takes a word of its own, an 8-byte float ``narrowed`` one)."""
    return count * sum(span.width // (8 if _narrow(span, narrowed) else min(span.size, 4)) for span in spans)


def _view(records: np.ndarray, span: Span) -> np.ndarray:
    """The span in ``FRAME`` records' bytes (records, bytes) as ``blosc`` stores it, a view: its
    elements' 4-byte words (words, channels, frames), a 1-byte element a word (1, channels,
    frames), so each channel's values over the batch lie side by side (where a smooth signal
    changes little) and an 8-byte element's low words apart from its high ones."""
    if span.size == 1:
        return np.ndarray((1, span.width, len(records)), np.uint8, records, span.offset, (1, 1, FRAME.itemsize))
    return np.ndarray((span.size // 4, span.width // span.size, len(records)), "<i4", records, span.offset,
                      (4, span.size, FRAME.itemsize))


def codec_of(blob: bytes) -> str:
    """The codec that wrote a batch's blob, read off its tag (``ValueError`` for none known)."""
    tag = bytes(blob[:4])
    for codec, known in CODECS.items():
        if tag == known:
            return codec
    raise ValueError(f"its blob starts with {tag!r}, the tag of no codec this microg reads ({', '.join(CODECS)}): "
                     "written by a newer microg, or damaged")


def decode(blob: bytes, count: int) -> np.ndarray:
    """The ``count`` ``FRAME`` records of a blob written by ``encode`` with any of ``CODECS``
    (``ValueError`` or ``OSError`` when it does not hold them)."""
    if codec_of(blob) == "zstd":
        frames = np.empty(count, dtype=FRAME)
        raw = pa.decompress(blob, decompressed_size=count * FRAME.itemsize, codec="zstd", asbytes=True)
        offset = 0
        for name in FRAME.names:
            field = FRAME.fields[name][0]
            size = count * field.itemsize
            frames[name] = np.frombuffer(raw, dtype=field.base, count=size // field.base.itemsize,
                                         offset=offset).reshape((count,) + field.shape)
            offset += size
        return frames
    prefix = BLOSC_PREFIX[codec_of(blob)]
    if len(blob) < prefix.size:
        raise ValueError(f"blosc: {len(blob)} bytes, fewer than its prefix's {prefix.size}")
    left_out, narrowed = (prefix.unpack_from(blob)[1:] + (0,))[:2]
    try:
        words = np.frombuffer(BLOSC.decode(memoryview(blob)[prefix.size:]) if len(blob) > prefix.size else b"",
                              "<i4")
    except RuntimeError as error:  # what numcodecs raises for a buffer Blosc cannot read
        raise ValueError(f"blosc: does not decompress ({error})") from None
    records = np.empty((count, FRAME.itemsize), np.uint8)
    if left_out:
        records[...] = UNTRACKED
    at = 0
    parts = _parts([slice(None)] * len(SIDES), count)[:1]  # the whole frame's fields say where the hands are
    while parts:
        rows, spans, length = parts.pop(0)
        if at + _words(spans, length, narrowed) > len(words):
            raise ValueError(f"blosc: {len(words)} words, too few for {count} frames")
        held = records if isinstance(rows, slice) else records[rows]
        for span in spans:
            if _narrow(span, narrowed):
                view = _values(held, span)
                view[...] = words[at:at + view.size].view("<f4").reshape(view.shape)
            else:
                view = _view(held, span)
                view[...] = words[at:at + view.size].reshape(view.shape)
            at += view.size
        if not isinstance(rows, slice):
            records[rows] = held
        if spans is FRAME_SPANS:
            tracked = records[:, TRACKED:TRACKED + len(SIDES)] != 0
            parts = _parts(_kept(tracked) if left_out else [slice(None)] * len(SIDES), count)[1:]
    if at != len(words):
        raise ValueError(f"blosc: {len(words)} words, not the {at} of {count} frames")
    return np.ndarray(count, FRAME, records)


def frames_of(moments: Moments) -> np.ndarray:
    """The ``FRAME`` records of a task's frames (``microg.task.Moments``): each frame as the physics
    received it, the world after it (object 0 and the rendered hands), the task's state, and what
    the task judged (object 0's contacts, the grasp); the stage as its code here (``stage_names``)."""
    records = moments.records
    frames = np.zeros(len(records), dtype=FRAME)
    if not len(records):
        return frames
    hands, after = records["hands"], records["after"]
    frames["t"] = hands["t"]
    frames["stage"] = stage_codes(moments.kind)[records["stage"]]
    frames["place"], frames["place_lit"], frames["place_timer"] = records["place"], records["lit"], records["timer"]
    frames["grasped"], frames["held"] = after["grasped_by"].any(axis=1), records["held"]
    bits = np.packbits(after["touching"].astype(bool), axis=1, bitorder="little")
    frames["touching"] = np.pad(bits, ((0, 0), (0, 8 - bits.shape[1]))).view("<u8")[:, 0]
    for field in ("position", "orientation", "velocity", "angular_velocity"):
        frames[field] = after[field]
    tracked = hands["present"].astype(bool)
    frames["tracked"], frames["track_id"] = tracked, np.where(tracked, hands["track_id"], 0)
    frames["palm_position"], frames["joints"] = hands["points"][:, :, 0], hands["points"][:, :, 1:].reshape(
        len(records), 2, N_DIGITS, N_BONES + 1, 3)
    frames["widths"], frames["palm_orientation"] = hands["widths"], hands["orientation"]
    frames["rendered"] = after["rendered"].reshape(len(records), 2, N_DIGITS * N_BONES, 3)
    for field in HAND_FIELDS:
        frames[field][~tracked] = np.nan
    return frames


def stage_codes(kind: Kind) -> np.ndarray:
    """A kind's stages' codes in the frame log (``stage_names``), by their index in the kind."""
    names = stage_names()
    return np.array([names.index(name) for name in kind.stage_names], dtype=np.uint8)


# ---------------------------------------------------------------- the store's side

TABLE = "frames"
"""``frames(run_id, first, count, t_first, t_last, checksum, data)``: one row per committed batch."""
HEADER = struct.Struct("<qqqdd")
"""What the checksum covers besides the blob: run_id, first, count, t_first, t_last."""


class DamagedFramesError(ValueError):
    """A frame batch does not match its checksum: it was damaged or changed after it was written."""


def checksum(run_id: int, *, first: int, count: int, t_first: float, t_last: float, blob: bytes) -> bytes:
    """SHA-256 of a batch's row: where it lies in its run, its times and its blob (about 0.7 us per
    frame here, ``microg bench store``)."""
    digest = hashlib.sha256(HEADER.pack(run_id, first, count, t_first, t_last))
    digest.update(blob)
    return digest.digest()


def insert(db: sqlite3.Connection, run_id: int, first: int, frames: np.ndarray) -> bool:
    """Add a batch of ``FRAME`` records (frames ``first`` .. ``first + len(frames) - 1`` of the run)
    with its checksum; False when there was nothing to add."""
    if not len(frames):
        return False
    n, t_first, t_last, blob = len(frames), float(frames["t"][0]), float(frames["t"][-1]), encode(frames)
    digest = checksum(run_id, first=first, count=n, t_first=t_first, t_last=t_last, blob=blob)
    db.execute(f"INSERT INTO {TABLE} ({ROW}) VALUES (?, ?, ?, ?, ?, ?, ?)", (run_id, first, n, t_first, t_last, digest, blob))
    return True


ROW = "run_id, first, count, t_first, t_last, checksum, data"
"""A batch's columns in the order ``sound`` and ``copy`` take them."""


def copy(db: sqlite3.Connection, row: Sequence, run_id: int, source: sqlite3.Connection) -> None:
    """Add a batch read from another study's database ``source`` (its columns ``ROW``) as a batch of
    the run ``run_id`` here: its blob as it is, its checksum computed again for its new place (a
    station's run merged, ``microg.study.stations``). A batch that does not match its own checksum
    there raises ``DamagedFramesError`` naming it."""
    if not sound(row):
        raise DamagedFramesError(damage(source, row))
    _, first, n, t_first, t_last, _, blob = row
    db.execute(f"INSERT INTO {TABLE} ({ROW}) VALUES (?, ?, ?, ?, ?, ?, ?)",
               (run_id, first, n, t_first, t_last,
                checksum(run_id, first=first, count=n, t_first=t_first, t_last=t_last, blob=blob), blob))


def count(db: sqlite3.Connection, run_id: int) -> int:
    """Frames logged for the run."""
    return db.execute(f"SELECT COALESCE(SUM(count), 0) FROM {TABLE} WHERE run_id = ?", (run_id,)).fetchone()[0]


def read(db: sqlite3.Connection, run_id: int, start: int = 0) -> np.ndarray:
    """The run's logged frames from frame ``start`` on (``FRAME`` records, in order), each batch
    verified against its checksum first (``DamagedFramesError`` naming the run and the batch)."""
    rows = db.execute(f"SELECT run_id, first, count, t_first, t_last, checksum, data FROM {TABLE} "
                      "WHERE run_id = ? AND first + count > ? ORDER BY first", (run_id, start)).fetchall()
    if not rows:
        return np.empty(0, dtype=FRAME)
    for row in rows:
        if not sound(row):
            raise DamagedFramesError(damage(db, row))
    frames = np.concatenate([decode(row[6], row[2]) for row in rows])
    return frames[start - rows[0][1]:]


def sound(row: Sequence) -> bool:
    """Whether a frames row (all its columns, in order) matches its checksum."""
    run_id, first, n, t_first, t_last, stored, blob = row
    try:
        return checksum(run_id, first=first, count=n, t_first=t_first, t_last=t_last, blob=blob) == stored
    except (TypeError, struct.error):  # a column of the wrong type is damage too
        return False


def damaged(db: sqlite3.Connection) -> Iterator[tuple[int, str]]:
    """(run id, what is wrong) for every batch of the study that does not match its checksum or
    does not decode: the whole log read once (``microg study check``, an export that accepts damage)."""
    for row in db.execute(f"SELECT run_id, first, count, t_first, t_last, checksum, data FROM {TABLE} "
                          "ORDER BY run_id, first"):
        if not sound(row):
            yield row[0], damage(db, row)
            continue
        try:
            decode(row[6], row[2])
        except (ValueError, OSError) as error:
            yield row[0], (f"frames of {run_name(db, row[0])}, the batch from frame {row[1]} ({row[2]} frames): "
                           f"matches its checksum but does not decode ({error})")


def damage(db: sqlite3.Connection, row: Sequence) -> str:
    """What a batch that fails its checksum is: the participant, session, task and run, the batch."""
    return (f"frames of {run_name(db, row[0])}, the batch from frame {row[1]} ({row[2]} frames): does not match "
            "its checksum: damaged or changed after it was written")


def hand_frames(frames: np.ndarray) -> list[HandFrame]:
    """The hand frames exactly as the physics received them: feed them through the window filter
    (``microg.hands.filter.HandFilter``) into ``microg.sim.step`` on the task's world to simulate
    the run again."""
    out = []
    for f in frames:
        hands = tuple(Hand(name, f["joints"][s].astype(np.float64), f["widths"][s].astype(np.float64),
                           f["palm_position"][s].astype(np.float64), f["palm_orientation"][s].astype(np.float64),
                           int(f["track_id"][s]))
                      for s, name in enumerate(SIDES) if f["tracked"][s])
        out.append(HandFrame(float(f["t"]), hands))
    return out


JOINT_NAMES = ("metacarpal_base", "proximal_base", "intermediate_base", "distal_base", "tip")
"""Joint j of a digit is where bone j begins (j < 4) or the digit's tip."""
TRACKER = "the tracker's frame"
TRACKER_FRAME = f"{TRACKER} (x right, y up, z toward the participant; right-handed)"
PHYSICS = "the physics (the object after the frame's step)"
RULES = "the task kind's rules (the task's state after the frame)"
HANDS = ("the hand tracker, through the tracking guard and the window filter: the hand exactly as the physics "
         "received it")
STATE = (
    Column("frame", "int64", "index of the frame within its task run, from 0", minimum=0, source=FRAME_LOG),
    Column("t", "float64", "the frame's timestamp: the hand source's time (a live tracker's clock, re-anchored by the "
           "tracking guard after a jump; a recording's or a simulated participant's time), from which task times "
           "are measured", unit="s", source=HANDS),
    Column("stage", "string", "the task's stage (its kind's: what the participant's page says at it)", levels="stages",
           source=RULES),
    Column("place", "int64", "index of the current place, from 0 (the number of places once all are done; 0 for "
           "kinds without places)", minimum=0, source=RULES),
    Column("place_lit", "bool", "whether the current place is lit (the held object's centre within its radius)",
           source=RULES),
    Column("place_timer", "float64", "time the current place has been lit (0 when dark)", unit="s", minimum=0,
           source=RULES),
    Column("grasped", "bool", "whether a hand grasps the object (the physics' grasp rule, this frame)",
           source=PHYSICS),
    Column("held", "bool", "whether the task counts the object as held (grasped for grasp_settle_s, not yet let go "
           "for drop_grace_s)", source=RULES),
    Column("touching", "int64", "the phalanx slots touching the object, as a bit mask: bit k is set when slot k "
           f"(microg.skeleton.slot_name(k): the left hand's thumb metacarpal first, {N_BONES} bones a digit, "
           f"{BONES_PER_HAND} slots a hand) touches it", minimum=0, maximum=2 ** SLOTS - 1, source=PHYSICS),
    *(Column(f"p{axis}", "float64", f"the object's position, {axis} in {TRACKER_FRAME}", unit="m", source=PHYSICS)
      for axis in "xyz"),
    *(Column(f"q{c}", "float64", f"the object's orientation, quaternion component {c} (unit quaternion w, x, y, z "
             f"from the object's frame to {TRACKER})", minimum=-1, maximum=1, source=PHYSICS) for c in "wxyz"),
    *(Column(f"v{axis}", "float64", f"the object's velocity, {axis} in {TRACKER_FRAME}", unit="m/s", source=PHYSICS)
      for axis in "xyz"),
    *(Column(f"w{axis}", "float64", f"the object's angular velocity, {axis} in {TRACKER_FRAME}", unit="rad/s",
             source=PHYSICS) for axis in "xyz"),
)
"""The frames table's columns of the task's and the object's state, in order."""
STATE_COLUMNS = tuple(column.name for column in STATE)


def hand_declarations(side: str) -> tuple[Column, ...]:
    """The frames table's columns for one side's hand: joints, bone widths, palm pose (as the physics
    received them) and the rendered (god-object) phalanges; empty where the hand was not tracked."""
    untracked = "; empty where the hand was not tracked"
    joints = tuple(Column(f"{side}_{d}_{j}_{axis}", "float64", f"the {side} hand's {d} {j.replace('_', ' ')} joint, "
                          f"{axis} in {TRACKER_FRAME}{untracked}", unit="m", source=HANDS)
                   for d in DIGITS for j in JOINT_NAMES for axis in "xyz")
    widths = tuple(Column(f"{side}_{d}_{b}_width", "float64", f"width of the {side} hand's {d} {b} bone, as the "
                          f"tracker reports it{untracked}", unit="m", minimum=0, source=HANDS)
                   for d in DIGITS for b in BONES)
    palm = tuple(Column(f"{side}_palm_{axis}", "float64", f"the {side} palm's centre, {axis} in {TRACKER_FRAME}"
                        f"{untracked}", unit="m", source=HANDS) for axis in "xyz")
    palm += tuple(Column(f"{side}_palm_q{c}", "float64", f"the {side} palm's orientation, quaternion component {c} "
                         f"(unit quaternion w, x, y, z from the hand's frame to {TRACKER}){untracked}",
                         minimum=-1, maximum=1, source=HANDS) for c in "wxyz")
    rendered = tuple(Column(f"rendered_{side}_{d}_{b}_{axis}", "float64", f"centre of the {side} hand's {d} {b} "
                            "phalanx as the participant saw it (the god-object hand, kept at the object's surface "
                            "instead of inside it), "
                            f"{axis} in {TRACKER_FRAME}{untracked}", unit="m",
                            source="the physics (the rendered hand after the frame's step)")
                     for d in DIGITS for b in BONES for axis in "xyz")
    return joints + widths + palm + rendered


def hand_columns(side: str) -> list[str]:
    """The flat table's columns for one side's hand (``hand_declarations``' names)."""
    return [column.name for column in hand_declarations(side)]


FRAME_COLUMNS = STATE + tuple(column for side in SIDES for column in hand_declarations(side))
"""The columns ``frame_columns`` makes, in order."""


def frame_columns(frames: np.ndarray) -> dict[str, np.ndarray]:
    """The logged frames as the flat table's columns (``STATE_COLUMNS``, then ``hand_columns`` of
    each side), each a contiguous array: what exports write. NaN where a hand was not tracked."""
    n = len(frames)
    columns: dict[str, np.ndarray] = {
        "frame": np.arange(n), "t": frames["t"], "stage": np.array(stage_names(), dtype=object)[frames["stage"]],
        "place": frames["place"].astype(np.int64), "place_lit": frames["place_lit"],
        "place_timer": frames["place_timer"].astype(np.float64), "grasped": frames["grasped"],
        "held": frames["held"], "touching": frames["touching"].astype(np.int64)}
    for prefix, field in (("p", "position"), ("q", "orientation"), ("v", "velocity"), ("w", "angular_velocity")):
        axes = "wxyz" if prefix == "q" else "xyz"
        for i, axis in enumerate(axes):
            columns[f"{prefix}{axis}"] = frames[field][:, i].astype(np.float64)
    for s, side in enumerate(SIDES):
        values = np.hstack([frames[field][:, s].reshape(n, -1) for field in HAND_FIELDS]).astype(np.float64)
        columns.update(zip(hand_columns(side), np.ascontiguousarray(values.T)))
    return columns


def frame_table(frames: np.ndarray) -> pd.DataFrame:
    """``frame_columns`` as a DataFrame."""
    return pd.DataFrame(frame_columns(frames))


def touching_slots(mask) -> np.ndarray:
    """(..., 40) the phalanx slots set in ``touching`` masks (one frame's, or a column of them)."""
    bits = np.arange(2 * N_DIGITS * N_BONES, dtype=np.uint64)
    return ((np.asarray(mask, dtype=np.uint64)[..., None] >> bits) & np.uint64(1)).astype(bool)
