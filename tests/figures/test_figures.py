"""The figures compare writes are ready for a journal: each PDF one page of the column's
width, each SVG with its text as text, each PNG at 300 dpi and not blank, a tick at each
measured amplitude, no title, legends that cover no data, forces in mN."""

from __future__ import annotations

import itertools
import json
import re
import struct
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.image import imread

from evtribo.cli import main
from evtribo.errors import UserInputError
from evtribo.figures.layout import legend_overlap
from evtribo.figures.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_electrostatic_force_all,
    plot_friction_normal_force,
    plot_friction_time,
)
from evtribo.figures.style import (
    journal_style,
    parse_dpi,
    parse_figure_formats,
    parse_figure_width,
)
from evtribo.fit.tables import read_results
from evtribo.model import TABLE_1
from evtribo.report.compare import compare
from synthetic import AMPLITUDES, TRUE_H_L, make_out

MM_PT = 72.0 / 25.4
FORMATS = ("pdf", "svg", "png")
#: The amplitudes of the sine rows added to the synthetic results (V).
SINE_AMPLITUDES = (100.0, 140.0)


def _add_sine_rows(folder: Path) -> None:
    """Sine-drive rows for P01 in electrostatic.csv (two waveforms in one study)."""
    path = folder / "electrostatic.csv"
    elec = pd.read_csv(path)
    rows = elec[(elec["subject"] == "P01")
                & elec["amplitude_V"].isin(SINE_AMPLITUDES)].copy()
    rows["waveform"] = "sine"
    for col in ("electrostatic_force_N", "electrostatic_force_ci_low_N",
                "electrostatic_force_ci_high_N"):
        rows[col] = rows[col] / 2.0  # a sine's mean U^2 is half a square's
    pd.concat([elec, rows]).to_csv(path, index=False)


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A result folder compared with every format at the default resolution."""
    folder = make_out(tmp_path_factory.mktemp("figs") / "out", bootstrap=False)
    _add_sine_rows(folder)
    compare(folder, formats="pdf,svg,png")
    return folder


def _records(folder: Path) -> list[dict[str, object]]:
    return json.loads((folder / "fit.json").read_text(encoding="utf-8"))["figures"]


def _stems(folder: Path) -> list[str]:
    return [str(r["stem"]) for r in _records(folder)]


def test_one_file_per_figure_and_format(written):
    records = _records(written)
    assert records[0]["kind"] == "electrostatic_force_all"
    assert records[0]["stem"] == "electrostatic_force_all" and records[0]["subject"] is None
    assert {r["kind"] for r in records} == {"electrostatic_force_all", "electrostatic_force",
                                            "friction_normal_force", "friction_time",
                                            "area_increase"}
    files = sorted(p.name for p in (written / "figures").iterdir())
    assert files == sorted(f"{s}.{fmt}" for s in _stems(written) for fmt in FORMATS)
    # fit.json records every file it wrote, and only those
    listed = json.loads((written / "fit.json").read_text())["output_sha256"]
    assert sorted(k for k in listed if k.startswith("figures/")) == [
        f"figures/{f}" for f in files]


def _pdf_pages(data: bytes) -> int:
    return len(re.findall(rb"/Type\s*/Page(?![a-z])", data))


def test_each_pdf_is_one_page_a_column_wide(written):
    for stem in _stems(written):
        data = (written / "figures" / f"{stem}.pdf").read_bytes()
        assert data.startswith(b"%PDF")
        assert _pdf_pages(data) == 1, stem
        box = re.search(rb"/MediaBox\s*\[\s*0 0 ([\d.]+) ([\d.]+)", data)
        assert box is not None
        assert float(box.group(1)) == pytest.approx(85 * MM_PT, abs=0.5), stem
        assert b"/FontFile2" in data, "a TrueType font embedded (Type 42), not Type 3"


def test_the_page_counter_counts_pages():
    two = b"<< /Type /Pages /Count 2 >> << /Type /Page >> << /Type/Page >>"
    assert _pdf_pages(two) == 2


def test_each_svg_has_its_text_as_text(written):
    for stem in _stems(written):
        svg = (written / "figures" / f"{stem}.svg").read_text(encoding="utf-8")
        assert "<text" in svg, stem
        assert 'id="DejaVuSans-' not in svg, f"{stem}: glyphs drawn as paths"


def _png_dpi(path: Path) -> tuple[float, float]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos = 8
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        if kind == b"pHYs":
            x, y, unit = struct.unpack(">IIB", data[pos + 8:pos + 17])
            assert unit == 1, "pixels per metre"
            return x * 0.0254, y * 0.0254
        if kind == b"IDAT":
            break  # pHYs comes before the image data
        pos += 12 + length
    raise AssertionError(f"{path.name}: no pHYs chunk")


def test_each_png_is_300_dpi_and_not_blank(written):
    for stem in _stems(written):
        path = written / "figures" / f"{stem}.png"
        dx, dy = _png_dpi(path)
        assert round(dx) == round(dy) == 300, stem
        img = imread(path)
        assert img.shape[1] == pytest.approx(85 / 25.4 * 300, abs=2), stem
        assert float(np.var(img[..., :3])) > 1e-3, f"{stem} is blank"


def _svg_xtick_labels(svg: str) -> list[str]:
    """The texts of the x-axis tick labels of an SVG matplotlib wrote (text as text)."""
    labels = []
    for block in re.split(r'<g id="xtick_\d+">', svg)[1:]:
        m = re.search(r"<text[^>]*>([^<]*)</text>", block)
        if m:
            labels.append(m.group(1))
    return labels


def test_voltage_axis_has_a_plain_tick_at_each_amplitude(written):
    amps = sorted(set(AMPLITUDES) | set(SINE_AMPLITUDES))
    voltage_axes = [s for s in _stems(written)
                    if s.startswith("electrostatic_force") or s == "area_increase"]
    assert len(voltage_axes) == 4
    for stem in voltage_axes:
        labels = _svg_xtick_labels(
            (written / "figures" / f"{stem}.svg").read_text(encoding="utf-8"))
        for a in amps:
            assert f"{a:g}" in labels, (stem, labels)
        assert all(re.fullmatch(r"\d+", t) for t in labels if t), (stem, labels)


def test_the_svg_tick_reader_sees_labels():
    svg = ('<g id="xtick_1"><g><text x="1">60</text></g></g>'
           '<g id="xtick_2"><text>1.4\u00d710\u00b2</text></g>')
    assert _svg_xtick_labels(svg) == ["60", "1.4\u00d710\u00b2"]


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    folder = make_out(tmp_path_factory.mktemp("tab") / "out", bootstrap=False)
    _add_sine_rows(folder)
    return read_results(folder)


def _params() -> dict[str, object]:
    return {s: TABLE_1.with_values(h_L=h) for s, h in TRUE_H_L.items()}


def _all_axes(tables):
    elec, win = tables.electrostatic, tables.windows
    p01 = TABLE_1.with_values(h_L=TRUE_H_L["P01"])
    fn = dict.fromkeys(TRUE_H_L, 0.5)
    return {
        "all": plot_electrostatic_force_all(elec, _params()),
        "fel": plot_electrostatic_force(elec[elec["subject"] == "P01"], p01),
        "ffn": plot_friction_normal_force(win[win["subject"] == "P01"], p01),
        "ft": plot_friction_time(tables.sine_trace, p01),
        "ft_model": plot_friction_time(None, p01),
        "area": plot_area_increase(fn, _params(), amplitudes=AMPLITUDES),
    }


def test_plots_have_no_title_mN_forces_and_free_legends(tables):
    for name, ax in _all_axes(tables).items():
        fig = ax.figure
        fig.canvas.draw()
        assert ax.get_title() == "", name
        assert fig.get_figwidth() == pytest.approx(85 / 25.4), name
        if name != "area":
            assert "(mN)" in ax.get_ylabel(), name
        legend = ax.get_legend()
        assert legend is not None, name
        assert legend_overlap(ax) == 0, name
        # independently: no marker centre under the legend's box
        box = legend.get_window_extent()
        for line in ax.lines:
            if line.get_marker() in (None, "None", ""):
                continue
            xy = ax.transData.transform(np.asarray(line.get_xydata(), float))
            inside = ((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1)
                      & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1))
            assert not inside.any(), name


def test_legend_overlap_sees_a_covered_point():
    from evtribo.figures.plots import new_axes

    with journal_style():
        ax = new_axes()
        ax.plot([0.0, 1.0], [0.0, 1.0], "o-", label="data")
        ax.legend(loc="center")  # on top of the line through the middle
        ax.figure.canvas.draw()
        assert legend_overlap(ax) > 0


def test_ticks_from_the_axes(tables):
    elec = tables.electrostatic
    for ax in (plot_electrostatic_force_all(elec, _params()),
               plot_electrostatic_force(elec[elec["subject"] == "P01"], TABLE_1)):
        ax.figure.canvas.draw()
        locs = ax.xaxis.get_majorticklocs()
        labels = [t.get_text() for t in ax.xaxis.get_majorticklabels()]
        for a in set(AMPLITUDES) | set(SINE_AMPLITUDES):
            assert a in locs
            assert f"{a:g}" in labels
        assert not any(t.get_text() for t in ax.xaxis.get_minorticklabels())
        ylabels = [t.get_text() for t in ax.yaxis.get_majorticklabels() if t.get_text()]
        assert ylabels and all(re.fullmatch(r"[\d.]+", t) for t in ylabels), ylabels


def test_all_subjects_figure_draws_each_subject_in_mN(tables):
    elec = tables.electrostatic
    ax = plot_electrostatic_force_all(elec, _params())
    colours = {}
    for container in ax.containers:
        line = container.lines[0]
        x, y = (np.asarray(v, float) for v in line.get_data())
        colours[line.get_color()] = line.get_marker()
        # the points are the table's forces in mN, at their amplitudes (spread <= 3 %)
        match = elec[np.isclose(elec["electrostatic_force_N"].to_numpy() * 1e3, y[0])]
        assert len(match) == 1
        assert x[0] == pytest.approx(match["amplitude_V"].item(), rel=0.031)
    # P01 square and sine, P02 square: three groups, two subjects' styles
    assert len(ax.containers) == 3
    assert len(colours) == 2 and len(set(colours.values())) == 2
    curves = [ln for ln in ax.lines if ln.get_marker() in ("None", None, "")
              and len(ln.get_xdata()) > 10]
    assert len(curves) == 3  # one model curve per subject and waveform
    labels = sorted(t.get_text() for t in ax.get_legend().get_texts())
    assert labels == ["P01, sine", "P01, square", "P02, square"]  # one entry per line


def test_drawing_on_a_given_axes_keeps_the_callers_style(tables):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.0, 3.0))
    ax = fig.add_subplot()
    out = plot_electrostatic_force_all(tables.electrostatic, _params(), ax=ax)
    assert out is ax and fig.get_figwidth() == 4.0


def test_the_style_is_not_global(tables):
    before = {k: mpl.rcParams[k] for k in ("svg.fonttype", "pdf.fonttype", "font.size",
                                           "figure.figsize")}
    plot_electrostatic_force_all(tables.electrostatic, _params())
    with journal_style("double"):
        assert mpl.rcParams["svg.fonttype"] == "none"
    assert {k: mpl.rcParams[k] for k in before} == before


def test_double_width_and_pdf_only_from_the_command_line(tmp_path, capsys):
    folder = make_out(tmp_path / "out", bootstrap=False, sine_trace=False)
    assert main(["compare", str(folder), "--figure-format", "pdf",
                 "--figure-width", "double"]) == 0
    files = sorted(p.name for p in (folder / "figures").iterdir())
    assert files and all(f.endswith(".pdf") for f in files)
    data = (folder / "figures" / "electrostatic_force_all.pdf").read_bytes()
    box = re.search(rb"/MediaBox\s*\[\s*0 0 ([\d.]+)", data)
    assert box is not None and float(box.group(1)) == pytest.approx(175 * MM_PT, abs=0.5)


def test_formats_are_checked():
    assert parse_figure_formats(None) == ("svg", "png")
    assert parse_figure_formats("PDF, png,pdf") == ("pdf", "png")
    with pytest.raises(UserInputError, match="unknown figure format 'jpg'; known: pdf, svg"):
        parse_figure_formats("png,jpg")
    with pytest.raises(UserInputError, match="no figure format"):
        parse_figure_formats(" , ")
    assert parse_dpi(None) == 300.0 and parse_dpi(72) == 72.0
    for bad in (0, -300, float("nan"), float("inf"), "many"):
        with pytest.raises(UserInputError, match="key 'dpi'"):
            parse_dpi(bad)
    with pytest.raises(UserInputError, match="unknown figure width 'triple'"):
        parse_figure_width("triple")


def test_help_cites_the_paper(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "Voltage-Induced Friction with Application to Electrovibration" in out
    assert "Lubricants 2019, 7(12), 102" in out and "doi:10.3390/lubricants7120102" in out


def test_dense_amplitudes_keep_every_tick_and_labels_apart():
    amps = np.arange(20.0, 201.0, 10.0)
    rows = pd.DataFrame({"subject": "P01", "waveform": "square", "amplitude_V": amps,
                         "normal_force_on_N": 0.5, "electrostatic_force_N": 1e-5 * amps ** 2,
                         "electrostatic_force_ci_low_N": 0.9e-5 * amps ** 2,
                         "electrostatic_force_ci_high_N": 1.1e-5 * amps ** 2})
    ax = plot_electrostatic_force(rows, TABLE_1)
    ax.figure.canvas.draw()
    assert list(ax.xaxis.get_majorticklocs()) == list(amps)
    shown = [t for t in ax.xaxis.get_majorticklabels() if t.get_text()]
    assert shown[-1].get_text() == "200" and shown[0].get_text() == "20"
    assert 5 <= len(shown) < len(amps)  # some left out: 19 labels do not fit 85 mm
    boxes = [t.get_window_extent() for t in shown]
    for a, b in itertools.pairwise(boxes):
        assert a.x1 < b.x0, "two tick labels overlap"


def test_many_drives_get_a_colour_bar_not_a_long_legend():
    amps = (40.0, 60.0, 80.0, 100.0, 120.0, 140.0, 160.0)
    rows = [{"condition": "on", "waveform": w, "amplitude_V": a, "normal_force_N": 0.5,
             "friction_force_N": 0.25 + 1e-6 * a ** 2} for w in ("square", "sine")
            for a in amps]
    rows.append({"condition": "off", "waveform": "square", "amplitude_V": 0.0,
                 "normal_force_N": 0.5, "friction_force_N": 0.25})
    ax = plot_friction_normal_force(pd.DataFrame(rows), TABLE_1)
    labels = {t.get_text() for t in ax.get_legend().get_texts()}
    # the points apart from the model's lines (one style per waveform, in each drive's colour)
    assert labels == {"OFF ($\\mu$ = 0.500)", "ON, square", "ON, sine", "model, OFF",
                      "model, ON square", "model, ON sine"}
    (bar,) = [a for a in ax.figure.axes if a is not ax]
    assert list(bar.yaxis.get_majorticklocs()) == list(amps)
    assert "(V)" in bar.get_ylabel()
    # a few drives: one entry each
    few = plot_friction_normal_force(pd.DataFrame(rows[:3] + rows[-1:]), TABLE_1)
    assert {t.get_text() for t in few.get_legend().get_texts()} == {
        "OFF ($\\mu$ = 0.500)", "ON 40 V", "ON 60 V", "ON 80 V", "model, OFF",
        "model, ON"}
    assert len(few.figure.axes) == 1


def test_a_leaky_fit_draws_the_model_at_each_drive_frequency():
    # with a finite r_g the force depends on the frequency (spec §9): the F_el figure's model
    # curves are the model at each frequency of the points, not the paper's (H = 1) alone
    import numpy as np
    import pandas as pd

    from evtribo.figures.electrostatic_plots import plot_electrostatic_force
    from evtribo.fit.model_points import mean_electrostatic_force
    from evtribo.model.params import TABLE_1

    rows = pd.DataFrame({
        "subject": "P01", "waveform": "square", "frequency_Hz": [20.0, 20.0, 1e4, 1e4],
        "amplitude_V": [80.0, 140.0, 80.0, 140.0], "normal_force_on_N": 0.5,
        "electrostatic_force_N": [0.02, 0.06, 0.06, 0.19],
        "electrostatic_force_ci_low_N": [0.018, 0.055, 0.055, 0.18],
        "electrostatic_force_ci_high_N": [0.022, 0.065, 0.065, 0.2]})

    def model_lines(params):
        ax = plot_electrostatic_force(rows, params, subject="P01")
        return [ln for ln in ax.get_lines()
                if len(ln.get_xdata()) == 80 and ln.get_linestyle() != ":"]

    leaky = TABLE_1.with_values({"r_g": 80.0})
    lines = model_lines(leaky)
    assert len(lines) == 2
    for ln, f in zip(lines, (20.0, 1e4), strict=True):
        grid = np.asarray(ln.get_xdata(), float)
        expected = 1e3 * mean_electrostatic_force(0.5, grid, "square", leaky, frequency=f)
        np.testing.assert_allclose(np.asarray(ln.get_ydata(), float), expected, rtol=1e-12)
    assert np.all(np.asarray(lines[0].get_ydata()) < np.asarray(lines[1].get_ydata()))
    assert len(model_lines(TABLE_1)) == 1  # no leak: one curve, the paper's


def test_every_format_of_a_figure_is_drawn_from_one_layout(monkeypatch):
    """figure_bytes lays a figure out once and draws each format from that layout: the
    constrained layout runs once however many formats are asked (not again for the second
    format, which savefig's own handling of the layout engine would bring back)."""
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from evtribo.figures.plots import figure_bytes
    from evtribo.figures.style import new_axes

    runs = []
    execute = ConstrainedLayoutEngine.execute
    monkeypatch.setattr(ConstrainedLayoutEngine, "execute",
                        lambda self, fig: (runs.append(fig.dpi), execute(self, fig))[1])
    with journal_style("single"):
        ax = new_axes()
        fig = ax.figure
        shown = fig.dpi
        ax.plot([1, 2, 3], [2, 1, 3], label="a line")
        ax.set_xlabel("normal force $F_n$ (mN)")
        runs.clear()
        out = figure_bytes(fig, ("svg", "png", "pdf"), dpi=50)
    assert sorted(out) == ["pdf", "png", "svg"] and all(out.values())
    # once, at the PNG's resolution (whose drawing then measures no text again), and the
    # figure keeps the resolution it is shown at
    assert runs == [50.0]
    assert fig.dpi == shown != 50.0
    assert fig.get_layout_engine() is None


@settings(max_examples=25)
@given(entries=st.integers(1, 12), chars=st.integers(1, 30), ncol=st.integers(1, 4),
       height=st.floats(1.5, 4.0))
def test_a_legend_above_keeps_the_axes_and_fits_the_figure(entries, chars, ncol, height):
    """place_legend puts a legend above the Axes of a figure of new_axes and grows the
    figure by what the legend needs: the Axes keep their size and their place from the
    bottom, in inches, as the layout left them, and the legend lies inside the figure. That
    layout is then fixed (nothing to lay out again when the formats are drawn); a legend
    wider than the figure leaves the layout engine, which narrows the Axes to make room."""
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from evtribo.figures.layout import place_legend
    from evtribo.figures.plots import figure_bytes
    from evtribo.figures.style import new_axes

    runs = []
    execute = ConstrainedLayoutEngine.execute

    def counted(self, fig):
        runs.append(fig)
        return execute(self, fig)

    with journal_style("single"), pytest.MonkeyPatch.context() as mp:
        mp.setattr(ConstrainedLayoutEngine, "execute", counted)
        ax = new_axes((3.35, height))
        fig = ax.figure
        for k in range(entries):
            ax.plot([0, 1], [k, k + 1], label=f"{k} " + "m" * chars)
        ax.set_ylabel("friction force $F_t$ (mN)")
        engine = fig.get_layout_engine()
        engine.execute(fig)
        before = [(a.get_position().bounds, fig.get_figheight()) for a in fig.axes]
        legend = place_legend(ax, ncol_outside=ncol)
        assert legend is not None
        grown = fig.get_figheight()
        assert grown > height
        fixed = not isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)
        box = legend.get_window_extent()
        pad = engine.get()["w_pad"] * fig.dpi
        # only a legend that would run past the figure's side keeps the engine
        assert fixed == (box.x0 >= pad and box.x1 <= fig.get_figwidth() * fig.dpi - pad)
        if fixed:
            for a, ((x0, y0, w, h), old) in zip(fig.axes, before, strict=True):
                p = a.get_position()
                np.testing.assert_allclose(
                    [p.x0, p.y0 * grown, p.width, p.height * grown],
                    [x0, y0 * old, w, h * old], rtol=1e-9, atol=1e-12)
        runs.clear()
        figure_bytes(fig, ("png",), dpi=72)
        assert len(runs) == (0 if fixed else 1)
    box = legend.get_window_extent()
    assert box.y0 >= ax.get_window_extent().y1  # above the Axes, covering none of them
    assert box.y1 <= fig.get_figheight() * fig.dpi + 0.5  # and below the figure's top
