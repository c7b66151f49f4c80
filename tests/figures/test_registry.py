"""Every figure is declared once, in the figure registry: compare draws what it declares, the
report places each figure where its spec says, the Python API draws the same figures, and a
lab's figure registered from outside the package (from a test module, and through an entry
point of a temporary ``*.dist-info``) is drawn by compare, placed by the report (by its
fit.json record when the plug-in is not there) and returned by the API."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

import evtribo
from _plugins import install
from analysed import analysed_study
from evtribo.figures.plots import new_axes
from evtribo.figures.registry import (
    FIGURES,
    Drawing,
    FigureContext,
    FigureSpec,
    catalogue,
    placement,
    planned,
    register,
    stems,
)
from evtribo.figures.registry.builtin import BUILTIN
from evtribo.figures.trial_checks import CheckFigure
from evtribo.fit.tables import read_results
from evtribo.report.compare import compare
from evtribo.report.study_report import build_report
from evtribo.results import outputs
from evtribo.util import plugins


def plot_press(windows: pd.DataFrame, *, subject: str = "", ax=None):
    """A lab's own figure: each window's friction against its normal force."""
    ax = new_axes() if ax is None else ax
    ax.plot(windows["normal_force_N"], windows["friction_force_N"], "o", ms=2)
    ax.set(xlabel="normal force (N)", ylabel="friction (N)")
    return ax


def _press(ctx: FigureContext, subject: str) -> Drawing:
    windows = ctx.tables.windows
    return Drawing(plot_press, (windows[windows["subject"].astype(str) == subject],),
                   {"subject": subject})


#: The lab's figure, placed among all subjects' figures although it is one subject's.
PRESS = FigureSpec("mylab_press", "mylab_press_{subject}", "The press of {subject}",
                   "{subject}: every window's friction against its normal force.", "all",
                   "subject", _press, needs="fits")

PLUGIN = '''
from evtribo.figures.plots import new_axes
from evtribo.figures.registry import Drawing, FigureSpec


def plot_count(windows, *, ax=None):
    ax = new_axes() if ax is None else ax
    ax.bar(range(len(windows)), windows["friction_force_N"])
    return ax


def _count(ctx, item):
    return Drawing(plot_count, (ctx.tables.windows,))


SPECS = [FigureSpec("mylab_windows", "mylab_windows", "Every window of the study",
                    "Each window's friction, in the order of windows.csv.", "models", "study",
                    _count, needs="population")]
'''


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """The analysed study's result folder and the cache folder its analysis used."""
    study, out = analysed_study(tmp_path_factory.mktemp("registry"))
    return out, study.parent / "cache"


@pytest.fixture
def fresh(monkeypatch):
    """The registry as it is, put back after the test (the plug-ins not yet read)."""
    monkeypatch.setattr(catalogue, "_SPECS", dict(catalogue._SPECS))
    monkeypatch.setattr(catalogue, "_read", {"plugins": False})
    plugins.forget()
    yield
    plugins.forget()


def _copy(analysed, base: Path) -> tuple[Path, Path]:
    out, cache = analysed
    return shutil.copytree(out, base / "out"), shutil.copytree(cache, base / "cache")


def _section_of(html: str, title: str) -> str:
    """The title of the report's section that shows the figure of this title."""
    at = html.index(f"</span> {title}</h3>")
    return re.findall(r"<h2>([^<]*)</h2>", html[:at])[-1]


def _records(out: Path) -> dict[str, dict]:
    return {f["stem"]: f for f in json.loads((out / "fit.json").read_text())["figures"]}


def test_the_figures_compare_draws_are_the_registry_s_and_the_report_places_each_by_it(
        analysed, tmp_path):
    out, cache = _copy(analysed, tmp_path)
    compare(out, dpi=30, formats="png", jobs=1, cache_dir=cache, models="paper,hertz")
    records = _records(out)
    assert {r["kind"] for r in records.values()} <= set(FIGURES)
    for stem, r in records.items():
        spec = FIGURES[r["kind"]]
        assert (r["section"], r["per"]) == (spec.section, spec.per), stem
        assert ("grid" in r) == (spec.grid is not None)
        assert (out / "figures" / f"{stem}.png").is_file()
    assert "trial_P01_run-01" in records and "population_square_10000Hz" not in records
    build_report(out, out / "report.html")
    html = (out / "report.html").read_text(encoding="utf-8")
    where = {"all": "All subjects", "predictions": "Model predictions",
             "models": "Model comparison"}
    for r in records.values():
        section = where.get(r["section"], f"Subject {r['subject']}")
        assert _section_of(html, r["title"]) == section, r["stem"]


def test_the_api_draws_what_compare_draws(analysed, tmp_path):
    out, cache = _copy(analysed, tmp_path)
    results = evtribo.load_results(out)
    fit = evtribo.compare(results, models="paper,hertz")
    compare(out, dpi=30, formats="png", jobs=1, cache_dir=cache, models="paper,hertz")
    written = json.loads((out / "fit.json").read_text())
    assert list(fit.figures) == [f["stem"] for f in written["figures"]]
    assert [r["kind"] for r in fit.records] == [f["kind"] for f in written["figures"]]
    assert sum(r["kind"] == "trial" for r in fit.records) == len(results.trials)
    # the models compared and ranked, as models.csv holds them
    on_disk = pd.read_csv(out / "models.csv")
    assert list(fit.models["model"]) == list(on_disk["model"])
    assert fit.models["aic"].to_numpy() == pytest.approx(on_disk["aic"].to_numpy(),
                                                         nan_ok=True)
    assert any(n.kind == "models-ranked" for n in fit.notes)
    said = [(n.kind, n.effect, n.text) for n in fit.notes]
    assert said == [(w["kind"], w["effect"], w["text"]) for w in written["warnings"]]
    assert [n.text for n in fit.notes] == written["notes"]
    loaded = evtribo.load_results(out).fit  # the same tables, read from the folder
    pd.testing.assert_frame_equal(loaded.models, fit.models)
    assert [(n.kind, n.effect, n.text) for n in loaded.notes] == said


