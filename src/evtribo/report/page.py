"""A self-contained HTML report, built like MNE's ``Report``: add figures, tables, text.

>>> report = Report("My study")                                     # doctest: +SKIP
>>> report.add_table(df, "Results", section="Summary")              # doctest: +SKIP
>>> report.add_figure(fig, "F_el vs U", caption="...", section="P01")  # doctest: +SKIP
>>> report.save("report.html")                                      # doctest: +SKIP

The page is one file: figures are embedded as base64 PNG or SVG (``data:`` URIs), the style
sheet is inline, nothing is loaded from anywhere, so it opens offline and can be mailed. A
figure given as a matplotlib figure is also written as PNG and SVG into a folder beside it
(``report_files/`` for ``report.html``); one given as a file on disk is embedded (PNG, SVG)
or linked (PDF), not copied.

The page is rendered from the Jinja2 template ``templates/report.html.j2`` with autoescaping
on: every title, caption, table cell and text item is escaped, so a subject's note holding
``<script>`` shows as text. Only :meth:`Report.add_html` inserts markup as given; it is for
HTML the program writes itself, never for user text.
"""

from __future__ import annotations

import base64
import io
import logging
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jinja2
import numpy as np
import pandas as pd
from markupsafe import Markup

from evtribo import __version__
from evtribo.errors import OutputExistsError, UserInputError
from evtribo.store.names import companion
from evtribo.store.owned import refuse_foreign
from evtribo.store.resultdir import Staging, locked, recover
from evtribo.util.numbers import frequency, significant

log = logging.getLogger(__name__)

__all__ = ["Report", "files_dir_for", "hertz"]

_env = jinja2.Environment(
    loader=jinja2.PackageLoader("evtribo.report", "templates"),
    autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True)


def files_dir_for(path: str | Path) -> Path:
    """The folder beside a report for its figure files: ``report.html`` -> ``report_files``
    (for a name so long that this one would pass 255 bytes, its start and a hash of it:
    :func:`~evtribo.store.names.companion`).

    Parameters
    ----------
    path : str or Path
        The report's HTML file.

    Returns
    -------
    Path
        The folder.
    """
    p = Path(path)
    return p.with_name(companion(p.stem, "_files"))


_HZ = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?) Hz\b")


def hertz(text: str) -> str:
    """Frequencies in a text as people write them: ``10000 Hz`` -> ``10 kHz`` (every title,
    caption and summary line of the page goes through it).

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    return _HZ.sub(lambda m: frequency(float(m.group(1))), text)


def _slug(text: str, used: set[str]) -> str:
    base = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "item"
    slug, k = base, 2
    while slug in used:
        slug, k = f"{base}-{k}", k + 1
    used.add(slug)
    return slug


def _cell(value: Any, float_format: str) -> str:
    if value is None:
        return ""
    if isinstance(value, float | np.floating):
        v = float(value)
        if math.isnan(v):
            return ""
        if v.is_integer() and abs(v) < 1e15:  # 10000 Hz, not 1e+04
            return str(int(v))
        text = format(v, float_format)
        if "e" in text.lower() and math.isfinite(v):  # positional, never 1e-06
            text = significant(v, _SIG.get(float_format, 4))
        return text
    return str(value)


#: Significant figures of the float formats a table may be given.
_SIG = {".3g": 3, ".4g": 4, ".5g": 5, ".6g": 6}

#: Embedded figure files: their suffix and ``data:`` type.
_EMBED = {".png": "image/png", ".svg": "image/svg+xml"}


#: A figure with a known physical size is shown at this many times its printed width
#: (a journal's single column, 85 mm, is 643 CSS pixels wide), never wider than the page.
SCREEN_SCALE = 2.0


def _png_width_in(data: bytes) -> float | None:
    """A PNG's width in inches, from its header and its ``pHYs`` resolution (None when it
    records none)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    width = int.from_bytes(data[16:20], "big")
    at = data.find(b"pHYs", 8, 4096)
    if at < 0 or data[at + 12] != 1:  # unit 1: per metre
        return None
    per_metre = int.from_bytes(data[at + 4:at + 8], "big")
    return width / (per_metre * 0.0254) if per_metre else None


