"""``population.csv`` by key: each row found by its quantity, its drive, its amplitude and
its analysis, never by its place in the file.

A row's key is ``(quantity, drive, amplitude, analysis)``:

- the *quantity*: ``electrostatic_force_N`` (F_el at an amplitude), ``exponent`` and
  ``prefactor_N`` (the power law across subjects), ``friction_increase_pct``, ``mu``,
  ``h_L_m``;
- the *drive*: a waveform at a frequency (:class:`Drive`; none for ``mu`` and ``h_L_m``),
  with the one rule for "the same frequency" (:func:`~evtribo.util.numbers.frequency_key`);
- the *amplitude*, V (none for the power law's and the study's quantities);
- the *analysis*: :data:`PRIMARY` (every subject in, but those the study excluded
  beforehand), ``without S03`` (:func:`without`: the same model without a subject far from
  the others), :data:`META` (the random-effects meta-analysis of log F_el at one amplitude).

:meth:`PopulationTable.row` gives the one row of a key, or None, and refuses a file where
two rows share one. :class:`Checks` are the mixed model's convergence checks of a drive,
as fields (:meth:`Checks.of_text` reads them from the text older files and fit.json hold).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from functools import total_ordering
from pathlib import Path
from typing import TYPE_CHECKING, Any

from evtribo.errors import ResultFolderError
from evtribo.util.numbers import amplitude_key, frequency, frequency_key

if TYPE_CHECKING:  # pandas only where a table is read: fit.json's checks need none
    import pandas as pd

__all__ = ["EXPONENT", "FORCE", "META", "PREFACTOR", "PRIMARY", "Checks", "Drive",
           "PopulationRow", "PopulationTable", "without"]

#: ``analysis`` of the rows every subject is in (but those the study excluded beforehand).
PRIMARY = "primary"
#: ``analysis`` of the rows of a meta-analysis of log F_el at each amplitude.
META = "meta-analysis"
#: The quantities of the mixed model: F_el at an amplitude, the exponent, the prefactor.
FORCE, EXPONENT, PREFACTOR = "electrostatic_force_N", "exponent", "prefactor_N"


def without(subject: str) -> str:
    """``analysis`` of the rows of the model refitted without a subject.

    Parameters
    ----------
    subject : str

    Returns
    -------
    str
        ``without S03``.
    """
    return f"without {subject}"


def _text(value: Any) -> str | None:
    """A cell of text: None where it is missing."""
    if value is None or (isinstance(value, float) and math.isnan(value)) or \
            type(value).__name__ == "NAType":  # pandas.NA, pandas not imported for it
        return None
    text = str(value)
    return text or None


@total_ordering
@dataclass(frozen=True)
class Drive:
    """A drive: a waveform at a frequency. Two drives are the same when their waveforms are
    and their frequencies' :func:`~evtribo.util.numbers.frequency_key` are.

    Attributes
    ----------
    waveform : str or None
        None: unknown.
    frequency_Hz : float or None, Hz
        Rounded to a millionth of a hertz; None: unknown.
    """

    waveform: str | None
    frequency_Hz: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "waveform", _text(self.waveform))
        object.__setattr__(self, "frequency_Hz", frequency_key(self.frequency_Hz))

    @classmethod
    def of(cls, waveform: Any, frequency_Hz: Any) -> Drive:
        """The drive of a table's cells (missing values, NaN, pandas' NA: unknown).

        Parameters
        ----------
        waveform : Any
        frequency_Hz : Any, Hz

        Returns
        -------
        Drive
        """
        return cls(_text(waveform), frequency_key(frequency_Hz))

    def label(self) -> str:
        """The drive for people: ``square 10 kHz``, ``sine 10 Hz``, ``square``.

        Returns
        -------
        str
        """
        wave = self.waveform or "unknown waveform"
        return wave if self.frequency_Hz is None else f"{wave} {frequency(self.frequency_Hz)}"

    @property
    def condition(self) -> str:
        """The drive as population_contrasts.csv and fit.json name it: ``square 10000 Hz``."""
        wave = self.waveform or "unknown waveform"
        return wave if self.frequency_Hz is None else f"{wave} {self.frequency_Hz:g} Hz"

    @classmethod
    def from_condition(cls, text: str) -> Drive:
        """The drive a :attr:`condition` names.

        Parameters
        ----------
        text : str
            ``square 10000 Hz``, ``square``.

        Returns
        -------
        Drive
        """
        m = re.fullmatch(r"(?P<wave>.+?) (?P<f>[-+0-9.eE]+|inf|nan) Hz", text.strip())
        wave, freq = (m["wave"], float(m["f"])) if m else (text.strip(), None)
        return cls(None if wave == "unknown waveform" else wave, freq)

    def _key(self) -> tuple[str, float]:
        return (self.waveform or "", -math.inf if self.frequency_Hz is None
                else self.frequency_Hz)

    def __lt__(self, other: object) -> bool:
        if not isinstance(other, Drive):
            return NotImplemented
        return self._key() < other._key()


@dataclass(frozen=True)
class Checks:
    """The mixed model's convergence checks of one drive.

    Attributes
    ----------
    finite : bool
        Every estimate and standard error finite.
    hessian_pd : bool
        The Hessian positive-definite at the optimum.
    agree : bool
        The optimisers agree.
    determined : bool
        The data determine the exponent.
    text : str
        The checks in words (population.csv's ``checks``).
    """

    finite: bool
    hessian_pd: bool
    agree: bool
    determined: bool
    text: str = ""

    @property
    def ok(self) -> bool:
        """Every check passed."""
        return self.finite and self.hessian_pd and self.agree and self.determined

    def holds(self, quantity: str) -> bool:
        """Whether the checks a quantity rests on passed: all four for the exponent and the
        prefactor; the first three for F_el at an amplitude (measured there, an exponent
        the data hardly determine does not move it); none for the rest (not the mixed
        model's).

        Parameters
        ----------
        quantity : str
            population.csv's ``quantity``.

        Returns
        -------
        bool
        """
        if quantity in (EXPONENT, PREFACTOR):
            return self.ok
        if quantity == FORCE:
            return self.finite and self.hessian_pd and self.agree
        return True

    @classmethod
    def of_text(cls, text: Any) -> Checks:
        """The checks from their words, as older files and fit.json hold them: passed when
        the text starts ``ok``, else failed, every one of them.

        Parameters
        ----------
        text : Any
            ``ok (4 optimisers agree)``, or the problems.

        Returns
        -------
        Checks
        """
        said = _text(text) or ""
        ok = said.strip().startswith("ok")
        return cls(ok, ok, ok, ok, said)

    def as_json(self) -> dict[str, Any]:
        """The checks as an object: ``ok``, each check and ``text``.

        Returns
        -------
        dict
        """
        return {"ok": self.ok, "finite": self.finite, "hessian_pd": self.hessian_pd,
                "agree": self.agree, "determined": self.determined, "text": self.text}

    @classmethod
    def from_json(cls, obj: Any) -> Checks:
        """The checks from :meth:`as_json`'s object, or from their text (older fit.json).

        Parameters
        ----------
        obj : mapping or str

        Returns
        -------
        Checks
        """
        if not isinstance(obj, Mapping):
            return cls.of_text(obj)
        return cls(finite=obj.get("finite") is True, hessian_pd=obj.get("hessian_pd") is True,
                   agree=obj.get("agree") is True, determined=obj.get("determined") is True,
                   text=str(obj.get("text") or ""))


@dataclass(frozen=True)
class PopulationRow:
    """One row of population.csv, SI units.

    Attributes
    ----------
    quantity : str
    drive : Drive or None
        None for the study's quantities (``mu``, ``h_L_m``).
    amplitude_V : float or None, V
    analysis : str
        :data:`PRIMARY`, ``without S03`` or :data:`META`.
    estimate, ci_low, ci_high : float
        The estimate and its 95 % confidence interval (NaN where absent).
    pi_low, pi_high : float
        The 95 % prediction interval for a new subject (NaN where absent).
    n_subjects : int or None
    method : str
    checks : str
        The mixed model's checks in words ("" for other methods).
    between_subject_sd, between_sd_low, between_sd_high : float
        The spread between subjects τ and its 95 % interval (NaN where absent).
    i2, i2_low, i2_high : float
        Its share I² of the subjects' scatter and its 95 % interval (NaN where absent).
    """

    quantity: str
    drive: Drive | None
    amplitude_V: float | None
    analysis: str
    estimate: float = math.nan
    ci_low: float = math.nan
    ci_high: float = math.nan
    pi_low: float = math.nan
    pi_high: float = math.nan
    n_subjects: int | None = None
    method: str = ""
    checks: str = ""
    between_subject_sd: float = math.nan
    between_sd_low: float = math.nan
    between_sd_high: float = math.nan
    i2: float = math.nan
    i2_low: float = math.nan
    i2_high: float = math.nan

    @property
    def key(self) -> tuple[str, Drive | None, float | None, str]:
        """``(quantity, drive, amplitude, analysis)``."""
        return self.quantity, self.drive, amplitude_key(self.amplitude_V), self.analysis


def _float(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


_SPREAD = ("between_subject_sd", "between_sd_low", "between_sd_high", "i2", "i2_low", "i2_high")


def _row(r: Mapping[Any, Any]) -> PopulationRow:
    wave, freq = _text(r.get("waveform")), frequency_key(r.get("frequency_Hz"))
    n = _float(r.get("n_subjects"))
    return PopulationRow(
        quantity=str(r.get("quantity")),
        drive=None if wave is None and freq is None else Drive(wave, freq),
        amplitude_V=amplitude_key(r.get("amplitude_V")),
        analysis=_text(r.get("analysis")) or PRIMARY,
        estimate=_float(r.get("estimate")), ci_low=_float(r.get("ci_low")),
        ci_high=_float(r.get("ci_high")), pi_low=_float(r.get("pi_low")),
        pi_high=_float(r.get("pi_high")), n_subjects=int(n) if math.isfinite(n) else None,
        method=_text(r.get("method")) or "", checks=_text(r.get("checks")) or "",
        **{k: _float(r.get(k)) for k in _SPREAD})


class PopulationTable:
    """population.csv's rows, looked up by key.

    Parameters
    ----------
    frame : pandas.DataFrame
        The table as read (at least ``quantity``; a file without ``analysis`` has primary
        rows only).
    checks : mapping of Drive to Checks, optional
        Each drive's checks as fields (fit.json's); else from the primary rows' text.
    path : path-like, optional
        Where the table was read from, for the messages.
    """

    def __init__(self, frame: pd.DataFrame, checks: Mapping[Drive, Checks] | None = None,
                 path: str | Path | None = None) -> None:
        if "quantity" not in frame.columns:
            raise ResultFolderError("no column 'quantity': not a population table", path=path)
        self.frame = frame
        self.path = path
        self._rows = [_row(r) for r in frame.to_dict("records")]
        self._by_key: dict[tuple[Any, ...], list[PopulationRow]] = {}
        for row in self._rows:
            self._by_key.setdefault(row.key, []).append(row)
        self._checks = dict(checks or {})

    def __iter__(self) -> Iterator[PopulationRow]:
        return iter(self._rows)

    def __len__(self) -> int:
        return len(self._rows)

    def drives(self) -> list[Drive]:
        """The drives the rows name, each once, in order (waveform, then frequency).

        Returns
        -------
        list of Drive
        """
        return sorted({r.drive for r in self._rows if r.drive is not None})

    def row(self, quantity: str, drive: Drive | None = None, amplitude_V: float | None = None,
            analysis: str = PRIMARY) -> PopulationRow | None:
        """The row of a key.

        Parameters
        ----------
        quantity : str
        drive : Drive, optional
            None: a row of no drive (``mu``, ``h_L_m``).
        amplitude_V : float, optional, V
            None: a row of no amplitude (the power law's, the study's).
        analysis : str
            :data:`PRIMARY` by default.

        Returns
        -------
        PopulationRow or None
            None when the table has no such row (a drive of one amplitude has no primary
            F_el: its force is the meta-analysis's).

        Raises
        ------
        ResultFolderError
            Two rows share the key: the table is not one population's.
        """
        found = self._by_key.get((quantity, drive, amplitude_key(amplitude_V), analysis), [])
        if len(found) > 1:
            where = ", ".join(x for x in (drive.label() if drive else None,
                                          None if amplitude_V is None else f"{amplitude_V:g} V",
                                          analysis) if x)
            raise ResultFolderError(f"{len(found)} rows of {quantity} ({where}): a population "
                                    "table has one row per quantity, drive, amplitude and "
                                    "analysis", path=self.path)
        return found[0] if found else None

    def rows(self, quantity: str, drive: Drive | None = None, analysis: str = PRIMARY
             ) -> list[PopulationRow]:
        """The rows of a quantity, a drive and an analysis, by amplitude (those of no
        amplitude first).

        Parameters
        ----------
        quantity : str
        drive : Drive, optional
            None: the rows of no drive.
        analysis : str

        Returns
        -------
        list of PopulationRow
        """
        found = [r for r in self._rows
                 if (r.quantity, r.drive, r.analysis) == (quantity, drive, analysis)]
        return sorted(found, key=lambda r: -math.inf if r.amplitude_V is None
                      else r.amplitude_V)

    def checks(self, drive: Drive) -> Checks:
        """A drive's checks: as given, else from its primary rows' text (failed where the
        table says none: a drive without a mixed model).

        Parameters
        ----------
        drive : Drive

        Returns
        -------
        Checks
        """
        if drive in self._checks:
            return self._checks[drive]
        said = next((r.checks for r in self._rows if r.drive == drive
                     and r.analysis == PRIMARY and r.checks), "")
        return Checks.of_text(said)
