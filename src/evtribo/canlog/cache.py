"""Decoded trials cached as Arrow IPC files, so a second analysis does not decode again.

>>> trial = load_trial("P01/run-01.log", rig, cache_dir="~/.cache/evtribo")  # doctest: +SKIP

The key is the SHA-256 of the log's bytes, the rig's fingerprint (DBC bytes and role
mapping, :meth:`~evtribo.canlog.rig.Rig.fingerprint`) and :data:`CACHE_VERSION`; a changed log, DBC
or mapping misses the cache. One file per trial, ``<key>.<checksum>.arrow`` (the Arrow IPC
file format, uncompressed), holding the three streams one after the other (column
``stream``: 0 normal, 1 tangential, 2 excitation; the excitation's own columns run-end
encoded, nulls over the cells' rows) and the counts in the schema metadata. Where it gives
every value back bit for bit, a time is kept as the step from the stream's previous one in
whole ticks of the log's clock (microseconds for candump), and a force as the code it was
decoded from (its signal's scale and offset in the metadata): a trial of 670 k frames
takes 7.4 MB instead of 12.7, and every megabyte written costs a cold analysis (2.4 ms of
the kernel's time on the machine evtribo is developed on, 0.6 ms of checksum).
``<checksum>`` is the start of the SHA-256 of the file's own bytes, verified on every read:
an entry whose bytes changed on disk (a flipped bit) is dropped and the trial decoded again,
with a warning. Written to a temporary name and renamed, so a crash never leaves a
half-written entry.

Where: ``cache_dir`` if given, else ``$EVTRIBO_CACHE_DIR``, else ``$XDG_CACHE_HOME/evtribo``
or ``~/.cache/evtribo``; never beside the raw logs unless that is the directory asked for.
``cache=False`` reads and decodes without touching any cache.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
from pyarrow import feather

from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io import FrameStream, FrameTable, sha256_log
from evtribo.canlog.io.registry import MAX_WARNINGS
from evtribo.canlog.rig import Rig
from evtribo.canlog.signal_codec import SignalCodec, scaled
from evtribo.canlog.signals import CellSignals, ExcitationSignals, TrialProvenance, TrialSignals
from evtribo.errors import AnalysisError
from evtribo.store.files import read_entry, write_checksummed
from evtribo.store.memo import default_cache_dir, plugin_distributions
from evtribo.util.docstrings import fill_doc
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

#: Bumped whenever what is stored, or how it is decoded, changes.
CACHE_VERSION = 15  # 2: dropped frames counted by evtribo.canlog.dropped; 3: Rig.counter guess,
#                     frames with an unknown multiplexer value ignored; 5: checksummed entries; 6:
#                     channel, logger's DROPCOUNT and decoder warnings kept; 7: waveform codes
#                     named without a value table (evtribo.canlog.signals.FALLBACK_WAVEFORMS); 8:
#                     the reader's damaged lines kept, warned of again from the cache; 9: Arrow IPC
#                     files (were Parquet); 10: the excitation's columns run-end encoded, counters
#                     in the narrowest ints, times as clock ticks' steps and forces as their codes
#                     where exact; 11: frames lost by the counter alone where it steps by one,
#                     outages only on bursty timestamps (evtribo.canlog.outages); CAN FD frames
#                     only as FD messages; 12: the cells' frames in the order sent, duplicates
#                     counted, counter jumps and the log's clock steps taken out
#                     (evtribo.canlog.sequence); 13: a force's samples outside its DBC range left
#                     out (bad samples); 14: lines stamped 2**63 s or more skipped, lines stamped
#                     far ahead a stretch of their own, the counters' law
#                     (evtribo.canlog.counters); 15: the decoder's warnings as records
#                     (evtribo.warning), every one of them kept, the frames lost's notes among them
_META = b"evtribo.trial"
SUFFIX = ".arrow"  #: An entry's file name ends so.


@fill_doc
def cache_key(log_path: str | os.PathLike[str], rig: Rig, *,
              log_sha256: str | None = None, channel: str | None = None) -> str:
    """Key of a trial: log content, rig content, the channel asked for, cache format version.

    Parameters
    ----------
    log_path : path-like
        The raw log (hashed unless *log_sha256* is given).
    %(rig)s
    log_sha256 : str, optional
        The log's SHA-256, when it is known.
    channel : str, optional
        The channel asked for.

    Returns
    -------
    str
        40 hex digits.
    """
    return _key(log_sha256 or sha256_log(log_path), rig.fingerprint(), channel)


def _key(log_sha256: str, rig_fingerprint: str, channel: str | None) -> str:
    """:func:`cache_key` from the log's and the rig's hashes."""
    h = hashlib.sha256(f"v{CACHE_VERSION}".encode())
    h.update(log_sha256.encode())
    h.update(rig_fingerprint.encode())
    if channel is not None:
        h.update(b"\0channel\0" + channel.encode("utf-8", "surrogateescape"))
    if plugin_distributions():  # a lab's log reader decodes as evtribo's own (none: as ever)
        h.update(json.dumps(plugin_distributions()).encode())
    return h.hexdigest()[:40]


#: Excitation signals and their Arrow types (a trial without one stores nulls).
_EXCITATION_TYPES = {"enabled": pa.bool_(), "amplitude": pa.float64(),
                     "frequency": pa.float64(), "waveform": pa.string()}


def _narrowest(values: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    """Integer *values* in the narrowest signed integers that hold them (read back into
    int64 exactly)."""
    if values.size:
        lo, hi = int(values.min()), int(values.max())
        for dtype in (np.int8, np.int16, np.int32):
            info = np.iinfo(dtype)
            if info.min <= lo and hi <= info.max:
                return values.astype(dtype)
    return values


def _same_bits(a: np.ndarray[Any, Any], b: np.ndarray[Any, Any]) -> bool:
    """Whether two float64 arrays hold the same bits (-0.0 is not 0.0)."""
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _after_nulls(values: np.ndarray[Any, Any] | None, rows: int, name: str) -> pa.Array:
    """A column of *rows* rows ending with *values* (all nulls without them), nulls before,
    run-end encoded: the excitation's rows come last, and its signals hold their value for
    many frames."""
    typ = _EXCITATION_TYPES[name]
    nulls = rows - (0 if values is None else len(values))
    ends: np.ndarray[Any, Any]
    if values is None or not len(values):
        ends = np.array([nulls] if nulls else [], dtype=np.int64)
        vals = pa.nulls(1 if nulls else 0, typ)
    else:
        arr = pa.array(values.tolist() if name == "waveform" else values, type=typ)
        runs = pc.run_end_encode(arr, run_end_type=pa.int64())
        ends = np.asarray(runs.run_ends) + nulls
        if nulls:
            ends = np.concatenate([[nulls], ends])
            vals = pa.concat_arrays([pa.nulls(1, typ), runs.values])
        else:
            vals = runs.values
    return pa.RunEndEncodedArray.from_arrays(pa.array(ends, type=pa.int64()), vals)


#: Clock units a log's timestamps may be whole numbers of (candump and ASC logs: us).
_CLOCK_UNITS = (1e6, 1e9, 1e3)
#: Largest whole number of ticks or codes kept as such (exact in float64).
_EXACT = float(2 ** 53)


def _ticks(t: np.ndarray[Any, Any], per_s: float) -> np.ndarray[Any, Any] | None:
    """*t* (s) as whole ticks of ``1 / per_s`` s, if ``ticks / per_s`` gives every value
    back bit for bit; else None."""
    with np.errstate(all="ignore"):
        scaled = t * per_s
        if not np.all(np.abs(scaled) < _EXACT):  # NaN and infinities too
            return None
    ticks = np.rint(scaled).astype(np.int64)
    return ticks if _same_bits(ticks / per_s, t) else None


def _codes(value: np.ndarray[Any, Any], scale: float, offset: float
           ) -> np.ndarray[Any, Any] | None:
    """The whole codes *value* was decoded from with *scale* and *offset*, if decoding them
    again (:func:`~evtribo.canlog.signal_codec.scaled`) gives every value back bit for bit; else
    None."""
    if not (np.isfinite(scale) and np.isfinite(offset) and scale != 0):
        return None
    with np.errstate(all="ignore"):
        k = np.rint((value - offset) / scale)
        if not np.all(np.abs(k) < _EXACT):  # NaN and infinities too
            return None
    codes = k.astype(np.int64)
    return codes if _same_bits(scaled(codes, scale, offset), value) else None


def _encoded_times(parts: list[np.ndarray[Any, Any]]) -> tuple[np.ndarray[Any, Any],
                                                               dict[str, Any] | None]:
    """The streams' times, one after the other: as the steps between whole clock ticks
    (each stream's first tick in the metadata) when every time is a whole number of ticks
    (a log's clock counts microseconds: 8 bytes a time become 2 or 4), else as they are."""
    for per_s in _CLOCK_UNITS:
        ticks = [_ticks(p, per_s) for p in parts]
        if all(k is not None for k in ticks):
            steps = np.concatenate([np.diff(k, prepend=k[:1]) for k in ticks if k is not None])
            return _narrowest(steps), {"per_s": per_s,
                                       "first": [int(k[0]) if k is not None and k.size else 0
                                                 for k in ticks]}
    return np.concatenate(parts), None


def _decoded_times(col: np.ndarray[Any, Any], stream: np.ndarray[Any, Any],
                   encoding: dict[str, Any] | None) -> np.ndarray[Any, Any]:
    """:func:`_encoded_times` undone."""
    if encoding is None:
        return col
    ticks = np.empty(col.size, dtype=np.int64)
    for k, first in enumerate(encoding["first"]):
        sel = np.flatnonzero(stream == k)
        if sel.size:
            ticks[sel] = int(first) + np.cumsum(col[sel], dtype=np.int64)
    return ticks / float(encoding["per_s"])


def _encoded_values(cells: tuple[CellSignals, CellSignals], n_ex: int,
                    scaling: Sequence[tuple[float, float] | None]
                    ) -> tuple[np.ndarray[Any, Any], list[list[float]] | None]:
    """The cells' forces, then NaN for the excitation's rows: as the whole codes they were
    decoded from (each cell's scale and offset in the metadata) when *scaling* gives every
    value back bit for bit, else as they are."""
    codes = [None if sc is None else _codes(np.asarray(c.value, dtype=np.float64), *sc)
             for c, sc in zip(cells, scaling, strict=True)]
    if all(k is not None for k in codes):
        return (_narrowest(np.concatenate([*(k for k in codes if k is not None),
                                           np.zeros(n_ex, dtype=np.int64)])),
                [[float(sc[0]), float(sc[1])] for sc in scaling if sc is not None])
    return np.concatenate([np.asarray(c.value, dtype=np.float64) for c in cells]
                          + [np.full(n_ex, np.nan)]), None


def _decoded_values(col: np.ndarray[Any, Any], stream: np.ndarray[Any, Any],
                    encoding: list[list[float]] | None) -> np.ndarray[Any, Any]:
    """:func:`_encoded_values` undone (NaN for the excitation's rows)."""
    if encoding is None:
        return col
    value = np.full(col.size, np.nan)
    for k, (scale, offset) in enumerate(encoding):
        sel = stream == k
        value[sel] = scaled(col[sel], scale, offset)
    return value


def _scaling(rig: Rig) -> list[tuple[float, float] | None]:
    """Each load cell's scale and offset, as its force signal is decoded (None: a float
    signal)."""
    out: list[tuple[float, float] | None] = []
    for role in ("normal_force", "tangential_force"):
        ref = rig.roles.get(role)
        codec = None if ref is None else SignalCodec.from_signal(ref.signal)
        out.append(None if codec is None or codec.is_float
                   else (float(codec.scale), float(codec.offset)))
    return out


def _to_table(trial: TrialSignals,
              scaling: Sequence[tuple[float, float] | None] = (None, None)) -> pa.Table:
    """The trial as an entry's table; *scaling*: each cell's force signal's scale and
    offset, if its values may be kept as the codes they were decoded from."""
    cells = (trial.normal, trial.tangential)
    ex = trial.excitation
    n_ex = 0 if ex is None else len(ex.t)
    parts = [len(c.t) for c in cells] + [n_ex]
    stream = np.repeat(np.arange(3, dtype=np.int8), parts)
    t, t_encoding = _encoded_times([np.asarray(c.t, dtype=np.float64) for c in cells]
                                   + [np.asarray(ex.t if ex is not None else [],
                                                 dtype=np.float64)])
    value, value_encoding = _encoded_values(cells, n_ex, scaling)
    counter = np.concatenate([np.full(len(c.t), -1, dtype=np.int64) if c.counter is None
                              else np.asarray(c.counter, dtype=np.int64) for c in cells]
                             + [np.full(n_ex, -1, dtype=np.int64)])
    cols: dict[str, pa.Array] = {
        "stream": pa.array(stream), "t": pa.array(t), "value": pa.array(value),
        "counter": pa.array(_narrowest(counter)),
    }
    for name in _EXCITATION_TYPES:
        cols[name] = _after_nulls(None if ex is None else getattr(ex, name), len(t), name)
    meta = {
        "version": CACHE_VERSION, "frames": trial.frames, "ignored_frames": trial.ignored_frames,
        "skipped_lines": trial.skipped_lines, "channel": trial.channel,
        "skipped_detail": [list(d) for d in trial.skipped_detail],
        "logger_dropped": trial.logger_dropped, "warnings": [w.as_json() for w in trial.warnings],
        "dropped": [trial.normal.dropped, trial.tangential.dropped],
        "dropped_method": [trial.normal.dropped_method, trial.tangential.dropped_method],
        "duplicates": [trial.normal.duplicates, trial.tangential.duplicates],
        "counter": [trial.normal.counter is not None, trial.tangential.counter is not None],
        "counter_period": [trial.normal.counter_period, trial.tangential.counter_period],
        "excitation": None if ex is None else
        [k for k in _EXCITATION_TYPES if getattr(ex, k) is not None],
        "t_encoding": t_encoding, "value_encoding": value_encoding,
    }
    return pa.table(cols).replace_schema_metadata({_META: json.dumps(meta).encode()})


def _from_table(table: pa.Table) -> TrialSignals:
    meta = json.loads(table.schema.metadata[_META])
    if meta.get("version") != CACHE_VERSION:
        raise ValueError("cache format version differs")
    stream = table.column("stream").to_numpy()
    t = _decoded_times(table.column("t").to_numpy(), stream, meta["t_encoding"])
    value = _decoded_values(table.column("value").to_numpy(), stream, meta["value_encoding"])
    counter = table.column("counter").to_numpy()
    cells = []
    for k in (0, 1):
        sel = stream == k
        cnt = counter[sel].astype(np.int64) if meta["counter"][k] else None
        cells.append(CellSignals(t[sel].copy(), value[sel].copy(), cnt, int(meta["dropped"][k]),
                                 meta["dropped_method"][k], int(meta["duplicates"][k]),
                                 meta["counter_period"][k]))
    ex = None
    if meta["excitation"] is not None:
        sel = np.flatnonzero(stream == 2)
        ex = ExcitationSignals(t=t[sel].copy(), **{
            name: _excitation_column(_rows(table.column(name), sel), name)
            for name in meta["excitation"]})
    return TrialSignals(cells[0], cells[1], ex, frames=int(meta["frames"]),
                        ignored_frames=int(meta["ignored_frames"]),
                        skipped_lines=int(meta["skipped_lines"]),
                        skipped_detail=tuple((None if d[0] is None else int(d[0]), str(d[1]))
                                             for d in meta["skipped_detail"]),
                        channel=meta["channel"],
                        logger_dropped=int(meta["logger_dropped"]),
                        warnings=tuple(WarningRecord.from_json(w) for w in meta["warnings"]))


def _rows(col: pa.ChunkedArray, sel: np.ndarray[Any, Any]) -> pa.Array:
    """The rows *sel* of a run-end encoded column, decoded (a slice when they follow one
    another, as written)."""
    arr = col.combine_chunks()
    if sel.size and sel[-1] - sel[0] + 1 == sel.size:
        return pc.run_end_decode(arr.slice(int(sel[0]), int(sel.size)))
    return pc.run_end_decode(arr).take(pa.array(sel))


def _excitation_column(col: pa.Array, name: str) -> np.ndarray[Any, Any]:
    """One excitation signal read back: names (object), bools or floats."""
    if name == "waveform":
        return np.array(col.to_pylist(), dtype=object)
    if name == "enabled":
        return np.asarray(col.to_numpy(zero_copy_only=False), dtype=bool)
    return np.asarray(col.to_numpy(zero_copy_only=False))


def _check_unchanged(log_path: str | os.PathLike[str], expect: tuple[str, int, int],
                     when: str) -> None:
    st = os.stat(log_path)
    if (st.st_size, st.st_mtime_ns) != (expect[1], expect[2]):
        raise AnalysisError(f"changed {when} (it is not the file of sha256 {expect[0][:12]}... "
                            "hashed when the analysis started: a recording in progress, or a "
                            "file replaced?); not analysed, analyse the study again",
                            path=log_path)


@fill_doc
def load_trial(log_path: str | os.PathLike[str], rig: Rig,
               cache_dir: str | os.PathLike[str] | None = None, strict: bool = False, *,
               cache: bool = True,
               expect: tuple[str, int, int] | None = None,
               channel: str | None = None) -> TrialSignals:
    """A trial's decoded signals, from the cache when it holds them.

    Parameters
    ----------
    log_path : path-like
        The raw log (any format :func:`~evtribo.canlog.io.read_frames` reads).
    %(rig)s
    %(cache_dir)s
    strict : bool
        Damaged lines are errors (a cached trial that had skipped lines is read again, so
        that the error is raised).
    cache : bool
        False: read and decode, neither reading nor writing the cache.
    expect : (str, int, int), optional
        The log as it was hashed: ``(sha256, size in bytes, modification time in ns)``. Its
        hash is the cache key (the log is not hashed again), and the log is decoded only if
        its size and time are still those (before and after reading it).
    channel : str, optional
        The channel to decode the rig's frames from when the log holds several (a log of one
        channel is decoded whole, whatever its channel's name). Default: the channel that
        carries most of the rig's frames.

    Returns
    -------
    TrialSignals
        With ``skipped_lines`` from reading the log, and its ``provenance``: the log, its
        SHA-256 (when hashed: with *cache* or *expect*), the rig's fingerprint, and whether
        it came from the cache.

    Raises
    ------
    LogFormatError
        As :func:`~evtribo.canlog.io.read_frames`.
    AnalysisError
        The log is not the one *expect* describes.
    """
    fingerprint = rig.fingerprint()
    log_sha256 = expect[0] if expect else None
    directory = key = None
    if cache:
        directory = Path(cache_dir).expanduser() if cache_dir is not None \
            else default_cache_dir()
        log_sha256 = log_sha256 or sha256_log(log_path)
        key = _key(log_sha256, fingerprint, channel)
    source = TrialProvenance(os.fspath(log_path), log_sha256, fingerprint)
    if directory is not None and key is not None:
        trial = _read_entry(directory, key)
        if trial is not None and not (strict and trial.skipped_lines):
            log.debug("%s: decoded trial from the cache in %s", log_path, directory)
            for line, reason in trial.skipped_detail:  # as the reader warned of them
                where = os.fspath(log_path) if line is None else f"{os.fspath(log_path)}:{line}"
                emit("damaged-line", where=where, reason=reason)
            return dataclasses.replace(
                trial, provenance=dataclasses.replace(source, from_cache=True))
    trial = _decode(log_path, rig, strict, expect, channel)
    trial = dataclasses.replace(trial, provenance=source)
    if directory is not None and key is not None:
        try:
            _write_atomic(directory, key, _to_table(trial, _scaling(rig)))
        except OSError as err:  # read-only, full, or a file in the way: the trial stands
            emit("cache-unwritable", cache=os.fspath(directory), error=str(err))
    return trial


def _decode(log_path: str | os.PathLike[str], rig: Rig, strict: bool,
            expect: tuple[str, int, int] | None, channel: str | None) -> TrialSignals:
    """Read the log (checking it is still the file *expect* describes) and decode it; the
    trial's ``skipped_lines`` are the reader's."""
    if expect is not None:
        _check_unchanged(log_path, expect, "since the analysis started")
    stream = FrameStream(log_path, strict=strict)
    frames, others = rig_frames(stream, rig)
    if expect is not None:
        _check_unchanged(log_path, expect, "while it was read")
    if channel is not None and len(frames.channel_names) <= 1:
        channel = None
    trial = decode_trial(frames, rig, channel=channel)
    report = stream.report
    return dataclasses.replace(trial, skipped_lines=report.skipped_lines,
                               ignored_frames=trial.ignored_frames + others,
                               skipped_detail=tuple(report.skipped[:MAX_WARNINGS]))


@fill_doc
def rig_frames(blocks: Iterable[FrameTable], rig: Rig) -> tuple[FrameTable, int]:
    """The frames the rig's decoding looks at, gathered from a log read block by block.

    Memory follows the rig's frames, not the log: a block's other frames are counted and
    let go. Kept are the frames whose ID number is one of the rig's messages' (of either
    kind: :func:`~evtribo.canlog.decode.decode_trial` names the frames of the wrong kind), with
    the log's channel names and its counts of dropped and CAN XL frames.

    Parameters
    ----------
    blocks : iterable of FrameTable
        The log, block by block (:class:`~evtribo.canlog.io.FrameStream`).
    %(rig)s

    Returns
    -------
    frames : FrameTable
        The kept frames in log order; ``decode_trial`` of it equals ``decode_trial`` of the
        whole log, but for the frames it counts as ignored.
    others : int
        The frames let go (add them to the trial's ``ignored_frames``).
    """
    ids = np.unique(np.array([ref.message.frame_id for ref in rig.measured_roles.values()],
                             dtype=np.uint32))
    kept, others = [], 0
    for block in blocks:
        keep = np.isin(block.arbitration_id, ids)
        if keep.all():
            kept.append(block)
            continue
        others += len(block) - int(np.count_nonzero(keep))
        kept.append(block.take(keep))
    if not kept:
        return FrameTable.empty(), 0
    return (kept[0] if len(kept) == 1 else FrameTable.concat(kept)), others


def _read_entry(directory: Path, key: str) -> TrialSignals | None:
    """The trial cached under *key*, or None; a damaged entry is removed (with a warning)."""
    return read_entry(directory, key, SUFFIX,
                      lambda data: _from_table(feather.read_table(pa.BufferReader(data))),
                      what="cache entry", then="the trial is decoded again")


def _write_atomic(directory: Path, key: str, table: pa.Table) -> Path:
    """Write *table* as the entry of *key*, named after its checksum; returns its path.

    Uncompressed: for a trial of 670 k frames, LZ4 halves the entry (7.4 -> 3.9 MB) for
    as much CPU as the smaller write saves, on threads of its own."""
    sink = pa.BufferOutputStream()
    feather.write_feather(table, sink, compression="uncompressed")
    return write_checksummed(directory, key, memoryview(sink.getvalue()), SUFFIX)


__all__ = ["CACHE_VERSION", "cache_key", "default_cache_dir", "load_trial", "rig_frames"]
