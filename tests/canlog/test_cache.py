"""Trial cache: a second load does not decode again; keys follow log and rig content."""

import dataclasses
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_decode import _second_rig_trial

from evtribo.canlog import cache
from evtribo.canlog.rig import Rig, default_rig
from evtribo.canlog.signal_codec import scaled
from evtribo.errors import LogFormatError
from evtribo.warning.catalogue import kind
from evtribo.warning.record import Scope


@pytest.fixture
def trial_files(tmp_path):
    rig, path, _fn, _ft = _second_rig_trial(tmp_path)
    return rig, path


def test_second_load_comes_from_cache(trial_files, tmp_path, monkeypatch):
    rig, path = trial_files
    cdir = tmp_path / "cache"
    first = cache.load_trial(path, rig, cache_dir=cdir)
    assert len(list(cdir.glob("*.arrow"))) == 1
    assert not list(path.parent.glob("*.arrow"))  # nothing beside the raw log

    def no_read(*_a, **_k):
        raise AssertionError("decoded again")

    monkeypatch.setattr(cache, "FrameStream", no_read)
    second = cache.load_trial(path, rig, cache_dir=cdir)
    for cell in ("normal", "tangential"):
        a, b = getattr(first, cell), getattr(second, cell)
        np.testing.assert_array_equal(a.t, b.t)
        np.testing.assert_array_equal(a.value, b.value)
        np.testing.assert_array_equal(a.counter, b.counter)
        assert a.dropped == b.dropped
        assert a.dropped_method == b.dropped_method
    assert second.excitation.waveform.tolist() == first.excitation.waveform.tolist()
    np.testing.assert_array_equal(second.excitation.enabled, first.excitation.enabled)
    np.testing.assert_array_equal(second.excitation.amplitude, first.excitation.amplitude)
    assert (second.frames, second.ignored_frames) == (first.frames, first.ignored_frames)


def test_changed_log_or_rig_misses_the_cache(trial_files, tmp_path):
    rig, path = trial_files
    cdir = tmp_path / "cache"
    cache.load_trial(path, rig, cache_dir=cdir)
    with path.open("a") as fh:
        fh.write("(200.000000) vcan0 701#00\n")
    cache.load_trial(path, rig, cache_dir=cdir)
    other = Rig.from_mapping({"dbc": str(rig.dbc), "normal_force": "NormalCell.Force_mN",
                              "tangential_force": "TangentialCell.Ft"}, tmp_path)
    trial = cache.load_trial(path, other, cache_dir=cdir)
    assert trial.excitation is None and trial.normal.counter is None
    assert len(list(cdir.glob("*.arrow"))) == 3


def test_strict_rereads_a_trial_with_skipped_lines(tmp_path):
    rig = default_rig()
    log = tmp_path / "t.log"
    log.write_text("(1.000000) vcan0 0C1#0000000000000000\n(1.001000) vcan0 0C1#00ZZ\n")
    cdir = tmp_path / "cache"
    assert cache.load_trial(log, rig, cache_dir=cdir).skipped_lines == 1
    assert cache.load_trial(log, rig, cache_dir=cdir).skipped_lines == 1
    with pytest.raises(LogFormatError):
        cache.load_trial(log, rig, cache_dir=cdir, strict=True)


