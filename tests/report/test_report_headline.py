"""The report leads with the answer: the order of its sections, the F_el table in mN with
intervals first, air gaps in µm, no number in scientific notation, each trial's check
folded, the model comparison, and the headline tables exported as Markdown and LaTeX.

The result folder is what ``evtribo analyze`` and ``evtribo compare --models paper,hertz,
circuit`` (with its per-trial checks) write of a simulated study (analysed.py).
"""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import pandas as pd
import pytest

from analysed import analysed_study
from evtribo.cli import main
from evtribo.report.compare import compare
from evtribo.report.headline import CITATION
from evtribo.report.study_report import build_report
from evtribo.results.outputs import report_files

#: The models compared.
MODELS = "paper,hertz,circuit"
#: A number in scientific notation (``1e-06``, ``3.2E+04``), not inside a word or hash.
SCIENTIFIC = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?[eE][-+]?\d+(?![\w.])")
#: A cell of the F_el table: ``26.5 [25.7, 27.4]``.
CELL = re.compile(r"^(\d+(?:\.\d+)?) \[(\d+(?:\.\d+)?), (\d+(?:\.\d+)?)\]$")


class _Outline(HTMLParser):
    """The page's outline: sections (h2), tables (with the h3 above), details, text."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.sections: list[str] = []
        self.tables: list[dict] = []
        self.details: list[dict] = []
        self.text: list[str] = []
        self._stack: list[str] = []
        self._h3 = ""
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        self._stack.append(tag)
        if tag == "table":
            self.tables.append({"title": self._h3, "section": self.sections[-1],
                                "headers": [], "rows": []})
        elif tag == "tr" and self.tables:
            self.tables[-1]["rows"].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "details":
            self.details.append({"summary": "", "imgs": 0, "section": self.sections[-1]})
        elif tag == "img" and "details" in self._stack:
            self.details[-1]["imgs"] += 1

    def handle_endtag(self, tag):
        while self._stack and self._stack.pop() != tag:
            pass
        if tag in ("td", "th") and self._cell is not None:
            text = "".join(self._cell).strip()
            table = self.tables[-1]
            (table["headers"] if tag == "th" else table["rows"][-1]).append(text)
            self._cell = None

    def handle_data(self, data):
        if "style" in self._stack or "sup" in self._stack:  # a cell's links to warnings
            return
        self.text.append(data)
        top = self._stack[-1] if self._stack else ""
        if top == "h2":
            self.sections.append(data.strip())
        elif top == "h3":
            self._h3 = data.strip()
        elif top == "summary":
            self.details[-1]["summary"] += data
        if self._cell is not None:
            self._cell.append(data)


def _outline(path: Path) -> _Outline:
    page = _Outline()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    for t in page.tables:
        t["rows"] = [r for r in t["rows"] if r]
    return page


@pytest.fixture(scope="module")
def out(tmp_path_factory) -> Path:
    _, folder = analysed_study(tmp_path_factory.mktemp("headline"))
    compare(folder, dpi=40, models=MODELS)
    return folder


@pytest.fixture(scope="module")
def page(out) -> tuple[Path, _Outline]:
    assert main(["report", str(out), "--tables", "md,tex"]) == 0
    path = out / "report.html"
    return path, _outline(path)


def test_sections_in_order(page):
    _, outline = page
    assert outline.sections == ["Key results", "Warnings", "Electrostatic force", "Model fit",
                                "Population", "All subjects", "Model predictions",
                                "Model comparison", "Subject P01", "Subject P02",
                                "Provenance and settings"]
    # the answer first: a sentence, then the tables by voltage and by subject
    assert [t["title"] for t in outline.tables[:2]] == ["Key results by voltage",
                                                        "Key results by subject"]
    # the study's facts (run_id, strict, elapsed_s...) are in the last section only
    facts = next(t for t in outline.tables if t["title"] == "Study")
    assert facts["section"] == "Provenance and settings"
    assert ["strict", "False"] in facts["rows"]


def _force_table(outline: _Outline) -> dict:
    return next(t for t in outline.tables if t["section"] == "Electrostatic force")


def test_the_force_table_leads_its_section_in_mN(page, out):
    _, outline = page
    first = _force_table(outline)
    assert "(mN)" in first["title"]
    assert first["headers"] == ["Subject", "Waveform", "Frequency", "80 V", "120 V", "160 V"]
    es = pd.read_csv(out / "electrostatic.csv", dtype={"subject": str})
    seen = 0
    for row in first["rows"]:
        subject, waveform, _, *cells = row
        for amp, cell in zip((80.0, 120.0, 160.0), cells, strict=True):
            hit = es[(es["subject"] == subject) & (es["waveform"] == waveform)
                     & (es["amplitude_V"] == amp)]
            if hit.empty:
                assert cell == "—"
                continue
            m = CELL.match(cell)
            assert m, cell
            value, low, high = (float(g) for g in m.groups())
            want = 1e3 * hit.iloc[0][["electrostatic_force_N", "electrostatic_force_ci_low_N",
                                      "electrostatic_force_ci_high_N"]].to_numpy(float)
            # three significant figures of the value; the bounds with its decimals
            assert value == pytest.approx(want[0], rel=5e-3)
            assert low <= value <= high
            assert (low, high) == pytest.approx(tuple(want[1:]), rel=1e-2, abs=0.5)
            seen += 1
    assert seen == len(es)


def test_air_gaps_in_micrometres(page, out):
    _, outline = page
    fit_table = next(t for t in outline.tables if t["title"] == "Model fit per subject")
    col = fit_table["headers"].index("air gap h_L (µm)")
    fit = pd.read_csv(out / "fit.csv", dtype={"subject": str}).set_index("subject")
    for row in fit_table["rows"]:
        value, low, high = (float(g) for g in CELL.match(row[col]).groups())
        assert value == pytest.approx(fit.loc[row[0], "value"] * 1e6, rel=5e-3)
        assert low < value < high
    r2 = fit_table["headers"].index("R²")
    assert all(row[r2] not in ("1", "1.0") for row in fit_table["rows"])
    params = next(t for t in outline.tables if "Model parameters" in t["title"])
    roles = {r[0]: r[2] for r in params["rows"]}
    assert roles["friction coefficient μ"].startswith("measured")
    assert roles["air gap h_L"].startswith("fitted")
    assert roles["effective modulus E*"] == "fixed: Table 1 of the paper"
    values = {r[0]: r[1] for r in params["rows"]}
    assert values["air-gap leakage r_g"] == "∞ Ω·m²"  # fit.json's null: no leakage
    assert roles["air-gap leakage r_g"].startswith("fixed: no leakage")


def test_no_number_in_scientific_notation(page):
    path, outline = page
    text = [t for t in outline.text if t.strip()]
    assert len(text) > 300
    found = [t for t in text if SCIENTIFIC.search(t)]
    assert not found, found[:5]
    assert SCIENTIFIC.search("air gap 3.0001e-06 m")  # the check does see one
    assert CITATION in path.read_text(encoding="utf-8").replace("&#34;", '"')


def test_each_trial_checked_in_details(page, out):
    _, outline = page
    trials = pd.read_csv(out / "trials.csv", dtype={"subject": str, "trial": str})
    checks = {(f["subject"], f["trial"]): f for f in
              json.loads((out / "fit.json").read_text(encoding="utf-8"))["figures"]
              if f["kind"] == "trial"}
    assert len(outline.details) == len(trials) == len(checks)
    for d, (_, t) in zip(outline.details, trials.iterrows(), strict=True):
        assert d["section"] == f"Subject {t['subject']}" and d["imgs"] == 1
        assert d["summary"].startswith(f"{t['trial']}: {t['waveform']}")
        assert f"{t['amplitude_V']:g} V" in d["summary"]
        # what the check's caption names as excluded is in the summary line
        caption = checks[(t["subject"], t["trial"])]["caption"]
        excluded = caption.split("excluded (hatched): ", 1)[1].rstrip(".")
        assert f"excluded: {excluded}" in d["summary"]
    by_trial = {d["summary"].split(":")[0] + d["section"]: d["summary"]
                for d in outline.details}
    assert by_trial["run-03Subject P01"].endswith(", 1 damaged line(s) skipped")
    assert by_trial["run-02Subject P02"].endswith(", 3 dropped frame(s)")
    assert "dropped" not in by_trial["run-01Subject P01"]


def test_model_comparison(page, out):
    _, outline = page
    models = pd.read_csv(out / "models.csv", dtype={"subject": str})
    tables = [t for t in outline.tables if t["section"] == "Model comparison"]
    assert [t["title"] for t in tables] == ["Models ranked over the study",
                                            "Models compared, P01", "Models compared, P02"]
    ranking, tables = tables[0], tables[1:]
    assert models["criterion"].eq("AICc").all()  # 3 points a subject: the small-sample AICc
    assert ranking["headers"][:4] == ["model", "summed AICc", "ΔAICc", "Akaike weight"]
    assert sorted(r[0] for r in ranking["rows"]) == sorted(set(models["model"]))
    for t in tables:
        mine = models[models["subject"] == t["title"].rsplit(" ", 1)[1]]
        assert t["headers"] == ["model", "fitted", "parameters", "AICc", "ΔAICc",
                                "Akaike weight", "verdict"]
        assert sorted(r[0] for r in t["rows"]) == sorted(mine["model"])
        for row in t["rows"]:
            m = mine[mine["model"] == row[0]].iloc[0]
            if math.isfinite(m["aic"]):
                assert float(row[3]) == pytest.approx(m["aic"], abs=0.05)
                assert float(row[4]) == pytest.approx(m["delta_aic"], abs=0.05)
            else:  # not defined: shown as absent, and the caption says why
                assert row[3] == row[4] == row[5] == "—"
            assert "µm" in row[1] and not SCIENTIFIC.search(row[1])
            bound = str(m["at_bound"]) if isinstance(m["at_bound"], str) else ""
            for name in filter(None, bound.split(";")):  # at its bound, not as fitted
                assert f"{name} at its bound" in row[1]
        ranked = [float(r[3]) for r in t["rows"] if r[3] != "—"]
        assert ranked == sorted(ranked)  # best first
    # one drive frequency: no figure of F_el against the frequency
    assert not any(f.startswith("Electrostatic force vs drive frequency")
                   for f in outline.text)


def test_figure_files_embedded_or_linked(tmp_path):
    import matplotlib.pyplot as plt

    from evtribo.report.page import Report

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    (tmp_path / "figures").mkdir()
    for fmt in ("svg", "pdf"):
        fig.savefig(tmp_path / "figures" / f"f.{fmt}")
    plt.close(fig)
    report = Report("t")
    report.add_figure(tmp_path / "figures" / "f.svg", "as SVG")
    report.add_figure(tmp_path / "figures" / "f.pdf", "as PDF")
    html = report.render(base=tmp_path)
    assert 'src="data:image/svg+xml;base64,' in html
    assert '<a href="figures/f.pdf">as PDF (PDF)</a>' in html


def _md_rows(text: str) -> list[list[str]]:
    lines = [ln for ln in text.splitlines() if ln.startswith("|")]
    return [[c.strip() for c in ln.strip("|").split("|")] for ln in lines
            if not set(ln) <= set("|-: ")]


def test_tables_exported_as_markdown_and_latex(page, out):
    _, outline = page
    html_tables = {"electrostatic_force": _force_table(outline),
                   "fit": next(t for t in outline.tables
                               if t["title"] == "Model fit per subject")}
    for stem, table in html_tables.items():
        md = (out / "tables" / f"{stem}.md").read_text(encoding="utf-8")
        assert _md_rows(md) == [table["headers"], *table["rows"]]
        tex = (out / "tables" / f"{stem}.tex").read_text(encoding="utf-8").splitlines()
        rules = [tex.index(r) for r in (r"\toprule", r"\midrule", r"\bottomrule")]
        assert rules == sorted(rules) and rules[1] - rules[0] == 2
        body = tex[rules[1] + 1:rules[2]]
        assert len(body) == len(table["rows"])
        for line, row in zip(body, table["rows"], strict=True):
            assert line.endswith(r"\\") and line.count(" & ") == len(row) - 1
            for cell in row:  # the same numbers as the page
                for number in re.findall(r"\d+(?:\.\d+)?", cell):
                    assert number in line
    fit_tex = (out / "tables" / "fit.tex").read_text(encoding="utf-8")
    assert r"air gap h\_L (\textmu{}m)" in fit_tex  # units in plain LaTeX
    assert "doi:10.3390/lubricants7120102" in fit_tex


def test_tables_are_files_of_the_report(page, out, tmp_path):
    assert {"tables/fit.md", "tables/fit.tex", "tables/electrostatic_force.md",
            "tables/electrostatic_force.tex"} <= set(report_files(out))
    # refused without --force; a new report without --tables takes the old tables away
    assert main(["report", str(out), "--tables", "md"]) == 2
    assert (out / "tables" / "fit.tex").is_file()
    assert main(["report", str(out), "--force"]) == 0
    assert not (out / "tables").exists() or not any((out / "tables").iterdir())
    assert main(["report", str(out), "--force", "--tables", "md,tex"]) == 0
    # a report elsewhere: its tables beside it
    path = build_report(out, tmp_path / "r.html", tables="tex")
    assert sorted(p.name for p in (tmp_path / "tables").iterdir()) == [
        "electrostatic_force.tex", "fit.tex"]
    assert path.is_file()


def test_analyze_force_replaces_the_tables(tmp_path):
    study, folder = analysed_study(tmp_path)
    compare(folder, dpi=30)
    (folder / "tables").mkdir()
    (folder / "tables" / "notes.md").write_text("mine\n", encoding="utf-8")  # not ours
    assert main(["report", str(folder), "--tables", "md,tex"]) == 0
    assert len(list((folder / "tables").iterdir())) == 5
    assert main(["analyze", str(study), "--out", str(folder), "--jobs", "1"]) == 2
    assert (folder / "tables" / "fit.md").is_file()
    assert main(["analyze", str(study), "--out", str(folder), "--jobs", "1", "--force"]) == 0
    assert [p.name for p in (folder / "tables").iterdir()] == ["notes.md"]
    assert not (folder / "report.html").exists()


def test_no_model_comparison_without_models(tmp_path):
    _, folder = analysed_study(tmp_path)
    compare(folder, dpi=30, trial_checks=False)
    outline = _outline(build_report(folder, tmp_path / "r.html"))
    assert outline.sections == ["Key results", "Warnings", "Electrostatic force", "Model fit",
                                "Population", "All subjects", "Model predictions",
                                "Subject P01", "Subject P02", "Provenance and settings"]
    assert not outline.details  # no checks drawn, none folded


@pytest.mark.parametrize("fmt", ["png", "svg"])
def test_figure_shown_at_twice_its_printed_width(tmp_path, fmt):
    import matplotlib.pyplot as plt

    from evtribo.report.page import SCREEN_SCALE, Report

    fig, ax = plt.subplots(figsize=(85 / 25.4, 2.0))  # a journal's single column
    ax.plot([0, 1], [0, 1])
    fig.savefig(tmp_path / f"f.{fmt}", dpi=300)
    plt.close(fig)
    report = Report("t")
    report.add_figure(tmp_path / f"f.{fmt}", "f")
    shown = int(re.search(r'<img [^>]*width="(\d+)"', report.render()).group(1))
    assert abs(shown - 96 * SCREEN_SCALE * 85 / 25.4) <= 1  # 643 px, to a pixel's rounding


#: A number with a decimal point, not inside a version, a date, a name or a hash.
DECIMAL = re.compile(r"(?<![\w.:/-])-?(\d+)\.(\d+)(?![\w.])")
#: A value and its interval: ``26.5 [25.7, 27.4]``, ``72 [-398, 541]``.
INTERVAL = re.compile(r"(-?\d+(?:\.\d+)?) \[(-?\d+(?:\.\d+)?), (-?\d+(?:\.\d+)?)\]")


def test_no_number_over_long_and_intervals_with_one_precision(page):
    """Over the whole page's text: no number with more than four significant figures or
    eight decimals (an RMSE of 5.55e-14 mN is '< 0.000001', not its sixteen decimals),
    and in every value [interval] the three numbers have the same decimals."""
    _, outline = page
    text = " ".join(outline.text)
    numbers = DECIMAL.findall(text)
    assert len(numbers) > 100
    long = [f"{w}.{f}" for w, f in numbers if len(f) > 8 or len((w + f).lstrip("0")) > 4]
    assert not long, long[:10]
    intervals = INTERVAL.findall(text)
    assert len(intervals) > 10
    for triple in intervals:
        places = {len(x.partition(".")[2]) for x in triple}
        assert len(places) == 1, triple
    assert DECIMAL.findall("RMSE 0.0000000000000555 mN") == [("0", "0000000000000555")]


def test_the_comparison_s_warnings_are_among_the_warnings_and_settings_as_given(page, out):
    """fit.json's warnings are said with the analysis's, each kind once (counted in
    fit.json), none apart under the fit."""
    path, outline = page
    html = path.read_text(encoding="utf-8")
    sections = {part.split("</h2>", 1)[0].split(">")[-1]: part for part in html.split("<h2")}
    said = json.loads((out / "fit.json").read_text(encoding="utf-8"))["warnings"]
    assert said
    from markupsafe import escape

    from evtribo.warning.catalogue import KINDS
    for kind in {w["kind"] for w in said}:
        title = str(escape(KINDS[kind].title))
        assert sections["Warnings"].count(f"{title}</b>") == 1, kind
        assert title not in sections["Model fit"], kind
    assert sections["Warnings"].count("in fit.json)") == len({w["kind"] for w in said})
    settings = next(t for t in outline.tables if t["title"] == "Analysis settings")
    values = dict(settings["rows"])
    assert values["guard_s"] == "0.15" and values["confidence"] == "0.95"
