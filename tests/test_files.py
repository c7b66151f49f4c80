"""evtribo.files' hashing of a file, against hashlib on its bytes."""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo import files


@settings(max_examples=60, deadline=None)
@given(data=st.binary(max_size=300), block=st.integers(1, 64))
def test_a_file_hashed_by_blocks_is_its_bytes_hashed(data, block):
    """Any bytes, any block size (shorter and longer than the file, a file that ends on a
    block's end): the SHA-256 of the whole."""
    saved = files.HASH_BLOCK
    files.HASH_BLOCK = block
    try:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "f"
            path.write_bytes(data)
            assert files.sha256_file(path) == hashlib.sha256(data).hexdigest()
            path.write_bytes(data * block)  # ends on a block's end
            assert files.sha256_file(path) == hashlib.sha256(data * block).hexdigest()
    finally:
        files.HASH_BLOCK = saved
