"""A plug-in installed for one test: a module and a ``*.dist-info`` folder declaring its
entry points, in a temporary folder put first on ``sys.path`` (never into the shared
environment); the entry points read again at the next look (the test forgets them again after: its
``autouse`` fixture calls :func:`evtribo.util.plugins.forget`)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from evtribo.util import plugins


def install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, module: str, source: str, *,
            entry_points: dict[str, dict[str, str]], name: str = "mylab-plugin") -> Path:
    """Install a plug-in: *module* (its *source*) and a distribution *name* whose
    ``entry_points.txt`` holds *entry_points* (``{group: {name: "module:attr"}}``)."""
    root = tmp_path / "site"
    root.mkdir(exist_ok=True)
    (root / f"{module}.py").write_text(source, encoding="utf-8")
    info = root / f"{name.replace('-', '_')}-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n",
                                   encoding="utf-8")
    (info / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in items.items()) + "\n"
        for group, items in entry_points.items()), encoding="utf-8")
    monkeypatch.syspath_prepend(str(root))
    monkeypatch.delitem(sys.modules, module, raising=False)
    plugins.forget()
    return root
