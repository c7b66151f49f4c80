"""How a figure is declared: :class:`FigureSpec` (its kind, names, place in the report and
the function that gives its :class:`Drawing`), and what it is drawn from,
:class:`FigureContext`, filled in stage by stage as compare goes; :class:`PlannedFigure` is
one figure of a spec for one item (the study, a subject, a condition, a trial).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Literal, Protocol, get_args

from evtribo.figures.friction_only import subject_mu
from evtribo.figures.trial_checks import CheckFigure
from evtribo.fit.fit import SubjectFit
from evtribo.fit.models import ModelFit
from evtribo.fit.tables import ResultTables
from evtribo.population.estimates import Population
from evtribo.warning.record import WarningRecord

__all__ = ["PERS", "SECTIONS", "STAGES", "Draw", "Drawing", "FigureContext", "FigureSink",
           "FigureSpec", "PlannedFigure"]

Section = Literal["all", "predictions", "models", "population", "subject", "checks"]
Per = Literal["study", "subject", "condition", "trial"]
Stage = Literal["fits", "population", "models"]
#: The report's places for a figure: all subjects together, the model's predictions, the
#: model comparison, the population, each subject's section, each trial's check there.
SECTIONS: tuple[str, ...] = get_args(Section)
#: What a figure is drawn per.
PERS: tuple[str, ...] = get_args(Per)
#: compare's stages, in order: a figure is drawn once what it shows is known.
STAGES: tuple[str, ...] = get_args(Stage)


@dataclass(frozen=True)
class Drawing:
    """A figure to draw: ``func(*args, **kwargs)`` draws it and returns its Axes.

    Attributes
    ----------
    func : callable
        A function importable by its name (a worker process imports it).
    args : tuple
        Its arguments (what the figure shows).
    kwargs : dict
        Its keyword arguments.
    """

    func: Callable[..., Any]
    args: tuple[Any, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)

    def draw(self) -> Any:
        """Draw the figure here.

        Returns
        -------
        matplotlib.axes.Axes
        """
        return self.func(*self.args, **self.kwargs)


@dataclass(eq=False)
class FigureContext:
    """What compare's figures show, filled in stage by stage.

    Attributes
    ----------
    tables : ResultTables
        The result folder's tables.
    names : tuple of str
        The parameters fitted per subject.
    models : tuple of str
        The candidate models asked for (``compare --models``; empty: none).
    fits : list of SubjectFit
        Each subject's fit (stage ``fits``; none for a study of OFF trials).
    population : Population or None
        The population's estimates (stage ``population``).
    model_fits : list of ModelFit
        Each candidate model fitted to each subject (stage ``models``).
    checks : list of CheckFigure
        The trials whose checks are drawn.
    """

    tables: ResultTables
    names: tuple[str, ...] = ("h_L",)
    models: tuple[str, ...] = ()
    fits: list[SubjectFit] = field(default_factory=list)
    population: Population | None = None
    model_fits: list[ModelFit] = field(default_factory=list)
    checks: list[CheckFigure] = field(default_factory=list)

    @property
    def only_mu(self) -> bool:
        """A study without electrostatic forces (OFF trials only): its friction, no fit."""
        return bool(self.tables.electrostatic.empty)

    @cached_property
    def mu(self) -> dict[str, float]:
        """Each subject's friction coefficient from its OFF windows, in their order."""
        rows = subject_mu(self.tables.windows)
        return {str(s): float(m) for s, m in zip(rows["subject"], rows["mu"], strict=True)}

    @property
    def subjects(self) -> list[str]:
        """The subjects drawn: those with electrostatic forces (in a study of OFF trials,
        those with OFF windows), in the tables' order."""
        return list(self.mu) if self.only_mu else [str(s) for s in self.tables.subjects]

    def fit_of(self, subject: str) -> SubjectFit | None:
        """The subject's fit (None: not fitted)."""
        return next((f for f in self.fits if f.subject == subject), None)


Draw = Callable[[FigureContext, Any], Drawing | None]


def _always(ctx: FigureContext) -> bool:
    return True


