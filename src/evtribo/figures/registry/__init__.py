"""Every figure of ``evtribo compare``, declared once: one
:class:`~evtribo.figures.registry.spec.FigureSpec` per kind.

A spec names the figure's kind (fit.json's ``kind``), its file stem, title and caption
(templates with the fields of what it is drawn per: ``{subject}``, ``{condition}``,
``{trial}``), the section of ``evtribo report`` that places it (:data:`SECTIONS`), what it
is drawn per (:data:`PERS`: the study, each subject, each condition with a population power
law, each trial checked), the stage of compare's sequence after which it can be drawn
(:data:`STAGES`: the subjects' fits, the population, the models' fits) and the function
that gives its :class:`Drawing` (the plot function and its arguments). From the specs:

- compare (:func:`evtribo.report.compare.run_comparison`, for ``evtribo compare`` and
  ``evtribo.compare`` alike) draws the figures of each stage (:func:`planned`) as soon as
  what they show is known, and names their files before anything is drawn (:func:`stems`);
- ``evtribo report`` places each figure fit.json lists by its kind's spec, or, for a kind
  no spec has here (a plug-in not installed where the report is made), by the ``section``,
  ``per`` and ``grid`` its record carries (:func:`placement`).

:data:`FIGURES` holds evtribo's own kinds (:mod:`evtribo.figures.registry.builtin`), then
those of plug-ins: the entry point group ``evtribo.figures`` (:mod:`evtribo.util.plugins`)
names a :class:`FigureSpec` or a list of them, read the first time the registry is looked
through (:mod:`evtribo.figures.registry.catalogue`). A kind is registered once
(:func:`register`). A plug-in's plot function is drawn in compare's worker processes: it
must be importable by its module and name, and its arguments must pickle.
"""

from evtribo.figures.registry.catalogue import (
    ENTRY_POINTS,
    FIGURES,
    Placement,
    absent_notes,
    placement,
    planned,
    register,
    stems,
)
from evtribo.figures.registry.spec import (
    PERS,
    SECTIONS,
    STAGES,
    Drawing,
    FigureContext,
    FigureSink,
    FigureSpec,
    PlannedFigure,
)

__all__ = ["ENTRY_POINTS", "FIGURES", "PERS", "SECTIONS", "STAGES", "Drawing", "FigureContext",
           "FigureSink", "FigureSpec", "Placement", "PlannedFigure", "absent_notes",
           "placement", "planned", "register", "stems"]
