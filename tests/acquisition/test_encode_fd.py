"""The simulator's signal packer on any layout cantools accepts, CAN FD's 64-byte payloads
included: what it packs is what cantools encodes, bit for bit."""

import cantools
import numpy as np
from cantools.database.can import Message, Signal
from hypothesis import assume, given
from hypothesis import strategies as st

from evtribo.acquisition.simulator.encode import pack_signals

LENGTHS = (1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


@st.composite
def messages(draw):
    length = draw(st.sampled_from(LENGTHS))
    signals = []
    for k in range(draw(st.integers(1, 6))):
        bits = draw(st.integers(1, 64))
        order = draw(st.sampled_from(["little_endian", "big_endian"]))
        start = draw(st.integers(0, 8 * length - 1))
        signals.append(Signal(f"S{k}", start, bits, byte_order=order,
                              is_signed=draw(st.booleans())))
    try:  # cantools refuses overlapping signals and signals beyond the payload
        msg = Message(0x123, "M", length, signals, is_fd=length > 8, strict=True)
    except cantools.database.errors.Error:
        assume(False)
    values = {}
    for sig in signals:
        lo, hi = ((-(1 << (sig.length - 1)), (1 << (sig.length - 1)) - 1) if sig.is_signed
                  else (0, (1 << sig.length) - 1))
        values[sig.name] = draw(st.integers(lo, hi))
    return msg, values


@given(messages())
def test_packed_payloads_are_what_cantools_encodes(case):
    msg, raw = case
    packed = pack_signals(msg, {f"{k}_raw": np.array([v]) for k, v in raw.items()}, 1)
    assert packed.shape == (1, max(8, -(-msg.length // 8) * 8))
    want = msg.encode(raw, scaling=False, padding=False, strict=False)
    assert bytes(packed[0, :msg.length]) == bytes(want)
    assert not packed[0, msg.length:].any()
