"""What each signal of a log does: rate, min / mean / max, and its behaviour.

>>> frames, _ = read_frames("P01/run-01.log")                       # doctest: +SKIP
>>> stats = signal_stats(frames, load_dbc("rig/loadcells.dbc"))      # doctest: +SKIP
>>> stats["FzCell.Fz"].positive_fraction, stats["FxCell.Fx"].sign_changes_per_s  # doctest: +SKIP
(0.97, 1.4)

The behaviour is what tells a rig's signals apart when their names do not (``Ch1``,
``Ch2``): the normal force is positive and steady, the tangential force changes sign with
every stroke, a status signal switches between a few values, a rolling counter counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database

from evtribo.canlog.decode import DecodedMessage, decode_messages
from evtribo.canlog.io import FrameTable

__all__ = ["SignalStats", "signal_stats"]

#: A crossing of zero counts only from below -h to above +h (or back), with h this share of
#: the signal's 90th percentile of |value|: noise around zero is not a change of sign.
HYSTERESIS_SHARE = 0.25
#: At most this many distinct values are counted exactly (a continuous signal has more).
DISTINCT_CAP = 1000


@dataclass(frozen=True)
class SignalStats:
    """One signal of a log, decoded with a DBC.

    Attributes
    ----------
    message, signal : str
        Names in the DBC.
    unit : str
        The DBC's unit (empty when it has none).
    frame_id : int
    is_extended : bool
    frames : int
        Frames of the message in the log.
    rate_Hz : float, Hz
        Mean rate of the message (NaN with fewer than two frames).
    minimum, mean, maximum, std : float, in the signal's unit
        Of the physical values (NaN where a multiplexed signal is absent).
    distinct : int
        Distinct values (counted up to :data:`DISTINCT_CAP`).
    positive_fraction : float
        Share of the values above zero.
    sign_changes_per_s : float, 1/s
        Changes of sign per second, with hysteresis (:data:`HYSTERESIS_SHARE`).
    switches : int
        Changes of value between consecutive frames.
    counting_fraction : float
        Share of consecutive raw values that go up by one (modulo the signal's range): near 1
        for a rolling counter; NaN for a signal that is not an unsigned integer.
    choices : tuple of str
        The names of the DBC's value table, if it has one.
    bits : int
    """

    message: str
    signal: str
    unit: str
    frame_id: int
    is_extended: bool
    frames: int
    rate_Hz: float
    minimum: float
    mean: float
    maximum: float
    std: float
    distinct: int
    positive_fraction: float
    sign_changes_per_s: float
    switches: int
    counting_fraction: float
    choices: tuple[str, ...]
    bits: int

    @property
    def qualified_name(self) -> str:
        """``"Message.Signal"``."""
        return f"{self.message}.{self.signal}"

    @property
    def behaviour(self) -> str:
        """``"counter"``, ``"constant"``, ``"switching"`` (a few values) or
        ``"continuous"``."""
        if self.counting_fraction >= 0.9 and self.distinct > 2:
            return "counter"
        if self.distinct <= 1:
            return "constant"
        if self.distinct <= 8:
            return "switching"
        return "continuous"


def sign_changes(values: npt.NDArray[np.float64]) -> int:
    """Changes of sign of *values*, counting a crossing only from below ``-h`` to above
    ``+h`` or back, with ``h`` = :data:`HYSTERESIS_SHARE` of the 90th percentile of |values|.

    Parameters
    ----------
    values : ndarray of float64
        A signal in time order (NaN ignored).

    Returns
    -------
    int
        The number of changes.
    """
    v = values[np.isfinite(values)]
    if v.size < 2:
        return 0
    h = HYSTERESIS_SHARE * float(np.percentile(np.abs(v), 90))
    if h <= 0:
        return 0
    state = np.where(v > h, 1, np.where(v < -h, -1, 0))
    state = state[state != 0]
    return int(np.count_nonzero(np.diff(state)))


def _counting_fraction(raw: npt.NDArray[np.generic], bits: int, integer: bool) -> float:
    """Share of consecutive raw values that go up by one, modulo 2**bits."""
    if not integer or raw.size < 3 or bits > 62:
        return math.nan
    r = np.asarray(raw, dtype=np.float64)
    r = r[np.isfinite(r)].astype(np.int64)
    if r.size < 3:
        return math.nan
    step = np.diff(r) % (1 << bits)
    return float(np.mean(step == 1))


def _one_signal(msg: DecodedMessage, name: str, db: Database) -> SignalStats:
    """The statistics of signal *name* of one decoded message."""
    message = db.get_message_by_name(msg.name)
    sig = message.get_signal_by_name(name)
    t = msg.timestamp
    order = np.argsort(t, kind="stable")
    t = t[order]
    values = msg.scaled(name)[order]
    raw = msg.raw[name][order]
    finite = values[np.isfinite(values)]
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    n = int(t.size)
    integer = (not sig.is_signed and not sig.is_float and sig.scale == 1 and sig.offset == 0)
    distinct = int(np.unique(finite[: 100_000]).size) if finite.size else 0
    choices = tuple(str(v) for v in (sig.choices or {}).values())
    if finite.size == 0:
        lo = mean = hi = std = pos = math.nan
    else:
        lo, hi = float(finite.min()), float(finite.max())
        mean, std = float(finite.mean()), float(finite.std())
        pos = float(np.mean(finite > 0))
    return SignalStats(
        message=msg.name, signal=name, unit=sig.unit or "", frame_id=msg.frame_id,
        is_extended=msg.is_extended, frames=n,
        rate_Hz=(n - 1) / span if span > 0 else math.nan,
        minimum=lo, mean=mean, maximum=hi, std=std, distinct=min(distinct, DISTINCT_CAP),
        positive_fraction=pos,
        sign_changes_per_s=sign_changes(values) / span if span > 0 else math.nan,
        switches=int(np.count_nonzero(np.diff(finite) != 0)) if finite.size > 1 else 0,
        counting_fraction=_counting_fraction(raw, sig.length, integer),
        choices=choices, bits=int(sig.length))


def signal_stats(frames: FrameTable, db: Database) -> dict[str, SignalStats]:
    """The statistics of every signal of *db* present in *frames*.

    Parameters
    ----------
    frames : FrameTable
        A log's frames (:func:`evtribo.canlog.io.read_frames`).
    db : cantools Database
        The rig's DBC.

    Returns
    -------
    dict of str to SignalStats
        By ``"Message.Signal"``, in the DBC's order; messages the log lacks are left out.
    """
    out: dict[str, SignalStats] = {}
    for msg in decode_messages(frames, db).values():
        if len(msg) == 0:
            continue
        for name in msg.raw:
            s = _one_signal(msg, name, db)
            out[s.qualified_name] = s
    return out
