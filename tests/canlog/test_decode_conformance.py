"""evtribo's decoder against cantools on cantools' own test DBCs (tests/data/cantools: all 83
files: multiplexing, IEEE floats, CAN FD, J1939, odd positions, value tables, files cantools
refuses).

For every message of every file, frames are made (encoded by cantools for each of its
multiplexer values, and random bytes), written as a candump log, and decoded by evtribo and
by cantools: every value must be the same, every value-table name too (``decode --choices``),
and every frame cantools refuses (an unknown multiplexer value, a signal beyond the message's
length) must be refused by evtribo too. The one deliberate difference: a message whose
signals overlap, which cantools refuses whole, is decoded signal by signal (with a warning
when the DBC is loaded), each signal as cantools decodes it alone.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import cantools
import numpy as np
import pandas as pd
import pytest
from cantools.database.can import Message

from evtribo.canlog.decode import beyond_length, decode_messages
from evtribo.canlog.frame_match import is_fd_message
from evtribo.canlog.io import read_frames, write_candump
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import load_dbc
from evtribo.cli import main
from evtribo.errors import RigConfigError

DATA = Path(__file__).parents[1] / "data" / "cantools"
DBCS = sorted(p for p in DATA.iterdir() if p.suffix.lower() == ".dbc")
#: Frames of random bytes per message, and encoded ones per multiplexer value.
RANDOM, PER_MUX = 100, 24


def _cantools(path: Path) -> cantools.database.can.Database | None:
    """The file as cantools loads it (strictly, else leniently), None if it refuses it."""
    for strict in (True, False):
        try:
            return cantools.database.load_file(path, database_format="dbc", strict=strict)
        except Exception:  # cantools refuses it either way
            continue
    return None


def _raw(rng: np.random.Generator, sig) -> int | float:
    if sig.is_float:
        return float(rng.normal(0, 1e3))
    top = 1 << sig.length
    code = int(rng.integers(0, top, dtype=np.uint64)) if sig.length < 64 else \
        int(rng.integers(0, 1 << 63)) * 2 + int(rng.integers(0, 2))
    return code - top if sig.is_signed and code >= top >> 1 else code


def _payloads(message: Message, rng: np.random.Generator) -> list[bytes]:
    """Random payloads of the message's length, and encoded ones for each multiplexer value
    (random raw codes in every signal)."""
    out = [rng.integers(0, 256, message.length, dtype=np.uint8).tobytes()
           for _ in range(RANDOM)]
    muxes = [s for s in message.signals if s.is_multiplexer]
    values = sorted({i for s in message.signals for i in (s.multiplexer_ids or [])})
    for value in values or [None]:
        for _ in range(PER_MUX if muxes else 0):
            data = {s.name: _raw(rng, s) for s in message.signals}
            for mux in muxes:
                data[mux.name] = value
            try:
                out.append(message.encode(data, scaling=False, strict=False))
            except Exception:  # a value the nested multiplexers refuse
                continue
    return [p[:message.length].ljust(message.length, b"\0") for p in out]


def _frames(db, rng: np.random.Generator) -> tuple[FrameTable, list[tuple[Message, bytes]]]:
    rows = [(m, p) for m in db.messages if m.length for p in _payloads(m, rng)]
    n = len(rows)
    width = 64 if any(len(p) > 8 for _, p in rows) else 8
    data = np.zeros((n, width), np.uint8)
    for i, (_, p) in enumerate(rows):
        data[i, :len(p)] = np.frombuffer(p, np.uint8)
    return FrameTable(
        timestamp=1763700000.0 + np.arange(n) * 1e-3,
        arbitration_id=np.array([m.frame_id for m, _ in rows], np.uint32),
        is_extended=np.array([bool(m.is_extended_frame) for m, _ in rows]),
        is_remote=np.zeros(n, bool), is_error=np.zeros(n, bool),
        is_fd=np.array([is_fd_message(m) for m, _ in rows]),
        dlc=np.array([len(p) for _, p in rows], np.uint8), data=data, channel="vcan0"), rows


def _overlapping(message: Message) -> bool:
    bits = [set(range(s.start, s.start + s.length)) if s.byte_order == "little_endian"
            else None for s in message.signals]
    return any(a is None or b is None or a & b
               for i, a in enumerate(bits) for b in bits[i + 1:]) and not \
        message.is_multiplexed()


def _reference(message: Message, payload: bytes, choices: bool) -> dict | None:
    """cantools' decoding of one frame (None: refused); an overlapping message's signals
    each decoded alone."""
    try:
        return dict(message.decode(payload, decode_choices=choices))
    except Exception:  # cantools refuses the frame
        if not _overlapping(message):
            return None
    out = {}
    for sig in message.signals:
        alone = Message(frame_id=message.frame_id, name=message.name, length=message.length,
                        signals=[sig], strict=False, is_extended_frame=message.is_extended_frame)
        out.update(alone.decode(payload, decode_choices=choices))
    return out


def _same(ours: float, theirs: object) -> bool:
    value = float(theirs)  # type: ignore[arg-type]
    return (ours == value or (math.isnan(ours) and math.isnan(value))
            or math.isclose(ours, value, rel_tol=1e-12, abs_tol=0.0))


def _compare(path: Path, caplog) -> int:
    """Decode a file's frames both ways; return the number of values compared."""
    theirs = _cantools(path)
    if theirs is None:  # cantools refuses the file: so does evtribo, naming it
        with pytest.raises(RigConfigError) as err:
            load_dbc(path)
        assert str(path) in str(err.value)
        return 0
    with caplog.at_level(logging.WARNING):
        db = load_dbc(path)
    frames, rows = _frames(db, np.random.default_rng(len(path.name)))
    decoded = decode_messages(frames, db)
    compared = 0
    for i, (message, payload) in enumerate(rows):
        ref = _reference(message, payload, choices=False)
        names = _reference(message, payload, choices=True)
        got = decoded[message.name]
        k = int(np.searchsorted(got.index, i))
        assert got.index[k] == i
        refused = i in set(got.undecoded.tolist())
        assert refused == (ref is None), (path.name, message.name, got.undecoded_reason)
        for signal in got.raw:
            value = float(got.scaled(signal)[k])
            if ref is None or signal not in ref:  # refused, or absent from this frame
                assert math.isnan(value), (path.name, message.name, signal)
                assert got.choice_names(signal)[k] is None
                continue
            assert _same(value, ref[signal]), (path.name, message.name, signal, value, ref)
            if got.codecs[signal].choices:
                assert got.choice_names(signal)[k] == str(names[signal]), (path.name, signal)
            compared += 1
    if any(_overlapping(m) for m in db.messages):
        assert "decoding it anyway" in caplog.text
    return compared


