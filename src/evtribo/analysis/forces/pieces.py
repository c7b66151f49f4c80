"""A trial's timestamps as they should be: in seconds, and continuous.

A log whose clock jumped (half of it shifted hours back by a logger's clock correction, a
day's jump of an unsynchronised PC) puts a gap of hours between the load cells' frames; a
uniform time grid across it would ask for memory in proportion to the hours, not to the
frames. :func:`continuous_pieces` cuts a trial where neither load cell sent a frame for
longer than :data:`MAX_PAUSE_S`, so that each piece is analysed on its own grid and memory
follows the number of frames, whatever the time span; the analysis says where it cut.

A log written in milliseconds where seconds are expected (an 8-s trial read as 8000 s)
shows load cells sending one frame a second or slower: :func:`check_seconds` refuses it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from evtribo.analysis.forces.align import nominal_period
from evtribo.canlog.signals import CellSignals, ExcitationSignals, TrialSignals
from evtribo.errors import AnalysisError
from evtribo.util.docstrings import fill_doc
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

__all__ = ["MAX_PAUSE_S", "MIN_RATE_HZ", "check_seconds", "continuous_pieces", "describe_gap",
           "restrict"]

emit = emitter(__name__)

#: Neither load cell silent for longer than this inside a piece, s.
MAX_PAUSE_S = 1.0
#: Slowest load cell taken for one: slower, the timestamps are not in seconds, Hz.
MIN_RATE_HZ = 5.0

FloatArray = npt.NDArray[np.float64]


def _times(signals: TrialSignals, name: str) -> FloatArray:
    """A load cell's finite sample times, s."""
    cell: CellSignals = getattr(signals, name)
    t = np.asarray(cell.t, dtype=np.float64)
    return t[np.isfinite(t)]


def check_seconds(signals: TrialSignals) -> None:
    """Refuse timestamps that are not in seconds (load cells slower than
    :data:`MIN_RATE_HZ`, by their median interval).

    Parameters
    ----------
    signals : TrialSignals
        The decoded trial; its load cells' times are read.

    Raises
    ------
    AnalysisError
        Naming the cells' rates and the span they give the trial.
    """
    rates = {}
    for name in ("normal", "tangential"):
        t = np.sort(_times(signals, name), kind="stable")  # sorted already: one pass
        if t.size >= 10:
            rates[name] = 1.0 / nominal_period(t)
    if rates and max(rates.values()) < MIN_RATE_HZ:
        t = np.concatenate([_times(signals, n) for n in ("normal", "tangential")])
        span = float(t.max() - t.min())
        raise AnalysisError(
            "the load cells' timestamps advance by "
            + " and ".join(f"{1 / r:.3g} s per frame ({name})" for name, r in rates.items())
            + f", which makes the trial {span:.0f} s long: are they in milliseconds (or "
            "another unit)? evtribo reads seconds, as candump and python-can write them; "
            "convert the log, or record it with evtribo acquire")


def continuous_pieces(signals: TrialSignals, max_pause_s: float = MAX_PAUSE_S
                      ) -> list[tuple[float, float]]:
    """The stretches of a trial with no pause longer than *max_pause_s* in both load cells.

    Parameters
    ----------
    signals : TrialSignals
        ``normal.t`` and ``tangential.t`` are read (s).
    max_pause_s : float
        Longest pause inside a piece, s.

    Returns
    -------
    list of (start, stop)
        Times of the first and last frame of each piece, in time order (one piece for a
        continuous trial; none without frames).
    """
    t = np.sort(np.concatenate([_times(signals, n) for n in ("normal", "tangential")]),
                kind="stable")  # two sorted runs: one merge
    if t.size == 0:
        return []
    cut = np.flatnonzero(np.diff(t) > max_pause_s)
    starts = np.concatenate(([0], cut + 1))
    stops = np.concatenate((cut, [t.size - 1]))
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, stops, strict=True)]


def describe_gap(before: tuple[float, float], after: tuple[float, float], t0: float
                 ) -> WarningRecord:
    """Say the pause between two pieces (``pause``).

    Parameters
    ----------
    before, after : (float, float)
        The two pieces' first and last times, s.
    t0 : float
        The trial's start (times are said from it), s.

    Returns
    -------
    WarningRecord
        The warning said.
    """
    return emit("pause", gap_s=after[0] - before[1], at_s=before[1] - t0)


def _kept(t: FloatArray, lo: float, hi: float) -> npt.NDArray[np.bool_]:
    """Which of the times *t* lie in ``[lo, hi]``."""
    t = np.asarray(t, dtype=np.float64)
    return (t >= lo) & (t <= hi)


def _cut_cell(cell: CellSignals, lo: float, hi: float) -> CellSignals:
    """A load cell's samples of time in ``[lo, hi]`` (its count of missing frames kept:
    the trial's)."""
    keep = _kept(cell.t, lo, hi)
    return dataclasses.replace(cell, t=cell.t[keep], value=cell.value[keep],
                               counter=None if cell.counter is None else cell.counter[keep])


def _cut_excitation(exc: ExcitationSignals, lo: float, hi: float) -> ExcitationSignals:
    """The amplifier's status of time in ``[lo, hi]``."""
    keep = _kept(exc.t, lo, hi)
    return ExcitationSignals(
        t=exc.t[keep], enabled=None if exc.enabled is None else exc.enabled[keep],
        amplitude=None if exc.amplitude is None else exc.amplitude[keep],
        frequency=None if exc.frequency is None else exc.frequency[keep],
        waveform=None if exc.waveform is None else exc.waveform[keep])


@fill_doc
def restrict(signals: TrialSignals, lo: float, hi: float) -> TrialSignals:
    """The trial's signals between two times.

    Parameters
    ----------
    %(signals)s
    lo, hi : float
        The stretch's first and last time, s.

    Returns
    -------
    TrialSignals
        The load cells' samples in ``[lo, hi]``, and the amplifier's status (with its last
        status shortly before *lo*, which holds there); the counts are the whole trial's.
    """
    exc = signals.excitation
    if exc is not None and len(exc.t):
        te = np.asarray(exc.t, dtype=np.float64)
        before = te[(te < lo) & (te >= lo - MAX_PAUSE_S)]
        start = float(before.max()) if before.size else lo
        exc = _cut_excitation(exc, start, hi)
    return dataclasses.replace(signals, normal=_cut_cell(signals.normal, lo, hi),
                               tangential=_cut_cell(signals.tangential, lo, hi),
                               excitation=exc)