def _svg_width_in(data: bytes) -> float | None:
    """An SVG's width in inches, when its root gives one in pt, mm, cm or in."""
    m = re.search(rb'<svg[^>]*?\swidth="([0-9.]+)(pt|mm|cm|in)"', data[:4096])
    if not m:
        return None
    per_inch = {b"pt": 72.0, b"mm": 25.4, b"cm": 2.54, b"in": 1.0}[m.group(2)]
    return float(m.group(1)) / per_inch


def _figure_file(path: Path) -> dict[str, Any]:
    """How a figure file on disk is shown: a PNG or SVG embedded (at :data:`SCREEN_SCALE`
    times its printed width when it has one), a PDF linked."""
    suffix = path.suffix.lower()
    if not path.is_file() or suffix not in (*_EMBED, ".pdf"):
        raise UserInputError("expected an existing PNG, SVG or PDF file", path=path)
    if suffix == ".pdf":
        return {"pdf": path}
    data = path.read_bytes()
    inches = _png_width_in(data) if suffix == ".png" else _svg_width_in(data)
    payload = base64.b64encode(data).decode()
    return {"src": f"data:{_EMBED[suffix]};base64,{payload}",
            "width": None if inches is None else round(96 * SCREEN_SCALE * inches)}


@dataclass
class _Item:
    kind: str  # "figure", "grid", "table", "text", "html", "list"
    title: str
    caption: str = ""
    data: dict[str, Any] = field(default_factory=dict)


@dataclass
class _Section:
    title: str
    slug: str
    items: list[_Item] = field(default_factory=list)