def test_a_figure_registered_from_a_test_module(analysed, tmp_path, fresh):
    register(PRESS)
    with pytest.raises(ValueError, match="'mylab_press' is registered already"):
        register(PRESS)
    out, cache = _copy(analysed, tmp_path)
    compare(out, dpi=30, formats="png", jobs=1, cache_dir=cache)
    records = _records(out)
    assert (records["mylab_press_P01"]["section"], records["mylab_press_P01"]["per"]) == (
        "all", "subject")
    assert (out / "figures" / "mylab_press_P02.png").is_file()
    build_report(out, out / "report.html")
    html = (out / "report.html").read_text(encoding="utf-8")
    assert _section_of(html, "The press of P01") == "All subjects"
    fit = evtribo.compare(evtribo.load_results(out))
    assert {"mylab_press_P01", "mylab_press_P02"} <= set(fit.figures)


def test_a_figure_from_a_plug_in_s_entry_point(analysed, tmp_path, monkeypatch, fresh):
    install(tmp_path, monkeypatch, "mylab_figures", PLUGIN,
            entry_points={"evtribo.figures": {"windows": "mylab_figures:SPECS"}})
    assert "mylab_windows" in FIGURES
    out, cache = _copy(analysed, tmp_path)
    compare(out, dpi=30, formats="png", jobs=2, cache_dir=cache)  # drawn by the workers
    record = _records(out)["mylab_windows"]
    assert (record["kind"], record["section"], record["per"]) == ("mylab_windows", "models",
                                                                 "study")
    assert (out / "figures" / "mylab_windows.png").is_file()
    build_report(out, out / "report.html")
    assert _section_of((out / "report.html").read_text(encoding="utf-8"),
                       "Every window of the study") == "Model comparison"
    fit = evtribo.compare(evtribo.load_results(out))
    assert "mylab_windows" in fit.figures

    # where the plug-in is not installed, the report places it by its record
    del catalogue._SPECS["mylab_windows"]
    assert "mylab_windows" not in FIGURES
    build_report(out, out / "report.html", force=True)
    assert _section_of((out / "report.html").read_text(encoding="utf-8"),
                       "Every window of the study") == "Model comparison"


def test_a_plug_in_of_a_builtin_kind_is_skipped(tmp_path, monkeypatch, fresh, caplog):
    source = PLUGIN.replace('"mylab_windows", "mylab_windows"', '"population", "population"')
    install(tmp_path, monkeypatch, "mylab_twice", source,
            entry_points={"evtribo.figures": {"twice": "mylab_twice:SPECS"}})
    assert FIGURES["population"] is next(s for s in BUILTIN if s.kind == "population")
    assert "'population' is registered already" in caplog.text


def test_a_spec_names_a_section_a_per_and_a_stage_there_are():
    with pytest.raises(ValueError, match="section 'appendix'"):
        FigureSpec("x", "x", "x", "x", "appendix", "study", _press)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="subject's section"):
        FigureSpec("x", "x", "x", "x", "subject", "study", _press)


names = st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")),
                min_size=1, max_size=12)


@given(subject=names, trial=names, wave=st.sampled_from(["square", "sine", ""]),
       freq=st.one_of(st.just(math.nan), st.floats(0.1, 1e6)))
def test_every_builtin_stem_is_a_name_compare_owns(subject, trial, wave, freq):
    """Whatever the names, each builtin figure's files are among those analyze --force
    removes as compare's (results/outputs.py names them without the registry)."""
    items = {"study": None, "subject": subject, "condition": (wave, freq),
             "trial": CheckFigure(subject, trial, "")}
    for spec in BUILTIN:
        stem = catalogue._fields(spec.per, items[spec.per])[0]
        name = spec.stem.format(**stem)
        assert "/" not in name
        for fmt in ("png", "svg", "pdf"):
            assert outputs._FIGURE.match(f"{name}.{fmt}"), name


def test_a_record_the_registry_does_not_know_is_placed_by_itself_or_its_subject():
    assert placement({"kind": "gone", "subject": None, "section": "models",
                      "per": "study"}).section == "models"
    assert placement({"kind": "gone", "subject": "P01", "section": "all", "per": "subject",
                      "grid": ["Each", "Caption"]}).grid == ("Each", "Caption")
    # fit.json of an earlier compare: no section said
    assert placement({"stem": "x", "subject": None}).section == "all"
    assert placement({"kind": "gone", "subject": "P01"}).section == "subject"
    assert placement({"kind": "area_increase", "subject": None,
                      "section": "all"}).section == "predictions"  # the spec's, here


def test_the_files_compare_writes_are_named_before_anything_is_drawn(analysed):
    out, _ = analysed
    tables = read_results(out)
    known = stems(FigureContext(tables, models=("paper", "circuit")))
    assert known[:2] == ["electrostatic_force_all", "electrostatic_force_P01"]
    assert "area_increase" in known and "friction_normal_force_P02" in known
    assert not [s for s in known if s.startswith(("trial_", "population_"))]  # not yet known
    assert planned(FigureContext(tables), "fits") == []  # nothing fitted yet
