"""The report's headline tables as Markdown and LaTeX (``evtribo report --tables md,tex``).

The files go into ``tables/`` beside the report (``tables/electrostatic_force.md``,
``tables/fit.tex``...) and hold the very text the page shows
(:mod:`evtribo.report.headline`). The LaTeX is a ``table`` float with a ``tabular`` in the
booktabs style (``\\toprule``, ``\\midrule``, ``\\bottomrule``; ``\\usepackage{booktabs}``),
units and Greek letters in plain LaTeX, so it needs no other package.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

from evtribo.errors import UserInputError
from evtribo.report.headline import CITATION, Headline
from evtribo.results.outputs import REPORT_TABLES, TABLES

__all__ = ["TABLE_FORMATS", "latex_escape", "parse_table_formats", "table_files", "to_latex",
           "to_markdown"]

#: The formats ``--tables`` knows, by file suffix.
TABLE_FORMATS: tuple[str, ...] = ("md", "tex")

_LATEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
          "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
          "^": r"\textasciicircum{}", "µ": r"\textmu{}", "μ": r"$\mu$",
          "ε": r"$\varepsilon$", "Ω": r"$\Omega$", "Δ": r"$\Delta$", "²": r"$^{2}$",
          "·": r"$\cdot$", "—": "---", "∞": r"$\infty$", "<": r"$<$", ">": r"$>$",
          "\u00d7": r"$\times$", "\u00f7": r"$\div$", "\u2212": "-", '"': "''"}
_LATEX_RE = re.compile("|".join(re.escape(k) for k in _LATEX))


def parse_table_formats(text: str | Iterable[str] | None) -> tuple[str, ...]:
    """The formats of ``--tables md,tex``, checked.

    Parameters
    ----------
    text : str or iterable of str or None
        ``"md,tex"``, or the names; None or ``""`` for none.

    Returns
    -------
    tuple of str
        Known formats, each once, in the order given.

    Raises
    ------
    UserInputError
        An unknown format (exit code 2, key ``--tables``).
    """
    if not text:
        return ()
    items = text.split(",") if isinstance(text, str) else list(text)
    names = [str(i).strip().lower().lstrip(".") for i in items if str(i).strip()]
    for name in names:
        if name not in TABLE_FORMATS:
            raise UserInputError(f"unknown table format {name!r}; known: "
                                 f"{', '.join(TABLE_FORMATS)}", key="--tables")
    return tuple(dict.fromkeys(names))


def _caption(table: Headline) -> str:
    """The caption, citing the paper under the fit's table."""
    return f"{table.caption} Model: {CITATION}." if table.stem == "fit" else table.caption


def _md_cell(text: str) -> str:
    return str(text).replace("|", r"\|").replace("\n", " ")


def _numeric(table: Headline) -> list[bool]:
    """Which columns hold numbers (right-aligned): most cells start with a digit."""
    out = []
    for col in table.table.columns:
        cells = [str(v) for v in table.table[col] if str(v) != "—"]
        digits = sum(c[:1].isdigit() or c.startswith(("-", ">", "<")) for c in cells)
        out.append(bool(cells) and digits * 2 > len(cells))
    return out


def to_markdown(table: Headline) -> str:
    """A headline table as Markdown: its title, caption and a pipe table.

    Parameters
    ----------
    table : Headline
        The table.

    Returns
    -------
    str
        GitHub-flavoured Markdown, ending in a newline.
    """
    cols = [str(c) for c in table.table.columns]
    lines = [f"**{table.title}**", "", _caption(table), "",
             "| " + " | ".join(_md_cell(c) for c in cols) + " |",
             "|" + "|".join("--:" if num else "---" for num in _numeric(table)) + "|"]
    for rec in table.table.itertuples(index=False, name=None):
        lines.append("| " + " | ".join(_md_cell(v) for v in rec) + " |")
    return "\n".join(lines) + "\n"


def latex_escape(text: str) -> str:
    """*text* with LaTeX's special characters and the page's symbols (µ, Ω, ²...) in LaTeX.

    Parameters
    ----------
    text : str
        Plain text.

    Returns
    -------
    str
        Text for a LaTeX document (no package beyond the kernel needed).
    """
    return _LATEX_RE.sub(lambda m: _LATEX[m.group(0)], str(text))


def to_latex(table: Headline) -> str:
    """A headline table as a LaTeX ``table`` float in the booktabs style.

    Parameters
    ----------
    table : Headline
        The table.

    Returns
    -------
    str
        ``\\begin{table}`` ... ``\\end{table}``, with ``\\toprule``, ``\\midrule`` and
        ``\\bottomrule``; needs ``\\usepackage{booktabs}``.
    """
    cols = [str(c) for c in table.table.columns]
    spec = "".join("r" if num else "l" for num in _numeric(table))
    lines = ["% evtribo report: needs \\usepackage{booktabs}", r"\begin{table}", r"\centering",
             rf"\caption{{{latex_escape(table.title)}. {latex_escape(_caption(table))}}}",
             rf"\label{{tab:{table.stem.replace('_', '-')}}}",
             rf"\begin{{tabular}}{{{spec}}}", r"\toprule",
             " & ".join(latex_escape(c) for c in cols) + r" \\", r"\midrule"]
    for rec in table.table.itertuples(index=False, name=None):
        lines.append(" & ".join(latex_escape(v) for v in rec) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def table_files(tables: Sequence[Headline], formats: Sequence[str]) -> dict[str, str]:
    """The files ``--tables`` writes: ``tables/<stem>.<format>`` -> its text.

    Parameters
    ----------
    tables : sequence of Headline
        The headline tables (their stems among
        :data:`~evtribo.results.outputs.REPORT_TABLES`).
    formats : sequence of str
        Formats (:data:`TABLE_FORMATS`).

    Returns
    -------
    dict of str to str
        Names relative to the report's folder, and their contents.
    """
    render = {"md": to_markdown, "tex": to_latex}
    files = {}
    for t in tables:
        if t.stem not in REPORT_TABLES:
            raise ValueError(f"not a table the report exports: {t.stem!r}")
        for fmt in formats:
            files[f"{TABLES}/{t.stem}.{fmt}"] = render[fmt](t)
    return files