def test_default_cache_dir_from_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("EVTRIBO_CACHE_DIR", str(tmp_path / "c"))
    assert cache.default_cache_dir() == tmp_path / "c"
    monkeypatch.delenv("EVTRIBO_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert cache.default_cache_dir() == tmp_path / "x" / "evtribo"


def test_corrupt_entry_is_decoded_again(trial_files, tmp_path):
    rig, path = trial_files
    cdir = tmp_path / "cache"
    cache.load_trial(path, rig, cache_dir=cdir)
    entry = next(cdir.glob("*.arrow"))
    entry.write_bytes(b"not an Arrow file")
    trial = cache.load_trial(path, rig, cache_dir=cdir)
    assert trial.frames > 0
    assert entry.read_bytes()[:6] == b"ARROW1"  # the Arrow IPC file format's magic
    shutil.rmtree(cdir)


@pytest.mark.parametrize("how", ["file-in-the-way", "write-fails"])
def test_unwritable_cache_still_returns_the_trial(trial_files, tmp_path, monkeypatch, caplog,
                                                  how):
    rig, path = trial_files
    if how == "file-in-the-way":           # the cache folder's parent is a file
        (tmp_path / "afile").write_text("")
        cdir = tmp_path / "afile" / "cache"
    else:                                  # read-only or full disk, even as root
        cdir = tmp_path / "cache"

        def full_disk(*_a, **_k):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(cache.feather, "write_feather", full_disk)
    trial = cache.load_trial(path, rig, cache_dir=cdir)
    assert trial.frames > 0
    assert trial.frames == cache.load_trial(path, rig, cache=False).frames
    assert "cannot write the cache entry" in caplog.text
    assert not list(tmp_path.rglob("*.tmp"))


def test_a_flipped_bit_in_an_entry_is_caught_and_decoded_again(trial_files, tmp_path, caplog):
    """Every byte of an entry is checked: whatever bit of it flips on disk, the trial comes
    back exactly as decoded from the log, and the damage is said. (Unchecked, most single
    flips of such an entry read back as other numbers, without a word.)"""
    rig, path = trial_files
    cdir = tmp_path / "cache"
    fresh = cache.load_trial(path, rig, cache=False)
    cache.load_trial(path, rig, cache_dir=cdir)
    entry = next(cdir.glob("*.arrow"))
    original = entry.read_bytes()
    rng = np.random.default_rng(0)
    wrong, unsaid = [], []
    for pos in rng.choice(len(original), size=40, replace=False):
        damaged = bytearray(original)
        damaged[pos] ^= 1 << int(rng.integers(0, 8))
        for old in cdir.glob("*.arrow"):
            old.unlink()
        entry.write_bytes(bytes(damaged))
        caplog.clear()
        trial = cache.load_trial(path, rig, cache_dir=cdir)
        same = trial.frames == fresh.frames and all(
            np.array_equal(getattr(trial, c).value, getattr(fresh, c).value)
            and np.array_equal(getattr(trial, c).t, getattr(fresh, c).t)
            for c in ("normal", "tangential"))
        if not same:
            wrong.append(int(pos))
        if "damaged cache entry" not in caplog.text:
            unsaid.append(int(pos))
        assert [p.read_bytes() for p in cdir.glob("*.arrow")] == [original]
    assert wrong == [] and unsaid == []


def test_a_loaded_trial_says_where_it_came_from(trial_files, tmp_path):
    """The decoded trial carries its provenance: the log, its hash (when hashed), the rig's
    fingerprint, and whether it came from the cache; it is frozen."""
    import dataclasses

    from evtribo.store.files import sha256_file

    rig, path = trial_files
    cdir = tmp_path / "cache"
    first = cache.load_trial(path, rig, cache_dir=cdir)
    second = cache.load_trial(path, rig, cache_dir=cdir)
    plain = cache.load_trial(path, rig, cache=False)
    for trial in (first, second, plain):
        assert trial.provenance.log_path == str(path)
        assert trial.provenance.rig_fingerprint == rig.fingerprint()
    assert first.provenance.log_sha256 == second.provenance.log_sha256 == sha256_file(path)
    assert plain.provenance.log_sha256 is None  # not hashed without the cache
    assert (first.provenance.from_cache, second.provenance.from_cache,
            plain.provenance.from_cache) == (False, True, False)
    with pytest.raises(dataclasses.FrozenInstanceError):
        first.frames = 0


def test_a_cached_trial_warns_of_its_damaged_lines_as_the_reader_did(trial_files, tmp_path,
                                                                       caplog):
    # summary.json of a warm analysis must name the damaged lines as a cold one does
    rig, path = trial_files
    with path.open("a") as fh:
        fh.write("(200.000000) vcan0 0C1#ZZ\n(200.1) garbage\n")
    cdir = tmp_path / "cache"

    def damaged(records):
        return [r.getMessage() for r in records if "skipped damaged line" in r.getMessage()]

    with caplog.at_level("WARNING", logger="evtribo"):
        cold = cache.load_trial(path, rig, cache_dir=cdir)
    first = damaged(caplog.records)
    caplog.clear()
    with caplog.at_level("WARNING", logger="evtribo"):
        warm = cache.load_trial(path, rig, cache_dir=cdir)
    assert warm.provenance.from_cache and not cold.provenance.from_cache
    assert len(first) == 2 and damaged(caplog.records) == first
    assert warm.skipped_detail == cold.skipped_detail and len(cold.skipped_detail) == 2


@pytest.mark.parametrize("block_size", [64, 1000, 1 << 22])
def test_a_log_decoded_block_by_block_is_the_whole_log_decoded(tmp_path, block_size):
    """The trial's signals and counts (frames ignored, channel, warnings) are those of
    decode_trial on the whole log, foreign frames, a second bus and damaged lines included;
    only the rig's frames are held."""
    from evtribo.canlog.decode import decode_trial
    from evtribo.canlog.io import FrameStream, FrameTable, read_frames, write_candump

    rig, path = _second_rig_trial(tmp_path)[:2]
    frames, _ = read_frames(path)
    rng = np.random.default_rng(3)
    n = 3 * len(frames)
    foreign = FrameTable(
        timestamp=np.sort(rng.uniform(frames.timestamp[0], frames.timestamp[-1], n)),
        arbitration_id=rng.choice([0x0F0, 0x7E8, 0x1ABCDE01], n).astype(np.uint32),
        is_extended=np.zeros(n, bool), is_remote=np.zeros(n, bool),
        is_error=np.zeros(n, bool), is_fd=np.zeros(n, bool),
        dlc=rng.integers(0, 9, n).astype(np.uint8),
        data=rng.integers(0, 256, (n, 8)).astype(np.uint8), channel="can1")
    foreign.is_extended[:] = foreign.arbitration_id > 0x7FF
    mixed = FrameTable.concat([frames, foreign]).sorted_by_time()
    log = tmp_path / "mixed.log"
    write_candump(log, mixed)
    with open(log, "a") as fh:
        fh.write("(1.5) can1 damaged\n")
    whole, report = read_frames(log)
    expected = decode_trial(whole, rig)
    stream = FrameStream(log, block_size=block_size)
    kept, others = cache.rig_frames(stream, rig)
    assert others >= n and len(kept) + others == len(whole)
    assert stream.report == report and report.skipped_lines == 1
    got = decode_trial(kept, rig)
    assert got.frames == expected.frames
    assert got.ignored_frames + others == expected.ignored_frames
    assert (got.channel, got.warnings) == (expected.channel, expected.warnings)
    got = dataclasses.replace(got, ignored_frames=got.ignored_frames + others)
    a, b = cache._to_table(got), cache._to_table(expected)
    for name in a.column_names:
        np.testing.assert_array_equal(a.column(name).to_numpy(zero_copy_only=False),
                                      b.column(name).to_numpy(zero_copy_only=False), name)
    assert a.schema.metadata == b.schema.metadata
    loaded = cache.load_trial(log, rig, cache=False)
    assert (loaded.frames, loaded.ignored_frames, loaded.skipped_lines) == (
        expected.frames, expected.ignored_frames, 1)


_FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)
_COUNTERS = st.one_of(st.integers(-1, 255), st.integers(-(2 ** 63), 2 ** 63 - 1),
                      st.integers(-40_000, 40_000))


