"""The report as a researcher sees it, in headless Chromium at 1280 px: nothing scrolls
sideways (with every trial's check unfolded too), the F_el table is at the top of the page,
and every embedded figure is decoded."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from tests._browser import Browser

from analysed import analysed_study
from evtribo.report.compare import compare
from evtribo.report.study_report import build_report

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
def report(tmp_path_factory) -> Path:
    _, out = analysed_study(tmp_path_factory.mktemp("browser"), note="finger slipped")
    compare(out, dpi=60, models="paper,hertz,circuit")
    return build_report(out, out / "report.html")


def test_nothing_scrolls_sideways_at_1280px(report):
    with Browser() as browser:
        page = browser.open(report.resolve().as_uri())
        _send(page, "Emulation.setDeviceMetricsOverride",
              {"width": WIDTH, "height": 900, "deviceScaleFactor": 1, "mobile": False})
        # (the new tab shows about:blank, complete and without images, until the report
        # replaces it)
        assert page.wait_for("location.protocol === 'file:' && "
                             "document.readyState === 'complete' && "
                             "Array.from(document.images).every(i => i.complete)")
        assert page.eval("window.innerWidth") == WIDTH
        for unfolded in ("false", "true"):
            page.eval(f"document.querySelectorAll('details').forEach(d => d.open = {unfolded})")
            assert page.eval("document.documentElement.scrollWidth") <= WIDTH
            assert json.loads(page.eval(_OVERFLOWING)) == []
        # every figure decoded (a broken data: URI has no natural width)
        widths = page.eval("Array.from(document.images).map(i => i.naturalWidth)")
        assert len(widths) > 10 and min(widths) > 50
        # the answer is at the top: the F_el table starts within the first screen
        top = page.eval("document.querySelector('table').getBoundingClientRect().top")
        assert 0 < top < 400
        assert "(mN)" in page.eval("document.querySelector('table')"
                                   ".closest('section').textContent")
