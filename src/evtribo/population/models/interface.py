"""What a population model is: :class:`PopulationModel` fits one drive's cells of every
subject (:class:`DriveCells`) and gives the population's estimates (:class:`ModelFit`).

A model is one value of study.toml's ``[population] model``
(:mod:`evtribo.population.models` registers them by name). The orchestration around it is
:func:`evtribo.population.power_law.condition_estimates`: the primary rows are the chosen
model's, every subject in; the subjects it names as far from the others
(:meth:`PopulationModel.far`) each get the same model refitted without them (``without S03``); the
meta-analysis of log F_el is the second method unless it is the primary one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, runtime_checkable

from evtribo.population.data import Condition, ModelRow, SubjectData, condition_label
from evtribo.population.nonlinear import NonlinearData
from evtribo.population.nonlinear_fit import NonlinearFit
from evtribo.population.stats import Outlier

__all__ = ["DriveCells", "FarSubjects", "ModelFit", "PopulationModel"]


@dataclass(frozen=True)
class DriveCells:
    """One drive's cells (a waveform at a frequency) of every subject.

    Attributes
    ----------
    condition : (str, float)
        The waveform and drive frequency, Hz.
    subjects : sequence of SubjectData
        Every subject of the study (but those excluded beforehand): each one's cells with
        their intervals and covariances, on the linear and the log scale.
    data : NonlinearData
        The cells on the linear scale of the subjects that have some here (N).
    amplitudes : sequence of float, V
        Every amplitude measured here, ascending.
    label : str
        The drive in words (``square 10000 Hz``; ``... without S03`` for a refit).
    """

    condition: Condition
    subjects: Sequence[SubjectData]
    data: NonlinearData
    amplitudes: Sequence[float]
    label: str = ""

    def __post_init__(self) -> None:
        if not self.label:
            object.__setattr__(self, "label", condition_label(*self.condition))

    def without(self, subject: str) -> DriveCells:
        """These cells without one subject's.

        Parameters
        ----------
        subject : str

        Returns
        -------
        DriveCells
        """
        return replace(self, subjects=[s for s in self.subjects if s.name != subject],
                       data=self.data.without(subject), label=f"{self.label} without {subject}")


@dataclass
class ModelFit:
    """A population model fitted to one drive's cells.

    Attributes
    ----------
    rows : list of ModelRow
        Its estimates (population.csv's rows but for the drive and the analysis).
    notes : list of WarningRecord
        What its checks say of it (said of the primary fit): records of kinds of the
        catalogue (:mod:`evtribo.warning.catalogue`), made and not said
        (``emitter(__name__).record(...)``); a text is said as a ``population-model-note``.
    line : NonlinearFit or None
        The power law across subjects, for the figure and the report (None: the model
        has none to draw).
    modes : dict
        Each subject's own ``(log F at the fit's centre, exponent)``, for the figure.
    """

    rows: list[ModelRow]
    notes: list[Any] = field(default_factory=list)
    line: NonlinearFit | None = None
    modes: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class FarSubjects:
    """Subjects a model names as far from the others in one quantity.

    Attributes
    ----------
    quantity : str
        What they are far in (``exponent, square 10000 Hz``).
    found : sequence of Outlier
        Each one, its value and the others' prediction interval.
    unit : str or None
        The values are logs of a quantity in this unit; None: as they are.
    """

    quantity: str
    found: Sequence[Outlier]
    unit: str | None = None


@runtime_checkable
class PopulationModel(Protocol):
    """One value of ``[population] model``: how a drive's cells make the population's
    estimates.

    Attributes
    ----------
    name : str
        The setting's value (``mixed``).
    min_amplitudes : int
        The fewest amplitudes of a drive it is fitted to (with fewer, the drive has the
        meta-analysis only).
    """

    name: str
    min_amplitudes: int

    def fit(self, cells: DriveCells, notes: list[Any]) -> ModelFit | None:
        """The model fitted to one drive's cells.

        Parameters
        ----------
        cells : DriveCells
        notes : list
            Where what could not be fitted, and why, is said: a record of a kind of the
            catalogue, made and not said (``emitter(__name__).record(...)``; a lab's
            plug-in registers its kinds through ``evtribo.warning_kinds``), or a text,
            said as a ``population-model-note``.

        Returns
        -------
        ModelFit or None
            None when it cannot be fitted.
        """
        ...  # pragma: no cover - a protocol

    def far(self, fit: ModelFit, cells: DriveCells, alpha: float) -> list[FarSubjects]:
        """The subjects far from the others in a fit (named, never left out).

        Parameters
        ----------
        fit : ModelFit
            The model's fit of *cells*.
        cells : DriveCells
        alpha : float
            The level of each quantity's test (the study's 5 %, shared).

        Returns
        -------
        list of FarSubjects
        """
        ...  # pragma: no cover - a protocol
