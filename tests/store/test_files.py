"""evtribo.store.files' hashing of a file, against hashlib on its bytes."""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.store import files


@settings(max_examples=60, deadline=None)
@given(data=st.binary(max_size=300), repeat=st.sampled_from([1, 2, 873, 1 << 10]))
def test_a_file_hashed_is_its_bytes_hashed(data, repeat):
    """Any bytes, short or longer than the blocks hashlib reads them in (2**18 bytes,
    shorter and longer, ending on a block's end or not): the SHA-256 of the whole."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "f"
        path.write_bytes(data * repeat)
        assert files.sha256_file(path) == hashlib.sha256(data * repeat).hexdigest()
        path.write_bytes(bytes(1 << 18))  # exactly one block
        assert files.sha256_file(path) == hashlib.sha256(bytes(1 << 18)).hexdigest()
