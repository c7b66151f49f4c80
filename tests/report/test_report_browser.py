"""The report of an eight-subject study at one drive frequency as a reviewer sees it, in
headless Chromium, on screen at 1280 px and printed: the key results first, each kind of
warning once (linked from the cells it touches), no figure of F_el against a frequency
never varied, a table of contents in view on one line per entry, intervals whole, nothing
scrolling sideways, and, printed, each trial's check unfolded and each heading kept with
its figure."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from tests._browser import Browser

from eight_subjects import AMPLITUDES, eight_subject_study
from evtribo.report.study_report import build_report
from evtribo.util.numbers import with_interval

WIDTH = 1280

#: Tables (by the heading above them) wider than their box.
_OVERFLOWING = ("JSON.stringify(Array.from(document.querySelectorAll('.table-wrap'))"
                ".filter(e => e.scrollWidth > e.clientWidth + 1)"
                ".map(e => e.previousElementSibling ? e.previousElementSibling.textContent"
                " : '?'))")


def _send(page: Any, method: str, params: dict[str, Any]) -> Any:
    """One DevTools command on *page*, its result."""
    page.n += 1
    page.ws.send(json.dumps({"id": page.n, "method": method, "params": params}))
    while True:
        msg = json.loads(page.ws.recv())
        if msg.get("id") == page.n:
            return msg.get("result")


@pytest.fixture(scope="module")
def out(tmp_path_factory) -> Path:
    return eight_subject_study(tmp_path_factory.mktemp("eight"))


@pytest.fixture(scope="module")
def report(out) -> Path:
    return build_report(out, out / "report.html")


@pytest.fixture(scope="module")
def page(report):
    with Browser() as browser:
        tab = browser.open(report.resolve().as_uri())
        _send(tab, "Emulation.setDeviceMetricsOverride",
              {"width": WIDTH, "height": 900, "deviceScaleFactor": 1, "mobile": False})
        # (the new tab shows about:blank, complete and without images, until the report
        # replaces it)
        assert tab.wait_for("location.protocol === 'file:' && "
                            "document.readyState === 'complete' && "
                            "Array.from(document.images).every(i => i.complete)")
        yield tab


def _js(page: Any, expression: str) -> Any:
    return json.loads(page.eval(f"JSON.stringify({expression})"))


def test_nothing_scrolls_sideways_and_every_figure_is_decoded(page):
    assert page.eval("window.innerWidth") == WIDTH
    for unfolded in ("false", "true"):
        page.eval(f"document.querySelectorAll('details').forEach(d => d.open = {unfolded})")
        assert page.eval("document.documentElement.scrollWidth") <= WIDTH
        assert json.loads(page.eval(_OVERFLOWING)) == []
    page.eval("document.querySelectorAll('details').forEach(d => d.open = false)")
    widths = _js(page, "Array.from(document.images).map(i => i.naturalWidth)")
    assert len(widths) > 20 and min(widths) > 50


def test_the_key_results_come_first(page, out):
    sections = _js(page, "Array.from(document.querySelectorAll('main > section'))"
                         ".map(s => s.querySelector('h2').textContent)")
    assert sections[:2] == ["Key results", "Warnings"]
    first = _js(page, "Array.from(document.querySelector('main > section').children)"
                      ".map(e => e.tagName + ' ' + (e.className || ''))")
    assert first[:3] == ["H2 ", "P lead", "H3 "]
    sentence = page.eval("document.querySelector('p.lead').textContent")
    assert sentence.startswith("8 subjects, square 10 kHz: the relative friction increase")
    assert "ΔF" not in sentence and " % at 80 V to " in sentence
    # at the top of the page: the sentence and the table by voltage in the first screen
    top = page.eval("document.querySelector('main table').getBoundingClientRect().top")
    assert 0 < top < 500
    heads = _js(page, "Array.from(document.querySelector('main table').querySelectorAll('th'))"
                      ".map(t => t.textContent)")
    assert heads[0] == "U" and "relative friction increase F_el/F_n,ON (%)" in heads
    rows = _js(page, "Array.from(document.querySelector('main table tbody').rows)"
                     ".map(r => r.cells[0].textContent)")
    assert rows == [f"{a:g} V" for a in AMPLITUDES]
    # its relative increase is the population's 100 F_el/F_n,ON, population.csv's cell
    pop = pd.read_csv(out / "population.csv")
    at_80 = pop[(pop["quantity"] == "friction_increase_pct") & (pop["analysis"] == "primary")
                & (pop["amplitude_V"] == AMPLITUDES[0])].iloc[0]
    column = heads.index("relative friction increase F_el/F_n,ON (%)")
    cell = _js(page, "document.querySelector('main table tbody').rows[0]"
                     f".cells[{column}].textContent")
    assert cell.replace("\u00a0", " ") == with_interval(
        at_80["estimate"], at_80["ci_low"], at_80["ci_high"])


def test_each_kind_of_warning_appears_once_and_the_cells_it_touches_link_to_it(page, out):
    kinds = _js(page, "Array.from(document.querySelectorAll('ol.warnings > li'))"
                      ".map(li => [li.id, li.querySelector('b').textContent])")
    titles = [t.split(". ", 1)[1] for _, t in kinds]
    assert len(titles) == len(set(titles))
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert len(kinds) < len(summary["warnings"])  # each kind once, not once per trial
    zero = [t for t in titles if t == "the normal cell's zero is unknown"]
    assert len(zero) == 1
    text = page.eval("document.getElementById('warnings').textContent")
    assert text.count("the normal cell's zero is unknown (all 16 trials") == 1
    # the order: what may change a number, then what widens an interval
    effects = _js(page, "Array.from(document.querySelectorAll('#warnings h3'))"
                        ".map(h => h.textContent)")
    assert effects[0] == "May change a reported number"
    # every flagged cell links to a warning on the page; the key table flags its cells
    links = _js(page, "Array.from(document.querySelectorAll('sup.mark a'))"
                      ".map(a => a.getAttribute('href'))")
    assert links and {h[1:] for h in links} <= {i for i, _ in kinds}
    flagged = _js(page, "Array.from(document.querySelector('main table tbody').rows)"
                        ".map(r => r.cells[r.cells.length - 1].textContent)")
    assert all(re.match(r"\d of 8W\d", f) for f in flagged), flagged


def test_one_drive_frequency_draws_no_frequency_figure(page, out):
    heads = _js(page, "Array.from(document.querySelectorAll('figure h3'))"
                      ".map(h => h.textContent)")
    assert heads and not [h for h in heads if "frequency" in h]
    doc = json.loads((out / "fit.json").read_text(encoding="utf-8"))
    assert not [f for f in doc["figures"] if f["kind"] == "frequency_response"]
    assert any("at a single frequency" in n for n in doc["notes"])
    # the models ranked over the study, headed by the criterion they were ranked with
    ranking = page.eval("document.getElementById('model-comparison')"
                        ".querySelector('thead').textContent")
    assert "summed AICc" in ranking and "ΔAICc" in ranking


def test_the_contents_stay_in_view_on_one_line_each(page):
    page.eval("window.scrollTo(0, document.body.scrollHeight)")
    nav = _js(page, "(r => [r.top, r.bottom, r.right])("
                    "document.querySelector('nav.toc').getBoundingClientRect())")
    assert 0 <= nav[0] <= 1 and nav[1] > 100
    lines = _js(page, "Array.from(document.querySelectorAll('nav.toc a'))"
                      ".map(a => a.getClientRects().length)")
    assert len(lines) >= 10 and set(lines) == {1}
    main_left = page.eval("document.querySelector('main').getBoundingClientRect().left")
    assert nav[2] <= main_left
    page.eval("window.scrollTo(0, 0)")


def test_an_interval_never_breaks_inside_its_brackets(page):
    _send(page, "Emulation.setDeviceMetricsOverride",
          {"width": 700, "height": 900, "deviceScaleFactor": 1, "mobile": False})
    try:
        spans = _js(page, "Array.from(document.querySelectorAll('.iv'))"
                          ".map(s => s.getClientRects().length)")
        assert spans and set(spans) == {1}
        cells = _js(page, "Array.from(document.querySelectorAll('#key-results td'))"
                          ".map(td => td.textContent)")
        inside = [c for c in cells if re.search(r"\[[^\]]* [^\]]*\]", c)]
        assert not inside  # the key tables' intervals hold no breaking space
    finally:
        _send(page, "Emulation.setDeviceMetricsOverride",
              {"width": WIDTH, "height": 900, "deviceScaleFactor": 1, "mobile": False})


def test_every_table_and_figure_file_is_linked(page, out):
    hrefs = set(_js(page, "Array.from(document.querySelectorAll('a[href]'))"
                          ".map(a => a.getAttribute('href'))"))
    files = {p.name for p in out.iterdir() if p.suffix == ".csv"}
    files |= {f"figures/{p.name}" for p in (out / "figures").iterdir()}
    assert files <= hrefs, sorted(files - hrefs)[:5]


def test_printed_each_check_unfolded_each_heading_with_its_figure(page, out):
    _send(page, "Emulation.setEmulatedMedia", {"media": "print"})
    try:
        assert page.eval("getComputedStyle(document.querySelector('nav.toc')).display") \
            == "none"
        checks = _js(page, "Array.from(document.querySelectorAll('details.trial img'))"
                           ".map(i => i.getBoundingClientRect().height)")
        assert len(checks) == 16 and min(checks) > 50  # unfolded, each of them
        kept = _js(page, "Array.from(document.querySelectorAll('figure:not(.grid-figure)'))"
                         ".map(f => [getComputedStyle(f).breakInside, !!f.querySelector('h3')])")
        assert kept and all(k == ["avoid", True] for k in kept)
        panels = _js(page, "Array.from(document.querySelectorAll('.grid .panel'))"
                           ".map(p => getComputedStyle(p).breakInside)")
        assert len(panels) == 16 and set(panels) == {"avoid"}  # a grid breaks between rows
        headings = _js(page, "Array.from(document.querySelectorAll('h2, h3'))"
                             ".map(h => getComputedStyle(h).breakAfter)")
        assert set(headings) == {"avoid"}
    finally:
        _send(page, "Emulation.setEmulatedMedia", {"media": ""})
    pdf = base64.b64decode(_send(page, "Page.printToPDF", {"preferCSSPageSize": True})["data"])
    pages = len(re.findall(rb"/Type\s*/Page[^s]", pdf))
    sections = page.eval("document.querySelectorAll('main > section').length")
    figures = page.eval("document.querySelectorAll('figure').length")
    # half a page a figure or section at most, the 16 checks included (one page a figure
    # and its heading, the checks folded, was 44 pages)
    assert 0 < pages <= (figures + sections) / 2


def test_the_population_figure_names_its_subjects(out):
    from evtribo.figures.population_plots import plot_population
    from evtribo.figures.style import journal_style
    from evtribo.fit.tables import read_results
    from evtribo.population.estimates import population
    from legends import legend_entries

    tables = read_results(out)
    pop = population(tables)
    with journal_style():
        ax = plot_population(tables.electrostatic, pop, next(iter(pop.lines)))
        ax.figure.canvas.draw()
    labels = " ".join(label for label, _ in legend_entries(ax))
    assert all(s in labels for s in tables.subjects)