_SCALINGS = st.sampled_from([(1e-05, 0.0), (0.001, 0.0), (1 / 3, -100.5), (2.5e-5, 1e-3),
                             (1.0, 0.0), (-0.01, 7.0)])


@st.composite
def _times(draw, n):
    """Times of a log: whole microseconds (or nanoseconds) since 1970 as a reader gives
    them, or any floats."""
    kind = draw(st.sampled_from(["us", "ns", "any"]))
    if kind == "any":
        return np.sort(np.array(draw(st.lists(st.floats(-1e9, 1e9), min_size=n, max_size=n))))
    per_s = 1e6 if kind == "us" else 1e9
    start = draw(st.integers(0, 2 * 10 ** 15))  # since 1970 in us; ns since a boot
    steps = draw(st.lists(st.integers(0, 10 ** 7), min_size=n, max_size=n))
    return (start + np.cumsum(np.array(steps, dtype=np.int64))) / per_s


@st.composite
def _cells(draw, scaling=None):
    """A cell's samples; with *scaling*, forces decoded from whole codes (one of them,
    maybe, off that grid)."""
    from evtribo.canlog.signals import CellSignals

    n = draw(st.integers(0, 40))
    t = draw(_times(n))
    if scaling is None:
        value = np.array(draw(st.lists(_FLOATS, min_size=n, max_size=n)), dtype=np.float64)
    else:
        codes = np.array(draw(st.lists(st.integers(-(2 ** 31), 2 ** 31), min_size=n,
                                       max_size=n)), dtype=np.int64)
        value = scaled(codes, *scaling)
        if n and draw(st.booleans()):
            value[draw(st.integers(0, n - 1))] = draw(_FLOATS)
    counter = draw(st.one_of(st.none(), st.lists(_COUNTERS, min_size=n, max_size=n)))
    return CellSignals(t, value, None if counter is None else np.array(counter, np.int64),
                       draw(st.integers(0, 10 ** 6)), draw(st.sampled_from(["counter", "gaps"])))


