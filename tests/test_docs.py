"""The documentation site's sources (built by `make docs`, with warnings as errors): every
page of docs/ is in the navigation, and each entry of the navigation is a page."""

from __future__ import annotations

import inspect
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


def _words(text: str) -> str:
    return " ".join(text.split())


def test_the_electrostatic_force_is_defined_one_way_everywhere():
    """F_el and the μ each row used, stated word for word as the report states it."""
    import json

    import pandas as pd

    from evtribo.report.headline import F_EL_DEFINITION, force_table

    root = DOCS.parent
    notebook = json.loads((root / "examples" / "quickstart.ipynb").read_text(encoding="utf-8"))
    texts = {name: (root / name).read_text(encoding="utf-8")
             for name in ("README.md", "docs/study-format.md", "docs/analysis.md")}
    texts["examples/quickstart.ipynb"] = "\n".join(
        "".join(c["source"]) for c in notebook["cells"] if c["cell_type"] == "markdown")
    texts["the report"] = force_table(pd.DataFrame(columns=[
        "subject", "waveform", "amplitude_V", "electrostatic_force_N",
        "electrostatic_force_ci_low_N", "electrostatic_force_ci_high_N"])).caption
    for name, text in texts.items():
        assert _words(F_EL_DEFINITION) in _words(text), name
    for path in [root / "README.md", *DOCS.glob("*.md")]:
        assert "(F_on \u2212 F_off)/μ" not in path.read_text(encoding="utf-8"), path


def test_the_relative_friction_increase_is_defined_one_way_everywhere():
    """100 F_el/F_n,ON, stated word for word in the docs and the captions of the report's
    tables that show it (the key results by voltage, the population's and each subject's);
    the raw ratio of the friction ON to OFF under that name nowhere."""
    from evtribo.documents.quantities import FRICTION_INCREASE_DEFINITION
    from evtribo.report.lead import key_results
    from evtribo.report.population import INCREASE_CAPTION, SUBJECTS_CAPTION

    root = DOCS.parent
    texts = {name: (root / name).read_text(encoding="utf-8")
             for name in ("docs/population.md", "docs/analysis.md")}
    texts |= {"Table 9": INCREASE_CAPTION, "Table 10": SUBJECTS_CAPTION}
    for name, text in texts.items():
        assert _words(FRICTION_INCREASE_DEFINITION) in _words(text), name
    # Table 1's caption
    assert "{FRICTION_INCREASE_DEFINITION}" in inspect.getsource(key_results._by_voltage)
    for path in [*DOCS.glob("*.md"), *(root / "src").rglob("*.py")]:
        text = path.read_text(encoding="utf-8")
        for raw in ("F_t,OFF", "friction_on_N / friction_off_N", "ON over the friction OFF"):
            assert raw not in text, (path, raw)
