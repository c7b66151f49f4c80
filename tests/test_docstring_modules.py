"""Every module a docstring names with ``:mod:`` is there: a reader who follows the reference
finds what it describes (a module renamed or folded into another leaves none behind)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

SRC = Path(__file__).parents[1] / "src" / "evtribo"
#: ``:mod:`evtribo.x.y``` or ``:mod:`~evtribo.x.y```, a name broken over two lines joined.
_MOD = re.compile(r":mod:`~?(evtribo[\w.]*)`")


def _named() -> list[tuple[str, str]]:
    found = []
    for path in sorted(SRC.rglob("*.py")):
        text = re.sub(r"\.\n\s+", ".", path.read_text(encoding="utf-8"))
        found += [(path.relative_to(SRC).as_posix(), m.group(1)) for m in _MOD.finditer(text)]
    return found


def _exists(name: str) -> bool:
    try:
        importlib.import_module(name)
    except ModuleNotFoundError:
        return False
    return True


def test_every_module_a_docstring_names_exists():
    named = _named()
    assert len(named) > 100  # the references are found at all
    missing = sorted({f"{where}: {name}" for where, name in named if not _exists(name)})
    assert not missing, "\n".join(missing)