@st.composite
def _excitations(draw):
    from evtribo.canlog.signals import ExcitationSignals

    n = draw(st.integers(0, 30))

    def signal(values):
        return draw(st.one_of(st.none(), st.lists(values, min_size=n, max_size=n)))

    steps = st.sampled_from([0.0, 60.0, 140.0, float("nan")])  # runs, as a drive's status
    enabled, amplitude = signal(st.booleans()), signal(st.one_of(steps, _FLOATS))
    frequency, waveform = signal(steps), signal(st.sampled_from(["sine", "square", None, ""]))
    return ExcitationSignals(
        t=np.array(draw(st.lists(st.floats(-1e9, 1e9), min_size=n, max_size=n))),
        enabled=None if enabled is None else np.array(enabled, dtype=bool),
        amplitude=None if amplitude is None else np.array(amplitude, dtype=np.float64),
        frequency=None if frequency is None else np.array(frequency, dtype=np.float64),
        waveform=None if waveform is None else np.array(waveform, dtype=object))


def _whole_codes(value, scale, offset) -> bool:
    """Whether *value* is ``codes * scale + offset`` for whole codes (exact in float64)."""
    with np.errstate(all="ignore"):
        k = np.rint((value - offset) / scale)
        if not np.all(np.abs(k) < 2.0 ** 53):
            return False
    back = scaled(k.astype(np.int64), scale, offset)
    return np.array_equal(back.view(np.int64), value.view(np.int64))


@st.composite
def _scaled_cells(draw):
    scaling = (draw(st.one_of(st.none(), _SCALINGS)), draw(st.one_of(st.none(), _SCALINGS)))
    return (draw(_cells(scaling[0])), draw(_cells(scaling[1])), scaling)


@settings(max_examples=150, deadline=None)
@given(cells=_scaled_cells(), excitation=st.one_of(st.none(), _excitations()),
       counts=st.tuples(*[st.integers(0, 10 ** 9)] * 4))
