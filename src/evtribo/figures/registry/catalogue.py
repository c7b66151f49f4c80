"""The figures by kind (:data:`FIGURES`: evtribo's, then plug-ins'), which of them these
results have (:func:`planned`, :func:`stems`, :func:`absent_notes`) and where the report
places each (:func:`placement`).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from evtribo.figures.plots import safe_name
from evtribo.figures.population_plots import condition_stem
from evtribo.figures.registry.builtin import BUILTIN
from evtribo.figures.registry.spec import (
    PERS,
    SECTIONS,
    FigureContext,
    FigureSpec,
    PlannedFigure,
)
from evtribo.population.estimates import condition_label
from evtribo.util import plugins
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["ENTRY_POINTS", "FIGURES", "Placement", "absent_notes", "placement", "planned",
           "register", "stems"]

#: The entry point group of plug-ins' figures.
ENTRY_POINTS = "evtribo.figures"

_SPECS: dict[str, FigureSpec] = {}
_read: dict[str, bool] = {"plugins": False}
_reading = threading.RLock()


def register(*specs: FigureSpec) -> None:
    """Add figures to the registry (after those there).

    Parameters
    ----------
    *specs : FigureSpec

    Raises
    ------
    TypeError
        Something that is not a :class:`FigureSpec`.
    ValueError
        A kind the registry has already (none of the specs is then added).
    """
    seen = set(_SPECS)
    for spec in specs:
        if not isinstance(spec, FigureSpec):
            raise TypeError(f"a figure is a FigureSpec, not {type(spec).__name__}")
        if spec.kind in seen:
            raise ValueError(f"figure kind {spec.kind!r} is registered already")
        seen.add(spec.kind)
    _SPECS.update((s.kind, s) for s in specs)


def _plugins() -> None:
    """The plug-ins' figures, registered once per process (a broken one logged, skipped)."""
    with _reading:
        if _read["plugins"]:
            return
        _read["plugins"] = True
        for name, obj in plugins.load(ENTRY_POINTS):
            found: list[Any] = list(obj) if isinstance(obj, list | tuple) else [obj]
            for spec in found:
                try:
                    register(spec)
                except (TypeError, ValueError) as err:
                    log.warning("plug-in %s (%s): %s; skipped", name, ENTRY_POINTS, err)


class _Registry(Mapping[str, FigureSpec]):
    """Every figure by kind: evtribo's in their order, then the plug-ins'."""

    def __getitem__(self, kind: str) -> FigureSpec:
        _plugins()
        return _SPECS[kind]

    def __iter__(self) -> Iterator[str]:
        _plugins()
        return iter(list(_SPECS))

    def __len__(self) -> int:
        _plugins()
        return len(_SPECS)


#: Every figure by kind.
FIGURES: Mapping[str, FigureSpec] = _Registry()


def _fields(per: str, item: Any) -> tuple[dict[str, str], dict[str, str]]:
    """The template fields of an item: for the file stem, and for the title and caption."""
    if per == "subject":
        return {"subject": safe_name(item)}, {"subject": str(item)}
    if per == "condition":
        return {"condition": condition_stem(item)}, {"condition": condition_label(*item)}
    if per == "trial":
        return ({"subject": safe_name(item.subject), "trial": safe_name(item.trial)},
                {"subject": str(item.subject), "trial": str(item.trial)})
    return {}, {}


def _items(spec: FigureSpec, ctx: FigureContext) -> list[Any]:
    if spec.items is not None:
        return list(spec.items(ctx))
    if spec.per == "subject":
        return ctx.subjects
    if spec.per == "condition":
        return [] if ctx.population is None else list(ctx.population.lines)
    return list(ctx.checks) if spec.per == "trial" else [None]


def _subject_of(per: str, item: Any) -> str | None:
    return str(item) if per == "subject" else str(item.subject) if per == "trial" else None


def _in_order(ctx: FigureContext, specs: list[FigureSpec]) -> list[tuple[FigureSpec, Any]]:
    """Each spec's items in the registry's order, the figures of consecutive per-subject
    kinds subject by subject (a subject's figures together)."""
    out: list[tuple[FigureSpec, Any]] = []
    run: list[FigureSpec] = []
    for spec in [*specs, None]:
        if spec is not None and spec.per == "subject":
            run.append(spec)
            continue
        if run:
            rank = {s: i for i, s in enumerate(ctx.subjects)}
            pairs = [(k, s, item) for k, s in enumerate(run) for item in _items(s, ctx)]
            pairs.sort(key=lambda p: (rank.get(str(p[2]), len(rank)), p[0]))
            out += [(s, item) for _, s, item in pairs]
            run = []
        if spec is not None:
            out += [(spec, item) for item in _items(spec, ctx)]
    return out


