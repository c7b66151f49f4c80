from __future__ import annotations

import base64
import hashlib
import io
import json
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread

import evtribo
from analysed import analysed_study, set_notes
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.citation import PAPER, SOFTWARE
from evtribo.citation import text as cite_text
from evtribo.cli import main
from evtribo.errors import OutputExistsError, UserInputError
from evtribo.figures.plots import new_axes
from evtribo.report.compare import compare
from evtribo.report.headline import DOI_URL
from evtribo.report.page import Report, files_dir_for
from evtribo.report.study_report import build_report
from evtribo.results.pipeline import analyze_study
from synthetic import make_out

NOTE = "<script>alert('x')</script> & notes"


class _Page(HTMLParser):
    """Collects tags, reference attributes, text and table headers of a page."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.refs: list[tuple[str, str, str]] = []
        self.text: list[str] = []
        self.headers: list[str] = []
        self.imgs: list[str] = []
        self._in_th = False

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for name, value in attrs:
            if name in {"src", "href", "srcset", "data", "action", "poster"} or (
                    name == "style" and "url(" in (value or "")):
                self.refs.append((tag, name, value or ""))
        if tag == "img":
            self.imgs.append(dict(attrs)["src"])
        self._in_th = tag == "th"

    def handle_endtag(self, tag):
        if tag == "th":
            self._in_th = False

    def handle_data(self, data):
        self.text.append(data)
        if self._in_th:
            self.headers.append(data)


def _parse(path) -> tuple[_Page, str]:
    html = path.read_text(encoding="utf-8")
    page = _Page()
    page.feed(html)
    page.close()
    return page, html


@pytest.fixture(scope="module")
def compared_out(tmp_path_factory):
    """What `evtribo analyze` writes of a simulated study (with a sidecar note, dropped
    frames and a damaged line, see analysed.py), and `evtribo compare` of it."""
    _, out = analysed_study(tmp_path_factory.mktemp("analysed"), note=NOTE)
    compare(out, dpi=40)
    return out


@pytest.fixture(scope="module")
def report_page(compared_out, tmp_path_factory):
    path = tmp_path_factory.mktemp("rep") / "report.html"
    build_report(compared_out, path)
    page, html = _parse(path)
    return path, page, html


def test_report_is_self_contained(report_page, compared_out):
    path, page, html = report_page
    assert page.tags[0] == "html" and "body" in page.tags
    assert "script" not in page.tags and "link" not in page.tags and "iframe" not in page.tags
    linked = set()
    for tag, name, value in page.refs:
        # embedded figures, anchors, the paper's DOI, and links to the result folder's files
        # by their paths relative to the page (followed by a reader, never loaded)
        if (tag, name) == ("a", "href") and not value.startswith(("#", "http", "data:")):
            target = (path.parent / value).resolve()
            assert target.is_file() and target.is_relative_to(compared_out.resolve()), value
            linked.add(target.relative_to(compared_out.resolve()).as_posix())
            continue
        assert value.startswith(("data:image/png;base64,", "data:image/svg+xml;base64,", "#")) \
            or (tag, name, value) == ("a", "href", DOI_URL), (tag, name, value[:60])
    assert "@import" not in html and "url(" not in html
    # every table and every figure file of the result folder is linked
    files = {p.relative_to(compared_out).as_posix() for p in compared_out.rglob("*")
             if p.is_file() and p.suffix in (".csv", ".png", ".svg", ".pdf")}
    assert files and files <= linked, sorted(files - linked)[:5]


def test_report_holds_every_figure_and_table(report_page, compared_out):
    path, page, _ = report_page
    fit_doc = json.loads((compared_out / "fit.json").read_text())
    kinds = [f["kind"] for f in fit_doc["figures"]]
    n_trials = len(pd.read_csv(compared_out / "trials.csv"))
    assert len(page.imgs) == len(kinds) == 7 + n_trials
    assert kinds.count("trial") == n_trials  # the check of every trial
    text = " ".join(page.text)
    for fig in fit_doc["figures"]:
        assert fig["title"] in text
    for section in ("Electrostatic force", "Model fit", "All subjects", "Subject P01",
                    "Subject P02", "Warnings", "Provenance and settings"):
        assert section in text
    for table_title in ("Key results by voltage", "Key results by subject",
                        "Electrostatic force F_el (mN) by subject and voltage",
                        "What was analysed and what was left out, per subject",
                        "Model fit per subject", "Model parameters: measured, fixed or fitted",
                        "Trials", "Result files", "Software", "Analysis settings"):
        assert table_title in text
    for col in ("air gap h_L (µm)", "μ (mean of its rows)", "exponent n, measured", "R²",
                "RMSE (mN)", "F_el (mN) [95 %]", "dropped frames", "sha256", "analysed (s)",
                "guard around switches (s)", "lift-offs (s)", "unsteady sliding (s)"):
        assert col in page.headers
    # the fitted air gap is in the page, in µm to three significant figures
    fit = pd.read_csv(compared_out / "fit.csv")
    assert f"{fit['value'].iloc[0] * 1e6:.2f} [" in text
    # the figures are the result folder's: not copied beside the report
    assert not files_dir_for(path).exists()


def test_embedded_figure_is_a_real_image(report_page):
    _, page, _ = report_page
    png = base64.b64decode(page.imgs[0].split(",", 1)[1])
    img = imread(io.BytesIO(png), format="png")
    assert img.shape[0] > 50 and float(np.var(img[..., :3])) > 1e-3


def test_user_text_is_escaped(report_page):
    _, page, html = report_page
    assert NOTE in " ".join(page.text)  # shown as text ...
    assert "&lt;script&gt;alert(" in html  # ... because it was escaped
    assert "<script>alert(" not in html


def test_warnings_and_provenance(report_page, compared_out):
    _, page, _ = report_page
    text = " ".join(page.text)
    # each kind once, with the trials it concerns
    assert text.count("load-cell frames lost") == 1 and "P02: run-02" in text
    assert "3 dropped frame(s)" in text
    assert text.count("damaged log lines skipped") == 1 and "P01: run-03" in text
    assert "skipped damaged line" in text  # from summary.json
    digest = hashlib.sha256((compared_out / "fit.csv").read_bytes()).hexdigest()
    assert digest in text
    recorded = json.loads((compared_out / "summary.json").read_text())["inputs"][0]["sha256"]
    assert recorded in text


def test_notes_and_hashes_from_study_folder(tmp_path):
    study, out = tmp_path / "study", tmp_path / "out"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=6.0), sine_trial=False)
    set_notes(study / "P01" / "run-01.json", "<b>finger</b> <script>")
    analyze_study(study, out, jobs=1, cache_dir=tmp_path / "cache")
    log_bytes = (study / "P01" / "run-01.log").read_bytes()
    path = build_report(out, tmp_path / "r.html", dpi=30)
    page, html = _parse(path)
    text = " ".join(page.text)
    assert "<b>finger</b> <script>" in text and "&lt;b&gt;finger" in html
    assert hashlib.sha256(log_bytes).hexdigest() in text
    assert "model only" in text.lower() or "sine_trace.csv" in text


def test_report_refuses_to_overwrite(compared_out, tmp_path, capsys):
    path = tmp_path / "report.html"
    assert main(["report", str(compared_out), "-o", str(path)]) == 0
    first = path.read_bytes()
    with pytest.raises(OutputExistsError):
        build_report(compared_out, path)
    assert main(["report", str(compared_out), "-o", str(path)]) == 2
    assert "--force" in capsys.readouterr().err
    assert path.read_bytes() == first
    assert main(["report", str(compared_out), "-o", str(path), "--force"]) == 0


def test_report_without_fit(tmp_path, capsys):
    out = make_out(tmp_path / "out", sine_trace=False)
    assert main(["report", str(out), "--no-compare", "-o", str(tmp_path / "r.html")]) == 2
    assert "evtribo compare" in capsys.readouterr().err
    with pytest.raises(UserInputError):
        build_report(out, tmp_path / "r.html", run_compare=False)
    assert main(["report", str(tmp_path / "missing"), "-o", str(tmp_path / "r.html")]) == 2


def test_builder_escapes_all_but_add_html(tmp_path):
    report = Report("T <i>")
    ax = new_axes()
    ax.plot([0, 1], [0, 1])
    report.add_figure(ax.figure, "fig <1>", caption="c & d", section="S")
    report.add_table(pd.DataFrame({"a<": [1.5, np.nan], "b": ["<x>", "y"]}), "tab",
                     section="S")
    report.add_text("<em>t</em>", section="S")
    report.add_html("<em>trusted</em>", section="S")
    html = report.render()
    assert "<em>trusted</em>" in html and "&lt;em&gt;t&lt;/em&gt;" in html
    assert "&lt;x&gt;" in html and "a&lt;" in html and "fig &lt;1&gt;" in html
    assert "T &lt;i&gt;" in html and "c &amp; d" in html
    assert report.sections == ["S"]
    saved = report.save(tmp_path / "x.html")
    assert {p.suffix for p in files_dir_for(saved).iterdir()} == {".png", ".svg"}


def test_provenance_cites_the_software_and_the_model(report_page):
    """The provenance section says how to cite evtribo (at this version) and the seed paper,
    with the paper's DOI as the one link out of the page."""
    _, page, html = report_page
    text = " ".join(page.text)
    provenance = text[text.index("Provenance and settings"):]
    assert f"To cite: the software, {cite_text(SOFTWARE)}" in provenance
    assert f"(version {evtribo.__version__})" in provenance
    assert f"The model, {cite_text(PAPER)}" in " ".join(provenance.split())
    assert "analysed by evtribo" not in provenance  # the same version analysed them
    assert f'<a href="{DOI_URL}">{DOI_URL}</a>' in html


