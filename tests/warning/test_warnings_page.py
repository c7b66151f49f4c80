"""docs/warnings.md is the catalogue as its generator writes it: a kind added or changed is
on the page."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from evtribo.warning.catalogue import KINDS
from evtribo.warning.docs import page

ROOT = Path(__file__).parents[2]


def test_docs_warnings_md_is_the_catalogue():
    text = (ROOT / "docs" / "warnings.md").read_text(encoding="utf-8")
    assert text == page(), "docs/warnings.md is out of date: python scripts/warnings_doc.py"
    assert all(f"### `{id}`: " in text for id in KINDS)


def test_the_script_checks_and_writes_the_page(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("warnings_doc",
                                                  ROOT / "scripts" / "warnings_doc.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--check"]) == 0
    monkeypatch.setattr(module, "PAGE", tmp_path / "warnings.md")
    assert module.main(["--check"]) == 1
    assert module.main([]) == 0 and module.main(["--check"]) == 0