def test_an_entry_reads_back_as_the_trial_it_holds(cells, excitation, counts):
    """Written and read back, a trial's signals are the same values and types, bit for
    bit: any floats (NaN, infinities), times in whole clock ticks (kept as steps) or not,
    forces decoded from whole codes (kept as codes) or not, counters of any size (kept in
    fewer bytes), an excitation with any of its signals missing, empty streams."""
    from evtribo.canlog.signals import TrialSignals

    normal, tangential, scaling = cells

    trial = TrialSignals(normal, tangential, excitation, frames=counts[0],
                         ignored_frames=counts[1], skipped_lines=counts[2],
                         skipped_detail=((3, "bad"), (None, "worse")), channel="can0",
                         logger_dropped=counts[3],
                         warnings=(kind("frames-lost").record(Scope(), {"frames": 3}, "t"),))
    table = cache._to_table(trial, scaling)
    with tempfile.TemporaryDirectory() as folder:
        cache._write_atomic(Path(folder), "k" * 40, table)
        back = cache._read_entry(Path(folder), "k" * 40)
    assert back is not None
    meta = json.loads(table.schema.metadata[cache._META])
    streams = [normal.t, tangential.t] + ([] if excitation is None else [excitation.t])
    ticks = any(all(np.all(np.abs(x * per_s) < 2.0 ** 53) and np.array_equal(
        (np.rint(x * per_s) / per_s).view(np.int64), np.asarray(x).view(np.int64))
        for x in streams) for per_s in (1e6, 1e9, 1e3))
    assert (meta["t_encoding"] is not None) == ticks  # the steps kept wherever exact
    if all(sc is not None and _whole_codes(c.value, *sc)
           for c, sc in zip((normal, tangential), scaling, strict=True)):
        assert meta["value_encoding"] is not None  # the codes kept wherever exact
    for name in ("normal", "tangential"):
        a, b = getattr(trial, name), getattr(back, name)
        for part in ("t", "value"):  # bit for bit: NaN as NaN, -0.0 as -0.0
            assert getattr(b, part).dtype == np.float64
            np.testing.assert_array_equal(getattr(b, part).view(np.int64),
                                          np.asarray(getattr(a, part)).view(np.int64))
        if a.counter is None:
            assert b.counter is None
        else:
            assert b.counter.dtype == np.int64
            np.testing.assert_array_equal(b.counter, a.counter)
        assert (b.dropped, b.dropped_method) == (a.dropped, a.dropped_method)
    if excitation is None:
        assert back.excitation is None
    else:
        np.testing.assert_array_equal(back.excitation.t.view(np.int64),
                                      excitation.t.view(np.int64))
        for part in ("enabled", "amplitude", "frequency", "waveform"):
            want, got = getattr(excitation, part), getattr(back.excitation, part)
            if want is None:
                assert got is None, part
            elif part == "waveform":
                assert got.dtype == object and got.tolist() == want.tolist()
            else:
                assert got.dtype == want.dtype, part
                np.testing.assert_array_equal(got, want, part)
    assert (back.frames, back.ignored_frames, back.skipped_lines, back.logger_dropped) == counts
    assert (back.skipped_detail, back.channel, back.warnings) == (
        trial.skipped_detail, trial.channel, trial.warnings)


def test_a_negative_zero_is_kept_as_such():
    """-0.0 equals 0.0 but is not the same value: a force or a time of -0.0 among whole
    codes or ticks reads back as -0.0 (the compact forms are only used where the bits
    match)."""
    from evtribo.canlog.signals import CellSignals, TrialSignals

    t = np.array([-0.0, 1e-6, 2e-6])
    value = np.array([1e-05, -0.0, 2e-05])
    cell = CellSignals(t, value, None, 0)
    trial = TrialSignals(cell, cell, None, frames=6, ignored_frames=0)
    with tempfile.TemporaryDirectory() as folder:
        cache._write_atomic(Path(folder), "z" * 40,
                            cache._to_table(trial, [(1e-05, 0.0), (1e-05, 0.0)]))
        back = cache._read_entry(Path(folder), "z" * 40)
    for got in (back.normal, back.tangential):
        assert np.signbit(got.t[0]) and np.signbit(got.value[1])
        np.testing.assert_array_equal(got.value.view(np.int64), value.view(np.int64))
