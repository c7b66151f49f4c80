"""What a figure's legend explains: each drawn line, marker and shaded or hatched stretch
against the legend's entries as they are drawn (colour with its opacity, line style and
width, marker and its fill, hatch).

A drawn line is explained by an entry that looks like it: the same colour, line style
and width; or an entry in :data:`~evtribo.figures.style.EVERY_COLOUR` with its line style
(it stands for that style in every colour) together with an entry of its colour or a
colour bar holding its colour. A marker is explained by an entry with the same marker,
colour and fill, or by an entry in EVERY_COLOUR with its marker and fill (open or filled)
when a colour bar holds its colour. A shaded stretch by a patch
of its colour and opacity, a hatched one by a patch of its hatch. An entry that explains
nothing drawn is a phantom. Error bars' caps and bars, and lines with the gid ``zero`` (an
axis line at 0), are not data.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evtribo.figures.style import EVERY_COLOUR

_NONE = ("None", "none", "", " ", None)


def _rgba(color: Any, alpha: float | None) -> tuple[float, ...]:
    return tuple(np.round(to_rgba(color, alpha), 3))


def _line_look(line: Line2D) -> dict[str, Any]:
    has_line = line.get_linestyle() not in _NONE
    has_marker = line.get_marker() not in _NONE
    alpha = line.get_alpha()
    return {
        "label": str(line.get_label()),
        "line": (_rgba(line.get_color(), alpha), line.get_linestyle(),
                 tuple(line._unscaled_dash_pattern[1] or ()),
                 round(float(line.get_linewidth()), 2)) if has_line else None,
        "marker": (str(line.get_marker()), _rgba(line.get_markeredgecolor(), alpha),
                   _rgba(line.get_markerfacecolor(), alpha)) if has_marker else None,
    }


def _patch_look(patch: Patch) -> tuple[Any, ...]:
    hatch = patch.get_hatch()
    if hatch:
        return ("hatch", hatch)
    return ("fill", _rgba(patch.get_facecolor(), None))


def legend_entries(ax: Axes) -> list[tuple[str, list[Any]]]:
    """The entries of the Axes' legend (or its figure's), in the order they are drawn:
    ``(label, [the artists drawn as its handle])``."""
    legend = ax.get_legend() or (ax.figure.legends[0] if ax.figure.legends else None)
    if legend is None:
        return []
    out = []
    for column in legend._legend_handle_box.get_children():
        for entry in column.get_children():
            area, text = entry.get_children()
            out.append((text.get_text(), list(area.get_children())))
    return out


def _drawn(ax: Axes) -> tuple[list[Line2D], list[Patch]]:
    """The data lines and the shading of the Axes."""
    not_data = set()
    for container in ax.containers:
        if hasattr(container, "has_xerr"):  # an ErrorbarContainer: caps are not data
            _, caps, _ = container.lines
            not_data |= {id(c) for c in caps}
    lines = [ln for ln in ax.lines if id(ln) not in not_data and ln.get_gid() != "zero"
             and ln.get_visible() and len(ln.get_xdata())]
    return lines, [p for p in ax.patches if p.get_visible()]


def _on_a_bar(ax: Axes, colour: tuple[float, ...]) -> bool:
    """Whether a colour bar of the figure holds *colour* (within 0.01 in each channel)."""
    for other in ax.figure.axes:
        bar = getattr(other, "_colorbar", None)
        if other is ax or bar is None:
            continue
        ramp = bar.cmap(np.linspace(0.0, 1.0, 1024))
        if np.min(np.max(np.abs(ramp - np.asarray(colour)), axis=1)) < 0.01:
            return True
    return False


def _fill(marker: tuple[Any, ...]) -> str:
    """``open`` (a white face) or ``filled``."""
    return "open" if marker[2][:3] == (1.0, 1.0, 1.0) else "filled"


def unexplained(ax: Axes) -> tuple[list[str], list[str]]:
    """What the legend leaves unexplained, and its entries that explain nothing drawn.

    Returns
    -------
    (list of str, list of str)
        Descriptions of the drawn lines, markers and patches no entry explains, and the
        labels of the entries no drawn artist matches.
    """
    entries = legend_entries(ax)
    looks = [(label, [_line_look(a) for a in arts if isinstance(a, Line2D)],
              [_patch_look(a) for a in arts if isinstance(a, Patch)]) for label, arts in entries]
    colours = {lk["line"][0] for _, lines, _ in looks for lk in lines if lk["line"]}
    colours |= {lk["marker"][1] for _, lines, _ in looks for lk in lines if lk["marker"]}
    every = _rgba(EVERY_COLOUR, None)
    used: set[str] = set()
    missing: list[str] = []
    lines, patches = _drawn(ax)
    for line in lines:
        look = _line_look(line)
        if look["line"] is not None:
            colour, *style = look["line"]
            known = colour in colours or _on_a_bar(ax, colour)
            hits = [label for label, lks, _ in looks for lk in lks if lk["line"] and (
                lk["line"] == look["line"] or (lk["line"][0][:3] == every[:3]
                                               and list(lk["line"][1:]) == style
                                               and known))]
            if not hits:
                missing.append(f"line {look['line']}")
            used.update(hits)
            if hits and lk_colour_label(looks, colour):
                used.add(lk_colour_label(looks, colour))
        if look["marker"] is not None:
            mark = look["marker"]
            hits = [label for label, lks, _ in looks for lk in lks
                    if lk["marker"] == mark or (
                        lk["marker"] and lk["marker"][0] == mark[0]
                        and lk["marker"][1][:3] == every[:3]
                        and _fill(lk["marker"]) == _fill(mark) and _on_a_bar(ax, mark[1]))]
            if not hits:
                missing.append(f"marker {look['marker']}")
            used.update(hits)
    for patch in patches:
        look = _patch_look(patch)
        hits = [label for label, _, pls in looks if look in pls]
        if not hits:
            missing.append(f"patch {look}")
        used.update(hits)
    phantoms = [label for label, _, _ in looks if label not in used]
    return missing, phantoms


def lk_colour_label(looks: list[Any], colour: tuple[float, ...]) -> str | None:
    """The label of the first entry whose marker or line has *colour* (a drive's)."""
    for label, lks, _ in looks:
        for lk in lks:
            if (lk["marker"] and lk["marker"][1] == colour) or (lk["line"]
                                                                 and lk["line"][0] == colour):
                return label
    return None
