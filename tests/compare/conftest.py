from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from synthetic import make_out

from evtribo.compare import compare


@pytest.fixture
def out_dir(tmp_path: Path) -> Path:
    """A synthetic result folder with known air gaps (see synthetic.py)."""
    return make_out(tmp_path / "out")


@pytest.fixture(scope="module")
def compared_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic result folder on which ``compare`` has run (low-dpi figures)."""
    folder = make_out(tmp_path_factory.mktemp("cmp") / "out",
                      note="<script>alert('x')</script> & notes")
    compare(folder, dpi=40)
    return folder
