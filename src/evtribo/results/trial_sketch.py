"""A trial's check as kept: what its figure draws, made while the trial is analysed.

``evtribo analyze`` hands each continuous piece of a trial to a :class:`Sketcher` (an
observer of :func:`~evtribo.analysis.trial.analyze_signals`), which keeps of it only what
the check's figure (:mod:`evtribo.figures.trial_plots`) draws: the forces as analysed,
reduced to their envelope (:func:`envelope`, at most :data:`MAX_POINTS` points a line), the
ON phases, what no window may use and why (:class:`Stretch`), and each window's span and
mean forces. A :class:`TrialSketch` is a few tens of kB (:meth:`TrialSketch.to_bytes`), kept
beside the trial's outcome (:mod:`evtribo.results.reuse`), so that ``evtribo compare``
draws every trial's check without reading or analysing a trial again.

The bytes of a sketch are a function of the analysis alone (no time, no path), so that a
sketch made again from the same trial is the same bytes (its figure's key).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from evtribo.analysis.forces.conditions import EXCLUDED, OFF, ON
from evtribo.analysis.forces.lifted import EDGE_S
from evtribo.analysis.piece_observer import PieceState
from evtribo.util.running import true_runs

__all__ = ["MAX_POINTS", "MIN_HOLE_S", "STRETCH_LABELS", "SketchPiece", "Sketcher",
           "Stretch", "TrialSketch", "envelope", "piece_stretches"]

#: Most points drawn per force line (longer traces are drawn as their min/max envelope).
MAX_POINTS = 4000

#: Holes in the load cells' data, and stretches of unknown state, shorter than this are not
#: listed (a frame or two lost; the moment before the amplifier's first status frame), s.
MIN_HOLE_S = 0.02

#: What each kind of :class:`Stretch` is, in a few words (a figure's legend).
STRETCH_LABELS = {
    "lifted": "finger lifted: zero read",
    "lift-edge": "finger leaving / touching down",
    "switch": "ON/OFF switch (guard)",
    "unknown": "ON/OFF unknown (no status)",
    "hole": "load-cell frames missing",
    "pause": "pause in the log",
}

#: The first bytes of a sketch (:meth:`TrialSketch.to_bytes`), with its version.
_MAGIC = b"evtribo-sketch 1\n"


@dataclass(frozen=True)
class Stretch:
    """A stretch of a trial that the windows do not use, and why.

    Attributes
    ----------
    t_start, t_end : float, s
        From the trial's start.
    kind : str
        A key of :data:`STRETCH_LABELS`: ``lifted`` (the zero was read there), ``lift-edge``,
        ``switch``, ``unknown``, ``hole`` or ``pause``.
    """

    t_start: float
    t_end: float
    kind: str

    @property
    def label(self) -> str:
        """What the stretch is, in a few words."""
        return STRETCH_LABELS[self.kind]


def envelope(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64]
             ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """A trace as drawn: its samples, or for a long one the minimum and maximum of each of
    :data:`MAX_POINTS` / 2 bins (what the pixels would show anyway; a bin without samples
    breaks the line).

    Parameters
    ----------
    t : ndarray of float64
        Times, increasing.
    y : ndarray of float64
        Values (NaN where missing).

    Returns
    -------
    (ndarray, ndarray)
        The times and values to draw.
    """
    if t.size <= MAX_POINTS:
        return t, y
    starts = np.linspace(0, t.size, MAX_POINTS // 2, endpoint=False).astype(np.int64)
    with np.errstate(invalid="ignore"):
        lo = np.fmin.reduceat(y, starts)
        hi = np.fmax.reduceat(y, starts)
    stops = np.append(starts[1:], t.size)
    mid = t[(starts + stops - 1) // 2]
    return (np.column_stack([t[starts], mid]).ravel(), np.column_stack([lo, hi]).ravel())


def _runs_of(mask: npt.NDArray[np.bool_], t: npt.NDArray[np.float64], dt: float
             ) -> list[tuple[int, int, float, float]]:
    """``(i0, i1, t_start, t_end)`` of the runs of True in *mask*."""
    return [(a, b, float(t[a]), float(t[b - 1] + dt)) for a, b in true_runs(mask)]


def _condition_stretches(piece: PieceState, t: npt.NDArray[np.float64], dt: float
                         ) -> list[Stretch]:
    """Guard times around switches, and where no status frame tells the state."""
    cond = piece.condition
    out = []
    for a, b, t_start, t_end in _runs_of(cond == EXCLUDED, t, dt):
        before = int(cond[a - 1]) if a > 0 else EXCLUDED
        after = int(cond[b]) if b < cond.size else EXCLUDED
        kind = "switch" if {before, after} == {ON, OFF} else "unknown"
        if kind == "switch" or t_end - t_start >= MIN_HOLE_S:
            out.append(Stretch(t_start, t_end, kind))
    return out


def _lift_stretches(piece: PieceState, t0: float, span: tuple[float, float]) -> list[Stretch]:
    """The finger-lifted stretches and the margins around them that no window uses."""
    out = []
    lo, hi = span
    for s in piece.lifted:
        a, b = s.t_start - t0, s.t_end - t0
        out.append(Stretch(a, b, "lifted"))
        if a > lo:
            out.append(Stretch(max(lo, a - 2 * EDGE_S), a, "lift-edge"))
        if b < hi:
            out.append(Stretch(b, min(hi, b + 2 * EDGE_S), "lift-edge"))
    return out


def piece_stretches(piece: PieceState, t0: float) -> tuple[list[Stretch], tuple[float, float]]:
    """What the windows of one piece could not use, and the piece's span.

    Parameters
    ----------
    piece : PieceState
        The piece as analysed.
    t0 : float, s
        The trial's start on the log's clock.

    Returns
    -------
    (list of Stretch, (float, float))
        Lifted stretches and their edges, guard times, stretches of unknown state and holes
        of at least :data:`MIN_HOLE_S` (times from the trial's start, not sorted); the
        piece's first time and its last plus a grid step, s (NaN for an empty piece).
    """
    f = piece.forces
    if f.t.size == 0:
        return [], (math.nan, math.nan)
    dt = 1.0 / f.rate_Hz
    t = f.t - t0
    span = (float(t[0]), float(t[-1] + dt))
    out = _condition_stretches(piece, t, dt) + _lift_stretches(piece, t0, span)
    hole = ~(np.isfinite(f.normal) & np.isfinite(f.tangential))
    out += [Stretch(a, b, "hole") for _, _, a, b in _runs_of(hole, t, dt) if b - a >= MIN_HOLE_S]
    return out, span


def _on_spans(piece: PieceState, t0: float, lifted: Sequence[Stretch]
              ) -> list[tuple[float, float]]:
    """The piece's ON phases, each as its grid points' span; a lifted stretch is not ON."""
    t = piece.forces.t - t0
    dt = 1.0 / piece.forces.rate_Hz
    on = piece.condition == ON
    for s in lifted:  # a lifted stretch shows as lifted, not in a mix of colours
        on &= ~((t + dt > s.t_start) & (t < s.t_end))
    edges = np.flatnonzero(np.diff(np.concatenate(([0], on.view(np.int8), [0]))))
    return [(float(t[a]), float(t[b - 1] + dt)) for a, b in
            zip(edges[::2], edges[1::2], strict=True)]


@dataclass(frozen=True)
class SketchPiece:
    """One continuous piece of a trial as its check draws it.

    Attributes
    ----------
    t : ndarray of float32, s
        From the trial's start, the forces' envelope's times (:func:`envelope`).
    normal, tangential : ndarray of float32, N
        The forces as analysed (calibrated, tared, hum removed), as enveloped.
    span : (float, float), s
        The piece's first time and its last plus a grid step.
    on : ndarray of float64, shape (k, 2), s
        The ON phases' starts and ends.
    windows : ndarray of float64, shape (m, 4)
        Each window's start and end (s), mean normal force and mean friction with the
        stroke's sign (N).
    window_on : ndarray of bool, shape (m,)
        Whether each window is ON.
    stretches : list of Stretch
        What the windows could not use (:func:`piece_stretches`).
    """

    t: npt.NDArray[np.float32]
    normal: npt.NDArray[np.float32]
    tangential: npt.NDArray[np.float32]
    span: tuple[float, float]
    on: npt.NDArray[np.float64]
    windows: npt.NDArray[np.float64]
    window_on: npt.NDArray[np.bool_]
    stretches: list[Stretch] = field(default_factory=list)


def _sketch_piece(piece: PieceState, t0: float) -> SketchPiece:
    """What the check draws of one piece."""
    stretches, span = piece_stretches(piece, t0)
    t = piece.forces.t - t0
    tt, normal = envelope(t, piece.forces.normal)
    _, tangential = envelope(t, piece.forces.tangential)
    w = piece.windows
    if w.empty:
        bars = np.empty((0, 4))
        on = np.empty(0, dtype=bool)
    else:
        bars = np.column_stack([
            w.t_start.to_numpy(np.float64) - t0, w.t_end.to_numpy(np.float64) - t0,
            w.normal_force_N.to_numpy(np.float64),
            w.direction.to_numpy(np.float64) * w.friction_force_N.to_numpy(np.float64)])
        on = w.condition.astype(str).to_numpy() == "on"
    spans = _on_spans(piece, t0, [s for s in stretches if s.kind == "lifted"])
    return SketchPiece(tt.astype(np.float32), normal.astype(np.float32),
                       tangential.astype(np.float32), span,
                       np.asarray(spans, dtype=np.float64).reshape(-1, 2), bars, on, stretches)


#: The values of a trial's row of trials.csv that a check's caption tells.
ROW_KEYS = ("waveform", "frequency_Hz", "amplitude_V", "tare")


def _plain(value: Any) -> Any:
    """A row's value as JSON holds it (None for a missing number)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value if isinstance(value, (str, int, float, bool)) or value is None else str(value)


@dataclass(frozen=True)
class TrialSketch:
    """A trial's check, as its figure draws it.

    Attributes
    ----------
    subject, trial : str
        The trial's names.
    pieces : list of SketchPiece
        Each continuous piece analysed, in order.
    row : dict
        Of its row of trials.csv, the values the caption tells (:data:`ROW_KEYS`).
    """

    subject: str
    trial: str
    pieces: list[SketchPiece]
    row: dict[str, Any]

    @property
    def key(self) -> str:
        """``subject/trial``."""
        return f"{self.subject}/{self.trial}"

    @property
    def stretches(self) -> list[Stretch]:
        """What the windows could not use, the pauses between pieces with it, in time
        order (times from the trial's start)."""
        out: list[Stretch] = []
        previous_end = None
        for p in self.pieces:
            if not math.isfinite(p.span[0]):
                continue
            if previous_end is not None and p.span[0] > previous_end:
                out.append(Stretch(previous_end, p.span[0], "pause"))
            previous_end = p.span[1]
            out += p.stretches
        return sorted(out, key=lambda s: (s.t_start, s.t_end))

    def to_bytes(self) -> bytes:
        """The sketch as bytes: a JSON header and the arrays (little-endian), the same bytes
        for the same sketch.

        Returns
        -------
        bytes
        """
        head = {"subject": self.subject, "trial": self.trial,
                "row": {k: _plain(self.row.get(k)) for k in ROW_KEYS},
                "pieces": [{"points": int(p.t.size), "span": list(p.span),
                            "on": int(p.on.shape[0]), "windows": int(p.windows.shape[0]),
                            "stretches": [[s.t_start, s.t_end, s.kind] for s in p.stretches]}
                           for p in self.pieces]}
        text = json.dumps(head, sort_keys=True, allow_nan=True).encode()
        parts = [_MAGIC, len(text).to_bytes(8, "little"), text]
        for p in self.pieces:
            parts += [np.ascontiguousarray(a, dtype="<f4").tobytes()
                      for a in (p.t, p.normal, p.tangential)]
            parts += [np.ascontiguousarray(p.on, dtype="<f8").tobytes(),
                      np.ascontiguousarray(p.windows, dtype="<f8").tobytes(),
                      np.ascontiguousarray(p.window_on, dtype="u1").tobytes()]
        return b"".join(parts)

    @classmethod
    def from_bytes(cls, data: bytes) -> TrialSketch:
        """The sketch :meth:`to_bytes` wrote.

        Parameters
        ----------
        data : bytes

        Returns
        -------
        TrialSketch

        Raises
        ------
        ValueError
            Not the bytes of a sketch of this version.
        """
        if not data.startswith(_MAGIC):
            raise ValueError("not a trial's sketch of this version")
        at = len(_MAGIC) + 8
        size = int.from_bytes(data[len(_MAGIC):at], "little")
        head = json.loads(data[at:at + size])
        at += size

        def take(dtype: str, count: int) -> npt.NDArray[Any]:
            nonlocal at
            width = np.dtype(dtype).itemsize * count
            if at + width > len(data):
                raise ValueError("a sketch cut short")
            out = np.frombuffer(data, dtype=dtype, count=count, offset=at).copy()
            at += width
            return out

        pieces = []
        for p in head["pieces"]:
            n = int(p["points"])
            t, normal, tangential = (take("<f4", n) for _ in range(3))
            on = take("<f8", 2 * int(p["on"])).reshape(-1, 2)
            bars = take("<f8", 4 * int(p["windows"])).reshape(-1, 4)
            window_on = take("u1", int(p["windows"])).astype(bool)
            pieces.append(SketchPiece(t, normal, tangential, (float(p["span"][0]),
                                                              float(p["span"][1])),
                                      on, bars, window_on,
                                      [Stretch(float(a), float(b), str(k))
                                       for a, b, k in p["stretches"]]))
        if at != len(data):
            raise ValueError("bytes after the sketch's end")
        return cls(str(head["subject"]), str(head["trial"]), pieces, dict(head["row"]))


class Sketcher:
    """An observer of a trial's analysis that keeps what its check draws.

    Parameters
    ----------
    t0 : float, s
        The trial's start on the log's clock (:func:`~evtribo.analysis.trial.trial_start`).
    """

    def __init__(self, t0: float) -> None:
        self.t0 = t0
        self.pieces: list[SketchPiece] = []

    def __call__(self, piece: PieceState) -> None:
        """Keep what the check draws of one analysed piece.

        Parameters
        ----------
        piece : PieceState
            What the analysis of the piece worked on.
        """
        self.pieces.append(_sketch_piece(piece, self.t0))

    def sketch(self, subject: str, trial: str, row: Mapping[str, Any]) -> TrialSketch:
        """The trial's sketch, once every piece is analysed.

        Parameters
        ----------
        subject, trial : str
            The trial's names.
        row : mapping
            Its row of trials.csv.

        Returns
        -------
        TrialSketch
        """
        return TrialSketch(subject, trial, list(self.pieces),
                           {k: _plain(row.get(k)) for k in ROW_KEYS})
