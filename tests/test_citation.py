"""Citing evtribo: `evtribo cite` (text and BibTeX), CITATION.cff (valid CFF 1.2.0 and saying
the same), the licence file pyproject.toml declares, the changelog and the one version."""

from __future__ import annotations

import copy
import datetime
import functools
import io
import json
import re
import subprocess
import tomllib
from pathlib import Path
from typing import Any

import jsonschema
import pybtex
import pybtex.database
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

import evtribo
from evtribo.citation import PAPER, RELEASED, SOFTWARE, Work, bibtex, text
from evtribo.cli import main

ROOT = Path(__file__).parents[1]
SCHEMA = ROOT / "tests" / "data" / "cff" / "schema-1.2.0.json"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def _cff() -> dict:
    """CITATION.cff as its YAML says, dates as the ISO text the schema checks."""
    def dates_as_text(value):
        if isinstance(value, dict):
            return {k: dates_as_text(v) for k, v in value.items()}
        if isinstance(value, list):
            return [dates_as_text(v) for v in value]
        return value.isoformat() if isinstance(value, datetime.date) else value

    return dates_as_text(yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8")))


def _errors(document: dict) -> list[str]:
    schema = json.loads(SCHEMA.read_text(encoding="utf-8"))
    validator = jsonschema.Draft7Validator(schema, format_checker=jsonschema.FormatChecker())
    return [f"{'/'.join(map(str, e.absolute_path))}: {e.message}"
            for e in validator.iter_errors(document)]


@functools.cache
def _plugins() -> tuple[Any, Any, Any]:
    """pybtex's BibTeX parser, plain style and text backend, found once (pybtex looks its
    plugins up among every installed package's entry points each time it formats)."""
    from pybtex.plugin import find_plugin

    return (find_plugin("pybtex.database.input", "bibtex"),
            find_plugin("pybtex.style.formatting", "plain")(),
            find_plugin("pybtex.backends", "text")())


def _formatted(source: str) -> str:
    """BibTeX entries as BibTeX's plain style prints them (pybtex's implementation: what
    ``pybtex.format_from_string(source, "plain", output_backend="text")`` prints)."""
    parser, style, backend = _plugins()
    out = io.StringIO()
    backend.write_to_stream(style.format_bibliography(parser().parse_string(source)), out)
    return out.getvalue()


def test_the_entries_are_formatted_as_pybtex_formats_them():
    source = "\n".join(bibtex(w) for w in (PAPER, SOFTWARE))
    assert _formatted(source) == pybtex.format_from_string(source, "plain",
                                                           output_backend="text")


def test_citation_cff_is_valid_cff_1_2_0():
    document = _cff()
    assert document["cff-version"] == "1.2.0"
    assert _errors(document) == []


@pytest.mark.parametrize(("change", "where"), [
    (lambda d: d.pop("authors"), ""),
    (lambda d: d.update({"date-released": "26.11.2026"}), "date-released"),
    (lambda d: d.update({"licence": "BSD-3-Clause"}), ""),
    (lambda d: d.update({"license": "BSD-3"}), "license"),
    (lambda d: d["references"][0].pop("type"), "references/0"),
])
def test_the_schema_check_refuses_what_cff_1_2_0_does_not_allow(change, where):
    """The check can fail: a CITATION.cff without authors, with a date that is not ISO 8601,
    a misspelt key, a licence that is no SPDX identifier, a reference without a type."""
    document = copy.deepcopy(_cff())
    change(document)
    errors = _errors(document)
    assert errors and all(e.startswith(where) for e in errors), errors


def test_citation_cff_says_what_evtribo_cite_says():
    document = _cff()
    assert document["title"] == SOFTWARE.title
    assert document["version"] == evtribo.__version__ == SOFTWARE.field("version")
    assert document["date-released"] == RELEASED
    assert document["license"] == PYPROJECT["project"]["license"]
    assert document["url"] == SOFTWARE.field("url")
    assert [a["name"] for a in document["authors"]] == [f for f, _ in SOFTWARE.authors]
    assert [a["name"] for a in document["authors"]] == \
        [a["name"] for a in PYPROJECT["project"]["authors"]]
    (paper,) = document["references"]
    assert paper["type"] == "article" and paper["url"] == PAPER.field("url")
    assert paper["title"] == PAPER.title
    assert [(a["family-names"], a["given-names"]) for a in paper["authors"]] == \
        list(PAPER.authors)
    assert (paper["journal"], paper["year"], paper["volume"], paper["issue"], paper["start"],
            paper["doi"]) == (PAPER.field("journal"), PAPER.year, int(PAPER.field("volume")),
                              int(PAPER.field("number")), int(PAPER.field("pages")),
                              PAPER.field("doi"))


def test_evtribo_cite_prints_both_works(capsys):
    assert main(["cite"]) == 0
    out = capsys.readouterr().out
    assert text(SOFTWARE) in out and text(PAPER) in out
    assert f"(version {evtribo.__version__})" in text(SOFTWARE)
    assert text(PAPER) == ("Forsbach, F., & Heß, M. (2019). Voltage-Induced Friction with "
                           "Application to Electrovibration. Lubricants, 7(12), 102. "
                           "https://doi.org/10.3390/lubricants7120102")


def test_evtribo_cite_bibtex_is_read_by_bibtex(capsys):
    assert main(["cite", "--bibtex"]) == 0
    source = capsys.readouterr().out
    entries = pybtex.database.parse_string(source, "bibtex").entries
    assert list(entries) == ["evtribo", "forsbach2019"]
    software, paper = entries["evtribo"], entries["forsbach2019"]
    assert software.fields["version"] == evtribo.__version__
    # a body of people as author stays one name, not "developers, The evtribo"
    (body,) = software.persons["author"]
    assert body.last_names == ["{The evtribo developers}"] and not body.first_names
    assert [(p.first_names, p.last_names) for p in paper.persons["author"]] == \
        [(["Fabian"], ["Forsbach"]), (["Markus"], [r"He{\ss}"])]
    assert paper.fields["doi"] == "10.3390/lubricants7120102"
    # each entry says where the work is: the paper's DOI and URL, the package's URL
    assert paper.fields["url"] == "https://doi.org/10.3390/lubricants7120102"
    assert software.fields["url"] == "https://pypi.org/project/evtribo/"
    printed = _formatted(source)
    assert "Fabian Forsbach and Markus Heß. Voltage-Induced Friction with Application to " \
           "Electrovibration. Lubricants, 7(12):102, 2019." in printed
    assert f"The evtribo developers. {SOFTWARE.title}. {SOFTWARE.year}. Python package, " \
           f"version {evtribo.__version__}." in printed


_WORD = st.text(alphabet="abcdefghijklmnopqrstuvwxyzABCDEFXYZßäöüé", min_size=1, max_size=9)


@given(family=_WORD, given_name=_WORD,
       title=st.lists(st.one_of(_WORD, st.sampled_from(["&", "%", "_", "#", "R&D", "50%"])),
                      min_size=1, max_size=6).map(" ".join))
def test_any_name_and_title_come_back_from_bibtex(family, given_name, title):
    """Names and titles with letters BibTeX needs as commands (ß, umlauts, é) and characters
    it reads as syntax (&, %, _, #) are printed back by a BibTeX style as written."""
    work = Work(key="k", entry="misc", authors=((family, given_name),), title=title, year=2026)
    printed = _formatted(bibtex(work))
    assert f"{given_name} {family}. {title}. 2026." in printed


def test_the_licence_file_is_the_licence_pyproject_declares():
    project = PYPROJECT["project"]
    assert project["license"] == "BSD-3-Clause"
    assert project["license-files"] == ["LICENSE"]
    licence = " ".join((ROOT / "LICENSE").read_text(encoding="utf-8").split())
    assert licence.startswith("BSD 3-Clause License Copyright (c) ")
    for clause in ("1. Redistributions of source code must retain the above copyright notice",
                   "2. Redistributions in binary form must reproduce the above copyright "
                   "notice",
                   "3. Neither the name of the copyright holder nor the names of its "
                   "contributors may be used to endorse or promote products derived from this "
                   "software without specific prior written permission.",
                   'THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS '
                   'IS"'):
        assert clause in licence


def test_the_version_is_written_in_one_place():
    """``__version__ = ...`` only in evtribo/__init__.py; pyproject.toml's build and the
    documentation read it from there; CITATION.cff and the changelog agree with it."""
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout.split()
    assigned = [p for p in tracked if p.endswith(".py") and re.search(
        r"^__version__\s*=", (ROOT / p).read_text(encoding="utf-8"), re.MULTILINE)]
    assert assigned == ["src/evtribo/__init__.py"]
    assert "version" not in PYPROJECT["project"]
    assert "version" in PYPROJECT["project"]["dynamic"]
    assert PYPROJECT["tool"]["setuptools"]["dynamic"]["version"] == \
        {"attr": "evtribo.__version__"}
    conf = (ROOT / "docs" / "conf.py").read_text(encoding="utf-8")
    assert re.search(r"^release = evtribo\.__version__$", conf, re.MULTILINE)
    assert re.fullmatch(r"\d+\.\d+\.\d+", evtribo.__version__)


def test_evtribo_version_prints_it(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"evtribo {evtribo.__version__}\n"


def _changelog() -> list[tuple[str, str, str]]:
    """The changelog's releases: (version, date, body), newest first."""
    source = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    heads = list(re.finditer(r"^## \[(\d+\.\d+\.\d+)\] - (\d{4}-\d{2}-\d{2})$", source,
                             re.MULTILINE))
    ends = [h.start() for h in heads[1:]] + [len(source)]
    return [(h[1], h[2], source[h.end():end]) for h, end in zip(heads, ends, strict=True)]


def test_the_changelog_tells_each_version_newest_first():
    releases = _changelog()
    versions = [tuple(map(int, v.split("."))) for v, _, _ in releases]
    assert versions == sorted(versions, reverse=True) and len(set(versions)) == len(versions)
    assert releases[0][:2] == (evtribo.__version__, RELEASED)
    assert releases[-1][0] == "0.1.0"
    dates = [d for _, d, _ in releases]
    assert dates == sorted(dates, reverse=True)
    for version, _, body in releases:
        assert len(re.findall(r"^- ", body, re.MULTILINE)) >= 3, version


def test_the_readme_cites_as_evtribo_cite_does():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert f"> {text(SOFTWARE)}\n>\n> {text(PAPER)}\n" in readme