def test_the_folder_holds_cantools_dbcs_and_its_licence():
    assert len(DBCS) == 83
    assert "MIT License" in (DATA / "LICENSE").read_text()


def test_every_value_of_every_dbc_is_decoded_as_cantools_decodes_it(caplog):
    compared = {path: _compare(path, caplog) for path in DBCS}
    for path in (p for p, n in compared.items() if n == 0):
        # cantools refuses the file (an ID beyond 11 or 29 bits), or it has no signal that
        # a frame can carry (none at all, or one beyond its message: refused by both)
        db = _cantools(path)
        assert db is None or all(not m.signals or not m.length or beyond_length(m)
                                 for m in db.messages), path.name
    assert sum(n > 0 for n in compared.values()) == 69
    assert sum(compared.values()) > 80_000


def test_decode_choices_on_multiplexed_signals_with_value_tables(tmp_path):
    """``evtribo decode --choices`` crashed ("cannot convert float NaN to integer") on a
    multiplexed signal with a value table, absent from a frame."""
    dbc = DATA / "multiplex_choices.dbc"
    db = load_dbc(dbc)
    frames, rows = _frames(db, np.random.default_rng(1))
    log = tmp_path / "mux.log"
    write_candump(log, frames)
    out = tmp_path / "mux.csv"
    assert main(["decode", str(log), "--dbc", str(dbc), "-o", str(out), "--choices"]) == 0
    table = pd.read_csv(out, dtype=str, keep_default_na=False)
    assert len(table) == len(read_frames(log)[0]) == len(rows)
    seen = 0
    for (message, payload), (_, row) in zip(rows, table.iterrows(), strict=True):
        assert row["message"] == message.name
        ref = _reference(message, payload, choices=True) or {}
        for sig in message.signals:
            column = sig.name if sig.name in table.columns else f"{message.name}.{sig.name}"
            want = ref.get(sig.name)
            if want is None:  # absent from this frame (or the frame refused)
                assert row[column] == "", (column, row[column])
            elif sig.choices:  # the value table's name, or the physical value as text
                assert row[column] == str(want), (column, want)
                seen += 1
            else:
                assert _same(float(row[column]), want), (column, want)
    assert seen > 50


def test_a_signal_beyond_its_message_is_not_decoded_from_padding(tmp_path, caplog):
    """bad_message_length.dbc: Signal1 lies in byte 2 of a 1-byte message. cantools refuses
    every frame; evtribo decoded 0.0 from the padding of each, with only a load-time
    warning. Now its frames are refused, and said so."""
    dbc = DATA / "bad_message_length.dbc"
    db = load_dbc(dbc)
    frames, rows = _frames(db, np.random.default_rng(2))
    with caplog.at_level(logging.WARNING, logger="evtribo.canlog.decode"):
        got = decode_messages(frames, db)["Message1"]
    assert len(got.undecoded) == len(rows) and np.isnan(got.scaled("Signal1")).all()
    assert "its signal Signal1 ends in byte 2, beyond the message's 1 bytes" in caplog.text
    log, out = tmp_path / "bad.log", tmp_path / "bad.csv"
    write_candump(log, frames)
    assert main(["decode", str(log), "--dbc", str(dbc), "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert table["Signal1"].isna().all()
