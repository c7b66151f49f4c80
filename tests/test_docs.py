"""The documentation site's sources (built by `make docs`, with warnings as errors): every
page of docs/ is in the navigation, and each entry of the navigation is a page."""

from __future__ import annotations

import re
from pathlib import Path

DOCS = Path(__file__).parents[1] / "docs"


def _navigation() -> list[str]:
    """The entries of docs/index.md's toctrees, in order."""
    source = (DOCS / "index.md").read_text(encoding="utf-8")
    entries = []
    for block in re.findall(r"^```\{toctree\}\n(.*?)^```", source, re.MULTILINE | re.DOTALL):
        entries += [line.strip() for line in block.splitlines()
                    if line.strip() and not line.startswith(":")]
    return entries


def _pages() -> set[str]:
    return {p.stem for p in DOCS.iterdir()
            if p.suffix in (".md", ".ipynb") and p.stem != "index"}


def test_every_page_is_in_the_navigation_once():
    entries = _navigation()
    assert len(entries) == len(set(entries))
    missing = _pages() - set(entries)
    assert not missing, f"docs/index.md's toctrees lack {sorted(missing)}"


def test_every_entry_of_the_navigation_is_a_page():
    unknown = set(_navigation()) - _pages()
    assert not unknown, f"docs/index.md lists pages docs/ does not have: {sorted(unknown)}"


def test_the_front_page_is_the_readme_and_the_notebook_the_example():
    assert "```{include} ../README.md\n```" in (DOCS / "index.md").read_text(encoding="utf-8")
    notebook = DOCS / "quickstart.ipynb"
    assert notebook.is_symlink()
    assert notebook.resolve() == (DOCS.parent / "examples" / "quickstart.ipynb").resolve()