def _specs(ctx: FigureContext, stage: str | None) -> list[FigureSpec]:
    return [s for s in FIGURES.values() if (stage is None or s.needs == stage) and s.when(ctx)]


def planned(ctx: FigureContext, stage: str | None = None) -> list[PlannedFigure]:
    """The figures of these results (of one stage of compare's, when given), in order.

    Parameters
    ----------
    ctx : FigureContext
        What the figures show, as far as known.
    stage : str, optional
        One of :data:`~evtribo.figures.registry.spec.STAGES`: the figures drawn after it only.

    Returns
    -------
    list of PlannedFigure
        In the registry's order, a subject's figures together.
    """
    out = []
    for spec, item in _in_order(ctx, _specs(ctx, stage)):
        drawing = spec.draw(ctx, item)
        if drawing is None:
            continue
        names, words = _fields(spec.per, item)
        caption = (spec.caption(ctx, item) if callable(spec.caption)
                   else spec.caption.format(**words))
        out.append(PlannedFigure(spec, spec.stem.format(**names), spec.title.format(**words),
                                 caption, _subject_of(spec.per, item), drawing,
                                 {"trial": str(item.trial)} if spec.per == "trial" else {},
                                 spec.told.format(**words)))
    return out


def stems(ctx: FigureContext) -> list[str]:
    """The file stems of the figures known before anything is drawn (those whose items
    the tables give), so that compare refuses to write over a file before it starts.

    Parameters
    ----------
    ctx : FigureContext

    Returns
    -------
    list of str
    """
    return [spec.stem.format(**_fields(spec.per, item)[0])
            for spec, item in _in_order(ctx, _specs(ctx, None))]


def absent_notes(ctx: FigureContext, stage: str) -> list[WarningRecord]:
    """Compare's warnings on the figures of a stage not drawn, saying why (made, not said:
    compare says them in its order).

    Parameters
    ----------
    ctx : FigureContext
    stage : str
        One of :data:`~evtribo.figures.registry.spec.STAGES`.

    Returns
    -------
    list of WarningRecord
        Each spec's ``why_not``; a plug-in's text as a ``figure-absent`` record.
    """
    out = []
    for s in FIGURES.values():
        if s.needs != stage or s.why_not is None or s.when(ctx):
            continue
        why = s.why_not(ctx)
        if isinstance(why, WarningRecord):
            out.append(why)
        elif why:
            out.append(emit.record("figure-absent", figure=s.kind, text=str(why)))
    return out


@dataclass(frozen=True)
class Placement:
    """Where the report places a figure.

    Attributes
    ----------
    section : str
        One of :data:`SECTIONS`.
    per : str
        One of :data:`PERS`.
    grid : (str, str) or None
        The title and caption of the grid it joins with many subjects.
    order : int
        Its kind's place in the registry (an unknown kind's after all of them).
    """

    section: str
    per: str
    grid: tuple[str, str] | None
    order: int


def placement(record: Mapping[str, Any]) -> Placement:
    """Where the report places a figure fit.json lists.

    Parameters
    ----------
    record : mapping
        A figure's record in fit.json (``kind``, ``subject``, and, from this evtribo on,
        ``section``, ``per``, ``grid``).

    Returns
    -------
    Placement
        By its kind's spec; for a kind the registry lacks, by the record's own keys; for an
        older record without them, among all subjects' figures (no subject) or the
        subject's.
    """
    kinds = list(FIGURES)
    spec = FIGURES.get(str(record.get("kind")))
    if spec is not None:
        return Placement(spec.section, spec.per, spec.grid, kinds.index(spec.kind))
    alone = record.get("subject") is None
    section = record.get("section")
    per = record.get("per")
    grid = record.get("grid")
    return Placement(section if section in SECTIONS else "all" if alone else "subject",
                     per if per in PERS else "study" if alone else "subject",
                     (str(grid[0]), str(grid[1])) if isinstance(grid, list | tuple)
                     and len(grid) == 2 else None, len(kinds))


register(*BUILTIN)