class Report:
    """Builder of a self-contained HTML report.

    Parameters
    ----------
    title : str
        Title of the page (escaped).
    dpi : float
        Resolution of figures given as matplotlib Figures, dots per inch.
    """

    def __init__(self, title: str, *, dpi: float = 110) -> None:
        self.title = title
        self.dpi = dpi
        self._sections: list[_Section] = []
        self._slugs: set[str] = set()
        self._figure_files: list[tuple[str, bytes, bytes | None]] = []

    # ------------------------------------------------------------------------- building
    def _section(self, name: str | None) -> _Section:
        name = name or self.title
        for s in self._sections:
            if s.title == name:
                return s
        section = _Section(name, _slug(name, self._slugs))
        self._sections.append(section)
        return section

    @property
    def sections(self) -> list[str]:
        """Section titles, in order."""
        return [s.title for s in self._sections]

    def add_figure(self, fig: Any, title: str, *, caption: str = "",
                   section: str | None = None, details: str | None = None,
                   links: Sequence[str | Path] = ()) -> None:
        """Add a figure.

        Parameters
        ----------
        fig : matplotlib Figure or Axes, or str or Path
            A figure (rendered here as PNG and SVG, and written beside the page by
            :meth:`save`), or the path of a figure file already on disk: a PNG or an SVG is
            embedded, a PDF is linked (by its path relative to the page, see *href*), and
            none of them is copied.
        title, caption : str
            Shown above and below the figure (escaped).
        section : str, optional
            Section title (default: the report's title).
        details : str, optional
            Show the figure folded, in a ``<details>`` element with this summary line.
        links : sequence of str or Path
            Files to link under the figure (its PNG, SVG, PDF), named relative to the page
            by :meth:`render`.

        Returns
        -------
        None
        """
        sec = self._section(section)
        slug = _slug(f"{sec.slug}-{title}", self._slugs)
        data: dict[str, Any] = {"slug": slug, "details": details,
                                "links": [Path(x) for x in links]}
        if isinstance(fig, str | Path):
            data.update(_figure_file(Path(fig)))
        else:
            figure = getattr(fig, "figure", fig) if not hasattr(fig, "savefig") else fig
            png_buf, svg_buf = io.BytesIO(), io.BytesIO()
            figure.savefig(png_buf, format="png", dpi=self.dpi)
            figure.savefig(svg_buf, format="svg", metadata={"Date": None})
            png, svg = png_buf.getvalue(), svg_buf.getvalue()
            self._figure_files.append((slug, png, svg))
            data["src"] = "data:image/png;base64," + base64.b64encode(png).decode()
        sec.items.append(_Item("figure", title, caption, data))

    def add_figure_grid(self, panels: Sequence[tuple[str | Path, str]], title: str, *,
                        caption: str = "", section: str | None = None,
                        links: Sequence[str | Path] = ()) -> None:
        """Add figures of one kind side by side, as one figure of small multiples (a panel
        per subject, say): each panel a PNG or SVG file on disk, embedded, with its label.

        Parameters
        ----------
        panels : sequence of (str or Path, str)
            Each panel's file and its label (``P01``).
        title, caption : str
            Shown above and below the grid (escaped).
        section : str, optional
            Section title.
        links : sequence of str or Path
            Files to link under the grid.

        Returns
        -------
        None
        """
        sec = self._section(section)
        slug = _slug(f"{sec.slug}-{title}", self._slugs)
        shown = [{"label": label, **_figure_file(Path(f))} for f, label in panels]
        sec.items.append(_Item("grid", title, caption, {
            "slug": slug, "panels": shown, "links": [Path(x) for x in links]}))

    def add_table(self, table: pd.DataFrame, title: str, *, caption: str = "",
                  section: str | None = None, float_format: str = ".4g",
                  columns: Sequence[str] | None = None, wrap: bool | str = False,
                  marks: Mapping[tuple[int, str], Sequence[tuple[str, str]]] | None = None,
                  anchor: str | None = None,
                  links: Mapping[tuple[int, str], str | Path] | None = None) -> None:
        """Add a table (every cell escaped).

        Parameters
        ----------
        table : DataFrame
            The rows; NaN shows as an empty cell.
        title, caption : str
            Shown above and below (escaped).
        section : str, optional
            Section title.
        float_format : str
            Format of floating-point cells.
        columns : sequence of str, optional
            Columns to show (default: all).
        wrap : bool or str
            Let long cells wrap at their spaces (a table that must fit the page's width);
            ``"anywhere"`` also breaks long words (file names, hashes).
        marks : mapping, optional
            ``(row, column) -> [(text, href), ...]``: links set after a cell (``W1`` to a
            warning), the row counted from 0 in *table*'s order.
        anchor : str, optional
            An id of the table, for links to it (one is made from its title otherwise).
        links : mapping, optional
            ``(row, column) -> file``: the cell links to the file, named relative to the
            page by :meth:`render`.

        Returns
        -------
        None
        """
        cols = [c for c in (columns or list(table.columns)) if c in table.columns]
        rows = [[_cell(v, float_format) for v in rec]
                for rec in table[cols].itertuples(index=False, name=None)]
        marks = marks or {}
        cell_marks = [[list(marks.get((i, str(c)), ())) for c in cols] for i in range(len(rows))]
        files = {(i, str(c)): Path(f) for (i, c), f in (links or {}).items()}
        slug = _slug(anchor or f"table-{title}", self._slugs)
        self._section(section).items.append(
            _Item("table", title, caption, {"columns": [str(c) for c in cols], "rows": rows,
                                            "wrap": wrap, "marks": cell_marks,
                                            "slug": slug, "files": files}))

    def add_text(self, text: str, title: str = "", *, section: str | None = None) -> None:
        """Add a paragraph of plain text (escaped)."""
        self._section(section).items.append(_Item("text", title, "", {"text": text}))

    def add_list(self, items: Iterable[str], title: str = "", *, caption: str = "",
                 section: str | None = None, warning: bool = False) -> None:
        """Add a bulleted list of plain-text items (escaped): notes, or with *warning* in a
        warning's colour."""
        self._section(section).items.append(
            _Item("list", title, caption, {"items": [str(i) for i in items],
                                           "style": "warnings" if warning else "notes"}))

    def add_html(self, html: str, title: str = "", *, section: str | None = None) -> None:
        """Add HTML as given (NOT escaped: only for markup the program writes itself)."""
        self._section(section).items.append(_Item("html", title, "", {"html": Markup(html)}))

    @staticmethod
    def _refuse_existing(folder: Path, names: list[str], overwrite: bool) -> None:
        refuse_foreign(folder, names, {"report"})  # a user's file: never, overwrite or not
        existing = [folder / n for n in names if (folder / n).exists()]
        if existing and not overwrite:
            raise OutputExistsError("the report already exists; use {force} to overwrite it",
                                    path=existing[0])

    # ------------------------------------------------------------------------ rendering
    def render(self, base: str | Path | None = None) -> str:
        """The page as one HTML string.

        Parameters
        ----------
        base : str or Path, optional
            The folder the page will be in: linked files (PDF figures) are named relative
            to it (default: by their absolute path).

        Returns
        -------
        str
            The HTML.
        """
        def href(path: Path) -> str:
            return (Path(path).resolve().as_uri() if base is None else
                    Path(os.path.relpath(Path(path).resolve(), Path(base).resolve())).as_posix())

        counts = {"figure": 0, "table": 0}
        for sec in self._sections:
            for item in sec.items:
                item.title, item.caption = hertz(item.title), hertz(item.caption)
                if item.data.get("details"):
                    item.data["details"] = hertz(str(item.data["details"]))
                if item.kind == "text":
                    item.data["text"] = hertz(str(item.data["text"]))
                if item.kind == "list":
                    item.data["items"] = [hertz(x) for x in item.data["items"]]
                pdf = item.data.get("pdf")
                if pdf is not None:
                    item.data["href"] = href(pdf)
                item.data["hrefs"] = [(Path(p).name, href(p))
                                      for p in item.data.get("links", ())]
                if item.kind == "table":
                    cols = item.data["columns"]
                    files = item.data.get("files", {})
                    item.data["cell_hrefs"] = [[href(files[(i, c)]) if (i, c) in files else ""
                                                for c in cols]
                                               for i in range(len(item.data["rows"]))]
                kind = "figure" if item.kind in ("figure", "grid") else item.kind
                if kind in counts:
                    counts[kind] += 1
                    item.data["number"] = counts[kind]
        template = _env.get_template("report.html.j2")
        return template.render(title=self.title, sections=self._sections, version=__version__)

    def save(self, path: str | Path, *, overwrite: bool = False,
             figure_files: bool = True, unit: str | Path | None = None,
             extra_files: Mapping[str, str] | None = None,
             stale: Iterable[str] = ()) -> Path:
        """Write the page, and each figure given as a matplotlib figure as PNG and SVG into
        :func:`files_dir_for`.

        Parameters
        ----------
        path : str or Path
            The HTML file.
        overwrite : bool
            Replace an existing report and its files.
        figure_files : bool
            Also write the figures beside the report.
        unit : str or Path, optional
            The output the report is part of, locked and written as one unit with it (a
            result folder holding the report; default: the report itself).
        extra_files : mapping of str to str, optional
            Text files written with the page, by their names relative to its folder
            (``tables/fit.md``).
        stale : iterable of str
            Files of an earlier report (relative to the page's folder) removed in the same
            step when this one does not write them.

        Returns
        -------
        Path
            The HTML file.

        Raises
        ------
        OutputExistsError
            When the report or one of its files exists and *overwrite* is False.
        OutputBusyError
            When another process is writing the same report.

        Notes
        -----
        The page and its files are written as one unit (:mod:`evtribo.store.resultdir`): into a
        new folder beside the page, then swapped in; a report stopped at any moment is the
        old one or the new one, never half of each. With *overwrite*, figure files of the
        old report that the new one does not have are removed.
        """
        html_path = Path(path)
        files_dir = files_dir_for(html_path)
        extra = dict(extra_files or {})
        names = [html_path.name, *extra]
        if figure_files:
            for slug, _, svg in self._figure_files:
                names.append(f"{files_dir.name}/{slug}.png")
                if svg is not None:
                    names.append(f"{files_dir.name}/{slug}.svg")
        self._refuse_existing(html_path.parent, names, overwrite)
        text = self.render(base=html_path.parent)
        unit = html_path if unit is None else Path(unit)
        with locked(unit, "evtribo report"):
            recover(unit)
            self._refuse_existing(html_path.parent, names, overwrite)
            old = [f"{files_dir.name}/{p.name}" for p in sorted(files_dir.glob("*"))
                   if p.suffix.lower() in (".png", ".svg")] if files_dir.is_dir() else []
            old += [rel for rel in stale if (html_path.parent / rel).is_file()]
            with Staging(unit, target=html_path.parent, by="report") as stage:
                if figure_files:
                    for slug, png, svg in self._figure_files:
                        stage.path(f"{files_dir.name}/{slug}.png").write_bytes(png)
                        if svg is not None:
                            stage.path(f"{files_dir.name}/{slug}.svg").write_bytes(svg)
                for rel, content in extra.items():
                    stage.path(rel).write_text(content, encoding="utf-8")
                stage.path(html_path.name).write_text(text, encoding="utf-8")
                stage.commit(remove=old, last=[html_path.name])
        log.info("report: wrote %s (%d figures, %.0f kB)", html_path, len(self._figure_files),
                 len(text) / 1024)
        return html_path