def test_provenance_names_the_version_that_analysed_the_results(tmp_path):
    """Results analysed by another version: the report asks to cite that version."""
    out = make_out(tmp_path)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["evtribo_version"] != evtribo.__version__
    build_report(out, tmp_path / "report.html")
    page, _ = _parse(tmp_path / "report.html")
    text = " ".join(page.text)
    assert (f"These results were analysed by evtribo {summary['evtribo_version']}: cite that "
            "version.") in text


def test_an_exact_fit_prints_no_over_long_number(tmp_path):
    """A model that goes through every point has an RMSE of 1e-17 N: the page says '<
    0.000001' mN, not a number of sixteen decimals, nor one in scientific notation."""
    import re

    out = make_out(tmp_path / "out", exact=True)
    compare(out, dpi=40, trial_checks=False)
    rmse = pd.read_csv(out / "fit.csv")["rmse_N"].to_numpy(float)
    assert (rmse < 1e-12).all()
    page = _Page()
    page.feed(build_report(out, tmp_path / "r.html").read_text(encoding="utf-8"))
    text = " ".join(page.text)
    assert "< 0.000001" in text
    decimals = re.findall(r"(?<![\w.:/-])-?(\d+)\.(\d+)(?![\w.])", text)
    assert len(decimals) > 50
    assert [f"{w}.{f}" for w, f in decimals
            if len(f) > 8 or len((w + f).lstrip("0")) > 4] == []
    assert not re.search(r"(?<![\w.])\d+(?:\.\d+)?[eE][-+]?\d+(?![\w.])", text)
