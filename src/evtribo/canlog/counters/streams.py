"""The frames lost from a trial's load cells, counted one way wherever the frames come from.

The analysis counts them in a log (:func:`evtribo.canlog.decode.decode_trial`); the recorder
counts them as frames arrive (:class:`evtribo.acquisition.counters.CounterTracker`, the
trial's sidecar and the live display). Both hand each cell's frames, as received, to
:func:`count_cells`, which does what the analysis does and nothing else:

1. the counter's law (:func:`evtribo.canlog.counters.law.counter_law`: its period, step and
   start, whether it counts at all), or the law given (a period the rig file declares is
   used as it is);
2. the frames put in the order sent (:func:`evtribo.canlog.sequence.sending_order`:
   duplicates, late frames, a counter that stood still, restarts and the logger's clock
   steps, judged by the frames' upper envelope either side of a step);
3. the clock steps the cells saw taken out of every frame after them, the cells put in
   order again on the clock put right (:func:`~evtribo.canlog.sequence.log_clock_steps`);
4. the frames missing counted (:func:`evtribo.canlog.dropped.missing_frames_received`:
   the counter's, whole counter periods the timing shows in a pause, never more than the
   time holds; the timing's where the counter does not count).

So the sidecar's ``dropped_frames`` is the count ``evtribo analyze`` gives for the same log.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.canlog import sequence
from evtribo.canlog.counters.law import CounterLaw, counter_law
from evtribo.canlog.dropped import DropCount, missing_frames_received

__all__ = ["CellCount", "CellFrames", "CounterSignal", "count_cell", "count_cells"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class CounterSignal:
    """A load cell's counter signal, as its law is read.

    Attributes
    ----------
    bits : int
        The signal's width, bits.
    declared : int or None
        The period the rig file declares (frames), used as it is.
    name : str
        The counter (``FzCell.FzCounter``), for the notes.
    key : str
        The rig file's key that declares its period, for the notes.
    """

    bits: int
    declared: int | None = None
    name: str = "of this cell"
    key: str = "normal_force_counter_period"


@dataclass
class CellFrames:
    """One load cell's frames, in the order received.

    Attributes
    ----------
    rows : ndarray of int
        Their positions in the log (increasing).
    raw : ndarray of int or None
        The counter's values (None: the cell has no counter in its message).
    payload : ndarray of uint8, 2-D
        The frames' payloads, one row each (a duplicate has the counter and the payload of
        a frame just before).
    counter : CounterSignal or None
        The counter signal (None: no counter).
    law : CounterLaw or None
        The counter's law, used as it is (None: read from the frames).
    """

    rows: IntArray
    raw: IntArray | None
    payload: npt.NDArray[np.uint8]
    counter: CounterSignal | None = None
    law: CounterLaw | None = None


@dataclass
class CellCount:
    """What :func:`count_cell` makes of one cell's frames.

    Attributes
    ----------
    law : CounterLaw or None
        The counter's law (None: no counter).
    modulus : int or None
        The period of the counter's places in *seq* (None: no counter to trust).
    seq : Sequenced
        The frames in the order sent.
    found : DropCount
        The frames missing.
    """

    law: CounterLaw | None
    modulus: int | None
    seq: sequence.Sequenced
    found: DropCount

    @property
    def counted(self) -> bool:
        """Whether the counter counted the frames lost (it counts, and was not ignored for
        counting more than the time holds)."""
        return (self.seq.counter is not None and self.modulus is not None
                and not self.found.counter_ignored)


def _ordered(t: FloatArray, cell: CellFrames) -> tuple[CounterLaw | None, sequence.Sequenced,
                                                       int | None]:
    """*cell*'s counter law and its frames in the order sent, at the times *t*."""
    law = cell.law
    received = modulus = None
    if cell.raw is not None and cell.counter is not None:
        if law is None:
            spec = cell.counter
            law = counter_law(t, cell.raw, spec.bits, declared=spec.declared, name=spec.name,
                              key=spec.key)
        if law.counts:
            received, modulus = law.place(cell.raw), law.period
    return law, sequence.sending_order(t, received, modulus, cell.payload), modulus


def count_cell(t: npt.ArrayLike, cell: CellFrames) -> CellCount:
    """One cell's frames lost, on its own (no other cell's clock steps).

    Parameters
    ----------
    t : array_like of float, s
        The cell's timestamps, in the order received.
    cell : CellFrames
        Its frames.

    Returns
    -------
    CellCount
    """
    law, seq, modulus = _ordered(np.asarray(t, dtype=np.float64), cell)
    return CellCount(law, modulus, seq, missing_frames_received(seq.t, seq.counter, modulus))


def count_cells(t: npt.ArrayLike, cells: list[CellFrames]
                ) -> tuple[FloatArray, list[CellCount], list[tuple[int, int, float, float]]]:
    """The frames lost from each cell of one log, as the analysis counts them (see the
    module's docstring).

    Parameters
    ----------
    t : array_like of float, s
        The log's timestamps, in its order (the cells' rows index it).
    cells : list of CellFrames
        Each cell's frames.

    Returns
    -------
    t : ndarray of float, s
        The log's timestamps with the logger's clock steps taken out.
    counts : list of CellCount
        Each cell's, in the order of *cells*.
    steps : list of (int, int, float, float)
        The clock steps (:func:`~evtribo.canlog.sequence.log_clock_steps`).
    """
    times = np.asarray(t, dtype=np.float64)

    def each(at: FloatArray) -> list[tuple[CounterLaw | None, sequence.Sequenced, int | None]]:
        return [_ordered(at[cell.rows], cell) for cell in cells]

    ordered = each(times)
    steps = sequence.log_clock_steps([(cell.rows, seq) for cell, (_, seq, _)
                                      in zip(cells, ordered, strict=True)])
    if steps:
        times = sequence.clock_corrected(times, [(b, a, step) for b, a, step, _ in steps])
        ordered = each(times)
    return times, [CellCount(law, modulus, seq,
                             missing_frames_received(seq.t, seq.counter, modulus))
                   for law, seq, modulus in ordered], steps
