"""The key results as claims, then as text: each number the report leads with is a cell of
its table, named by its key.

:func:`key_claims` makes, for each drive (a waveform at a frequency), one claim per
amplitude of the relative friction increase (:func:`~evtribo.documents.quantities.
friction_increase_pct`) and of the electrostatic force F_el, and one of the exponent n of
F_el ∝ U^n; and one of the air gap h_L for the study. A claim is

- ``quoted``: population.csv's :data:`~evtribo.documents.population_table.PRIMARY` row of
  its key, shown as ``X [lo, hi]`` (the only way a number with an interval reaches the
  sentence);
- ``range``: with no such row (fewer than three subjects), the subjects' lowest and highest
  of the same quantity from electrostatic.csv's cells, labelled so;
- ``undetermined``: the row exists but the mixed model's checks it rests on failed
  (:meth:`~evtribo.documents.population_table.Checks.holds`): no number is shown;
- ``absent``: no row and nothing to range over (a drive of one amplitude has no primary
  F_el: its meta-analysis is in the Population section, never quoted as the population's).

:func:`key_sentence` writes one clause per drive from them; Table 1 of the report
(:mod:`evtribo.report.lead.key_results`) and ``evtribo compare``'s console read the same
claims.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from evtribo.documents.population_table import (
    EXPONENT,
    FORCE,
    PRIMARY,
    Drive,
    PopulationRow,
    PopulationTable,
)
from evtribo.documents.quantities import friction_increase_pct
from evtribo.population.stats import MIN_SUBJECTS
from evtribo.util.numbers import amplitude_key, significant, voltage, with_interval

__all__ = ["AIR_GAP", "INCREASE", "Quoted", "State", "drive_order", "exponent_claims",
           "key_claims",
           "key_sentence", "nb"]

#: population.csv's quantities the claims quote besides F_el and the exponent.
INCREASE, AIR_GAP = "friction_increase_pct", "h_L_m"
#: What a claim is: see the module's notes.
State = Literal["quoted", "range", "undetermined", "absent"]
#: Each quantity's unit as shown, and the factor from its SI value.
_SHOWN = {FORCE: (" mN", 1e3), INCREASE: (" %", 1.0), EXPONENT: ("", 1.0),
          AIR_GAP: (" µm", 1e6)}
_NBSP = "\u00a0"


def nb(text: str) -> str:
    """An interval whose brackets never break across lines.

    Parameters
    ----------
    text : str
        ``26.5 [25.7, 27.4]``.

    Returns
    -------
    str
        With non-breaking spaces inside the interval and before it.
    """
    return text.replace(" [", f"{_NBSP}[").replace(", ", f",{_NBSP}") if "[" in text else text


@dataclass(frozen=True)
class Quoted:
    """One claim of the key results.

    Attributes
    ----------
    drive : Drive or None
        None: a quantity of the study (h_L).
    quantity : str
        population.csv's ``quantity``.
    amplitude_V : float or None, V
        None: a quantity of no amplitude (the exponent, h_L).
    row : PopulationRow or None
        The :data:`~evtribo.documents.population_table.PRIMARY` row quoted, or whose checks
        failed; None for a range or an absent claim.
    state : str
        ``quoted``, ``range``, ``undetermined`` or ``absent``.
    text : str
        The value as shown, without its unit (``344 [138, 862]``, ``12 to 30``; the checks
        that failed for an undetermined one, "" for an absent one).
    """

    drive: Drive | None
    quantity: str
    amplitude_V: float | None
    row: PopulationRow | None
    state: State
    text: str

    @property
    def shown(self) -> str:
        """:attr:`text` with its unit (``344 [138, 862] mN``; "" unless quoted or a range)."""
        if self.state not in ("quoted", "range"):
            return ""
        return f"{self.text}{_SHOWN[self.quantity][0]}"

    @property
    def at(self) -> str:
        """``at 140 V`` ("" for a quantity of no amplitude)."""
        return "" if self.amplitude_V is None else f"at {voltage(self.amplitude_V)}"


def _cell_text(row: PopulationRow) -> str:
    factor = _SHOWN[row.quantity][1]
    return nb(with_interval(factor * row.estimate, factor * row.ci_low, factor * row.ci_high))


def _primary(table: PopulationTable | None, quantity: str, drive: Drive | None,
             amplitude_V: float | None) -> PopulationRow | None:
    return None if table is None else table.row(quantity, drive, amplitude_V, PRIMARY)


def _checked(table: PopulationTable, row: PopulationRow, quantity: str) -> Quoted | None:
    """An undetermined claim when the checks the row rests on failed (a row of no checks,
    not the mixed model's, rests on none)."""
    if not row.checks or row.drive is None:
        return None
    checks = table.checks(row.drive)
    if checks.holds(quantity):
        return None
    return Quoted(row.drive, quantity, row.amplitude_V, row, "undetermined",
                  checks.text or "the mixed model's checks failed")


def _claim(table: PopulationTable | None, quantity: str, drive: Drive | None,
           amplitude_V: float | None, values: np.ndarray) -> Quoted:
    """A key's claim: its primary row; else, of fewer than three subjects, their *values*'
    range."""
    row = _primary(table, quantity, drive, amplitude_V)
    if row is not None and table is not None:
        failed = _checked(table, row, quantity)
        return failed or Quoted(drive, quantity, amplitude_V, row, "quoted", _cell_text(row))
    factor = _SHOWN[quantity][1]
    v = factor * values[np.isfinite(values)]
    if v.size >= MIN_SUBJECTS:  # enough for a population estimate, which is not there
        return Quoted(drive, quantity, amplitude_V, None, "absent", "")
    if v.size >= 2:
        return Quoted(drive, quantity, amplitude_V, None, "range",
                      f"{significant(v.min())} to {significant(v.max())}")
    if v.size == 1:
        return Quoted(drive, quantity, amplitude_V, None, "range", significant(v[0]))
    return Quoted(drive, quantity, amplitude_V, None, "absent", "")


def _drive_cells(electrostatic: pd.DataFrame) -> dict[Drive, pd.DataFrame]:
    es = electrostatic
    freq = es["frequency_Hz"] if "frequency_Hz" in es.columns else pd.Series(
        [None] * len(es), index=es.index)
    keys = [Drive.of(w, f) for w, f in zip(es["waveform"], freq, strict=True)]
    return {d: es[[k == d for k in keys]] for d in sorted(set(keys))}


def drive_order(population: PopulationTable | None, electrostatic: pd.DataFrame
                ) -> list[Drive]:
    """The drives of the key results, in their order: those of more amplitudes first (a
    voltage sweep before a drive tried at one voltage), then as
    :meth:`~evtribo.documents.population_table.PopulationTable.drives` orders them.

    Parameters
    ----------
    population : PopulationTable or None
        population.csv.
    electrostatic : DataFrame
        electrostatic.csv.

    Returns
    -------
    list of Drive
    """
    cells = _drive_cells(electrostatic)
    drives = sorted({*cells, *(population.drives() if population is not None else [])})
    amps = {d: len({amplitude_key(a) for a in c["amplitude_V"]}) for d, c in cells.items()}
    return sorted(drives, key=lambda d: -amps.get(d, 0))


def exponent_claims(population: PopulationTable | None) -> list[Quoted]:
    """The exponent n of F_el ∝ U^n of each drive that has a power law's row: ``quoted``, or
    ``undetermined`` where the mixed model's checks failed (what ``evtribo compare`` says).

    Parameters
    ----------
    population : PopulationTable or None
        population.csv, with the checks of each drive.

    Returns
    -------
    list of Quoted
    """
    if population is None:
        return []
    found = [_claim(population, EXPONENT, d, None, np.zeros(0)) for d in population.drives()]
    return [c for c in found if c.state != "absent"]


def key_claims(population: PopulationTable | None, electrostatic: pd.DataFrame,
               fit: pd.DataFrame | None = None) -> list[Quoted]:
    """Every claim of the key results, drive by drive (:func:`drive_order`), then the study's.

    Parameters
    ----------
    population : PopulationTable or None
        population.csv, with fit.json's checks (None: no population estimates).
    electrostatic : DataFrame
        electrostatic.csv (its cells, for the subjects' ranges).
    fit : DataFrame, optional
        fit.csv (the subjects' h_L where the population has none).

    Returns
    -------
    list of Quoted
        Per drive: the relative friction increase and F_el at each amplitude, by
        amplitude, then the exponent; last the air gap h_L (drive None).
    """
    cells = _drive_cells(electrostatic)
    none = np.zeros(0)
    claims: list[Quoted] = []
    for drive in drive_order(population, electrostatic):
        mine = cells.get(drive, electrostatic.iloc[:0])
        amps = sorted({a for a in (amplitude_key(x) for x in mine["amplitude_V"])
                       if a is not None})
        at = [amplitude_key(x) for x in mine["amplitude_V"]]
        for amp in amps:
            here = mine[[a == amp for a in at]]
            force = here["electrostatic_force_N"].to_numpy(float)
            increase = friction_increase_pct(force, here["normal_force_on_N"].to_numpy(float)) \
                if "normal_force_on_N" in here.columns else none
            claims.append(_claim(population, INCREASE, drive, amp, increase))
            claims.append(_claim(population, FORCE, drive, amp, force))
        claims.append(_claim(population, EXPONENT, drive, None, none))
    h_l = none
    if fit is not None and not fit.empty and "parameter" in fit.columns:
        h_l = 1e-6 * _h_l_um(fit)
    claims.append(_claim(population, AIR_GAP, None, None, h_l))
    return claims


def _h_l_um(fit: pd.DataFrame) -> np.ndarray:
    rows = fit[fit["parameter"].astype(str) == "h_L"]
    return 1e6 * pd.to_numeric(rows["value"], errors="coerce").to_numpy(float)


def _of(claims: Sequence[Quoted], drive: Drive | None, quantity: str) -> list[Quoted]:
    return [c for c in claims if c.drive == drive and c.quantity == quantity]


def _increase_clause(mine: Sequence[Quoted]) -> str:
    shown = [c for c in mine if c.state in ("quoted", "range")]
    if not shown:
        return ""
    ends = [shown[0]] if len(shown) == 1 else [shown[0], shown[-1]]
    parts = " to ".join(f"{c.shown} {c.at}" for c in ends)
    ranged = any(c.state == "range" for c in ends)
    return ("the relative friction increase F_el/F_n,ON was " + parts
            + (" (the subjects' lowest to highest)" if ranged else ""))


def _force_clause(mine: Sequence[Quoted], amplitudes: int) -> str:
    quoted = [c for c in mine if c.state == "quoted"]
    if quoted:
        return f"the population's F_el was {quoted[-1].shown} {quoted[-1].at}"
    if any(c.state == "undetermined" for c in mine):
        return "the population's F_el is undetermined (the mixed model's checks failed)"
    ranged = [c for c in mine if c.state == "range"]
    if ranged:
        return (f"F_el was {ranged[-1].shown} {ranged[-1].at} (the subjects' lowest to "
                "highest)")
    if mine:
        why = "one amplitude" if amplitudes == 1 else "no mixed model"
        return (f"no population F_el ({why}: the meta-analysis, where valid, is in the "
                "Population section)")
    return ""


def _exponent_clause(mine: Sequence[Quoted]) -> str:
    for c in mine:
        if c.state == "quoted":
            return f"F_el grew as U^n with n = {c.text}"
        if c.state == "undetermined":
            return "its exponent n (F_el ∝ U^n) is undetermined (the mixed model's checks failed)"
    return ""


def _clause(claims: Sequence[Quoted], drive: Drive) -> str:
    increase = _of(claims, drive, INCREASE)
    parts = [_increase_clause(increase), _force_clause(_of(claims, drive, FORCE), len(increase)),
             _exponent_clause(_of(claims, drive, EXPONENT))]
    return f"{drive.label()}: " + "; ".join(p for p in parts if p)


def key_sentence(claims: Sequence[Quoted], *, n_subjects: int, excluded: Sequence[str] = (),
                 models_verdict: str = "", flagged: Sequence[str] = ()) -> str:
    """The key results in words: one clause per drive, then the study's air gap, the models'
    verdict and the warnings that may change the numbers.

    Parameters
    ----------
    claims : sequence of Quoted
        :func:`key_claims`'s.
    n_subjects : int
        Subjects with electrostatic forces.
    excluded : sequence of str
        Subjects the study excluded beforehand from the population's estimates.
    models_verdict : str
        The model comparison's verdict ("" when none).
    flagged : sequence of str
        The warnings that may change a number (``W1``...).

    Returns
    -------
    str
        ``3 subjects, square 10 kHz: ...; the population's F_el was 344 [138, 862] mN at
        140 V; .... Sine 10 Hz: .... The model's air gap h_L = 4.3 [2.4, 7.5] µm.``
    """
    drives = list(dict.fromkeys(c.drive for c in claims if c.drive is not None))
    head = f"{n_subjects} subject{'s' if n_subjects != 1 else ''}"
    if excluded:
        head += (f" ({', '.join(excluded)} excluded beforehand from the population's "
                 "estimates)")
    clauses = [_clause(claims, d) for d in drives]
    if clauses:
        first = clauses[0]
        clauses[0] = f"{head}, {first[:1].lower()}{first[1:]}"
    else:
        clauses = [head]
    text = ". ".join(c[:1].upper() + c[1:] for c in clauses) + "."
    gap = next(iter(_of(claims, None, AIR_GAP)), None)
    if gap is not None and gap.state == "quoted":
        text += f" The model's air gap h_L = {gap.shown}."
    elif gap is not None and gap.state == "range":
        text += f" The model's air gap h_L: {gap.shown} (the subjects' lowest to highest)."
    if models_verdict:
        text += f" Models: {models_verdict}."
    if flagged:
        text += (f" {len(flagged)} kind(s) of warning may change these numbers "
                 f"({', '.join(flagged)}).")
    return text

