"""Identifier keys: one per ID and kind, the same scalar and vectorised, reversible."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from evtribo.canlog.io.ids import frame_key, frame_keys, id_text, key_id

ids = st.one_of(st.tuples(st.integers(0, 0x7FF), st.just(False)),
                st.tuples(st.integers(0, 0x1FFFFFFF), st.just(True)))


@given(st.lists(ids, min_size=1, max_size=50))
def test_keys_are_one_per_identifier_and_kind(frames):
    keys = [frame_key(i, e) for i, e in frames]
    assert [key_id(k) for k in keys] == [(i, e) for i, e in frames]
    assert len(set(keys)) == len(set(frames))
    vec = frame_keys([i for i, _ in frames], [e for _, e in frames])
    assert vec.tolist() == keys and vec.dtype == np.int64


def test_standard_and_extended_of_one_number_differ_and_read_as_candump_writes_them():
    assert frame_key(0xC1, False) != frame_key(0xC1, True)
    assert id_text(0xC1, False) == "0C1" and id_text(0xC1, True) == "000000C1"