@dataclass(frozen=True)
class FigureSpec:
    """One kind of figure: how compare draws it and where the report places it.

    Attributes
    ----------
    kind : str
        The registry's key and fit.json's ``kind``.
    stem, title : str
        Templates of the file stem and the short title, with the fields of :attr:`per`
        (``"electrostatic_force_{subject}"``; ``{subject}`` and ``{trial}`` made safe for
        a file name in the stem, ``{condition}`` as ``square_10000Hz`` there and
        ``square 10000 Hz`` in the title).
    caption : str or callable
        A template like :attr:`title`, or ``caption(ctx, item)``.
    section : str
        One of :data:`SECTIONS`.
    per : str
        One of :data:`PERS`.
    draw : callable
        ``draw(ctx, item)``: the figure's :class:`Drawing`, or None when there is none
        for this item.
    needs : str
        The stage of :data:`STAGES` after which it is drawn.
    when : callable
        ``when(ctx)``: whether the figure is drawn for these results at all.
    why_not : callable, optional
        ``why_not(ctx)``: where :attr:`when` is false, compare's warning saying why: a
        record of a kind of the catalogue (a plug-in's text is said as a ``figure-absent``
        record), or None (or "") for none.
    items : callable, optional
        ``items(ctx)``: what it is drawn per, when not every one of :attr:`per`'s (the
        subjects, the conditions with a power law, the trials checked).
    grid : (str, str), optional
        With many subjects, the report shows the kind as one grid of small multiples:
        its title and caption.
    screen : bool
        A figure to look at on a screen, not to print: written as PNG (else in the first
        format asked) at most at the checks' resolution, listed after the others.
    told : str
        What compare's progress says as each is done, a template like :attr:`title` (""
        for nothing).
    """

    kind: str
    stem: str
    title: str
    caption: str | Callable[[FigureContext, Any], str]
    section: Section
    per: Per
    draw: Draw
    needs: Stage = "models"
    when: Callable[[FigureContext], bool] = _always
    why_not: Callable[[FigureContext], WarningRecord | str | None] | None = None
    items: Callable[[FigureContext], Iterable[Any]] | None = None
    grid: tuple[str, str] | None = None
    screen: bool = False
    told: str = ""

    def __post_init__(self) -> None:
        for name, value, allowed in (("section", self.section, SECTIONS),
                                     ("per", self.per, PERS), ("needs", self.needs, STAGES)):
            if value not in allowed:
                raise ValueError(f"figure {self.kind!r}: {name} {value!r} is not one of "
                                 f"{', '.join(allowed)}")
        if self.section in ("subject", "checks") and self.per not in ("subject", "trial"):
            raise ValueError(f"figure {self.kind!r}: a subject's section holds figures per "
                             f"subject or per trial, not per {self.per}")


@dataclass(frozen=True)
class PlannedFigure:
    """One figure to draw: its spec, its names filled in, and its drawing.

    Attributes
    ----------
    spec : FigureSpec
    stem, title, caption : str
    subject : str or None
        The subject shown (None: no one subject).
    drawing : Drawing
    extra : dict
        Further keys of its record (``trial`` for a trial's check).
    told : str
        What compare's progress says when it is done ("" for nothing).
    """

    spec: FigureSpec
    stem: str
    title: str
    caption: str
    subject: str | None
    drawing: Drawing
    extra: Mapping[str, Any] = field(default_factory=dict)
    told: str = ""

    def placed(self) -> dict[str, Any]:
        """Where the report places it, as its fit.json record says it (for a report made
        without its spec): ``section``, ``per`` and, for a grid, ``grid``, then the extra
        keys.

        Returns
        -------
        dict
        """
        spec = self.spec
        grid = {"grid": list(spec.grid)} if spec.grid is not None else {}
        return {"section": spec.section, "per": spec.per, **grid, **self.extra}


class FigureSink(Protocol):
    """Where compare's figures go: written as files
    (:class:`evtribo.report.drawing.Figures`) or kept in memory (``evtribo.compare``'s)."""

    def emit(self, figure: PlannedFigure) -> None:
        """Take one figure: draw it (now or later) and record it.

        Parameters
        ----------
        figure : PlannedFigure

        Returns
        -------
        None
        """
