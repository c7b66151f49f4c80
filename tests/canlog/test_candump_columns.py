"""The column parser against the per-line parser: every line of a block, well-formed or
damaged at any character, gives the same frame or the same damage report either way."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.canlog.io.candump import _parse_block, _slow_lines
from evtribo.canlog.io.candump_columns import _Chunk, _digits_value
from evtribo.canlog.io.table import CLASSIC_WIDTH

T0 = 1763700000.0
# characters a damaged line may hold: next to digits and hex digits in ASCII (':', '/', '@',
# 'G', '`', 'g'), separators, and bytes with the high bit set
_NOISE = b":/@G`g .#(),_Rx\x7f\x80\xb9\xc6\xff"


@st.composite
def lines(draw):
    """A well-formed candump line of one of the layouts a mixed log holds, followed (one
    time in four) by a copy with one byte changed: a line of the same length, which the
    column parser meets in the group the first one sets the layout of; or (one time in
    four) a line cut short."""
    ts = f"{T0 + draw(st.integers(0, 10**9)) * 1e-6:.6f}" if draw(st.booleans()) else \
        str(draw(st.integers(0, 10**12)))
    can_id = draw(st.sampled_from(["%03X", "%08X"])) % draw(st.integers(0, 0x1FFFFFFF)) \
        if draw(st.integers(0, 4)) else draw(st.sampled_from(["7FF", "800", "FFF"]))
    payload = draw(st.binary(max_size=8)).hex()
    payload = payload.upper() if draw(st.booleans()) else payload
    line = f"({ts}) {draw(st.sampled_from(['can0', 'vcan1']))} {can_id}#{payload}".encode()
    damage = draw(st.integers(0, 3))
    if damage == 1:
        at = draw(st.integers(0, len(line) - 1))
        return [line, line[:at] + bytes([draw(st.sampled_from(_NOISE))]) + line[at + 1:]]
    if damage == 2:
        return [line, line[:draw(st.integers(0, len(line)))]]
    return [line]


def _per_line(block: bytes):
    """The block read by the per-line parser alone."""
    buf = np.frombuffer(block, dtype=np.uint8)
    nl = np.flatnonzero(buf == 10)
    starts = np.concatenate(([0], nl + 1))[:-1]
    out = _Chunk(len(starts), CLASSIC_WIDTH)
    bad: list = []
    _slow_lines(block, starts, nl, np.arange(len(starts)), first_line=1,
                on_bad=lambda *a: bad.append(a), out=out)
    return out.table(), sorted(bad)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(lines(), min_size=1, max_size=60), st.integers(1, 40))
def test_the_column_parser_reads_each_line_as_the_per_line_parser(sample, repeat):
    """Repeated lines make groups of one length large enough for the column parser; the
    damaged ones must leave it for the per-line parser, which reports them."""
    block = b"".join(line + b"\n" for group in sample * repeat for line in group)
    bad: list = []
    table, n = _parse_block(block, 1, lambda *a: bad.append(a))
    ref, ref_bad = _per_line(block)
    assert n == sum(map(len, sample)) * repeat
    assert sorted(bad) == ref_bad
    assert len(table) == len(ref)
    for name in ("timestamp", "arbitration_id", "is_extended", "is_remote", "is_error",
                 "is_fd", "dlc", "channel_index"):
        np.testing.assert_array_equal(getattr(table, name), getattr(ref, name), err_msg=name)
    width = min(table.data.shape[1], ref.data.shape[1])
    np.testing.assert_array_equal(table.data[:, :width], ref.data[:, :width])
    assert table.channel_names == ref.channel_names


@given(st.lists(st.binary(min_size=1, max_size=16), min_size=1, max_size=30))
def test_digit_words_tell_digits_from_any_other_byte(rows):
    """The word-wise digit check agrees with a byte-wise one on any bytes, and digits give
    their exact value."""
    width = max(len(r) for r in rows)
    mat = np.array([list(r.rjust(width, b"0")) for r in rows], dtype=np.uint8)
    value, digits = _digits_value(mat)
    expect = [all(48 <= b <= 57 for b in r.rjust(width, b"0")) for r in rows]
    assert digits.tolist() == expect
    for r, v, d in zip(rows, value, digits, strict=True):
        if d:
            assert v == float(int(r))


@settings(max_examples=300, deadline=None)
@given(st.integers(1, 50), st.sampled_from(["can0", "vcan1"]), st.data())
def test_a_block_of_one_line_length_is_read_as_lines_whatever_one_byte_becomes(n, channel,
                                                                               data):
    """Lines of one length are read as a matrix, unless a row fails: a byte changed into a
    newline (two lines where the matrix has one row, every line end still in its place) or
    into anything else gives what the per-line parser gives."""
    rows = [f"({T0 + k * 5e-4:.6f}) {channel} 0C1#{k % 256:02X}F1FF0060090000".encode()
            for k in range(n)]
    block = bytearray(b"".join(row + b"\n" for row in rows))
    if data.draw(st.booleans()):
        at = data.draw(st.integers(0, len(block) - 1))
        block[at] = data.draw(st.sampled_from(b"\n" + _NOISE))
    block = bytes(block)
    bad: list = []
    table, count = _parse_block(block, 1, lambda *a: bad.append(a))
    ref, ref_bad = _per_line(block + (b"" if block.endswith(b"\n") else b"\n"))
    assert count == block.count(b"\n") + (not block.endswith(b"\n"))
    assert sorted(bad) == ref_bad
    for name in ("timestamp", "arbitration_id", "dlc", "channel_index"):
        np.testing.assert_array_equal(getattr(table, name), getattr(ref, name), err_msg=name)
    np.testing.assert_array_equal(table.data[:, :8], ref.data[:, :8])
    assert table.channel_names == ref.channel_names
