"""Any signal of any CAN log over time (what ``evtribo plot LOG --dbc FILE SIGNAL...`` draws).

The signals are named as ``Signal`` (every message's signal of that name) or
``Message.Signal``, or by shell-style patterns (``Fz*``, ``FzCell.*``), as cantools' ``plot``
takes them. Signals that share a unit share a panel, whose axis names the unit; a signal
without a unit gets a panel of its own. Time counts from the log's first frame.
"""

from __future__ import annotations

import difflib
import fnmatch
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from evtribo.canlog.decode import decode_messages
from evtribo.canlog.io import FrameTable
from evtribo.errors import UserInputError
from evtribo.figures.trial_plots import envelope

__all__ = ["LogSignal", "decode_signals", "on_channel", "plot_signals", "resolve_signals"]

#: How many of the DBC's signal names an error lists at most.
_MAX_LISTED = 40


@dataclass(frozen=True)
class LogSignal:
    """One signal of a log, decoded.

    Attributes
    ----------
    message, name : str
        Its message and name in the DBC.
    unit : str
        Its unit (empty when the DBC gives none).
    t : ndarray of float64, s
        Times of its frames, from the log's first frame.
    value : ndarray of float64
        Its physical values (scaled; value-table codes as numbers).
    """

    message: str
    name: str
    unit: str
    t: npt.NDArray[np.float64]
    value: npt.NDArray[np.float64]

    @property
    def qualified_name(self) -> str:
        """``Message.Signal``."""
        return f"{self.message}.{self.name}"


def resolve_signals(db: Database, asked: Sequence[str], *,
                    dbc_path: str | os.PathLike[str] | None = None) -> list[tuple[str, str]]:
    """The ``(message, signal)`` pairs *asked* names, in the order asked.

    Parameters
    ----------
    db : cantools.database.can.Database
        The DBC.
    asked : sequence of str
        ``Signal``, ``Message.Signal`` or a shell-style pattern of either.
    dbc_path : path-like, optional
        The DBC's file, named in errors.

    Returns
    -------
    list of (str, str)
        Each pair once.

    Raises
    ------
    UserInputError
        A name or pattern that matches no signal, naming the DBC's signals.
    """
    known = [(m.name, s.name) for m in db.messages for s in m.signals]
    out: list[tuple[str, str]] = []
    for text in asked:
        found = [(m, s) for m, s in known
                 if fnmatch.fnmatchcase(s, text) or fnmatch.fnmatchcase(f"{m}.{s}", text)]
        if not found:
            names = [f"{m}.{s}" for m, s in known]
            close = difflib.get_close_matches(text, names + [s for _, s in known], n=3,
                                              cutoff=0.5)
            hint = f"did you mean {', '.join(close)}? " if close else ""
            listed = ", ".join(names[:_MAX_LISTED]) + (
                f" and {len(names) - _MAX_LISTED} more" if len(names) > _MAX_LISTED else "")
            raise UserInputError(f"no signal {text!r} in the DBC; {hint}its signals: "
                                 f"{listed or 'none'}", path=dbc_path, key=text)
        out += [pair for pair in found if pair not in out]
    return out


def decode_signals(frames: FrameTable, db: Database, pairs: Sequence[tuple[str, str]]
                   ) -> list[LogSignal]:
    """The signals *pairs* name, decoded from a log's frames.

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    db : cantools.database.can.Database
        The DBC.
    pairs : sequence of (str, str)
        ``(message, signal)`` (:func:`resolve_signals`).

    Returns
    -------
    list of LogSignal
        In the order of *pairs*; a signal whose message has no frame in the log is left
        out.
    """
    decoded = decode_messages(frames, db, messages=sorted({m for m, _ in pairs}))
    t0 = float(np.nanmin(frames.timestamp)) if len(frames) else 0.0
    out = []
    for message, name in pairs:
        if message not in decoded:
            continue
        m = decoded[message]
        unit = db.get_message_by_name(message).get_signal_by_name(name).unit or ""
        out.append(LogSignal(message, name, unit, np.asarray(m.timestamp, np.float64) - t0,
                             np.asarray(m.scaled(name), dtype=np.float64)))
    return out


def on_channel(frames: FrameTable, channel: str | None, log_path: str | os.PathLike[str]
               ) -> FrameTable:
    """The frames of one channel (bus) of a log, or all of them.

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    channel : str or None
        The channel (None: every frame).
    log_path : path-like
        The log, named in errors.

    Returns
    -------
    FrameTable

    Raises
    ------
    UserInputError
        The log has no such channel, naming those it has.
    """
    if channel is None:
        return frames
    if channel not in frames.channel_names:
        have = ", ".join(frames.channel_names) or "none (its format names no channel)"
        raise UserInputError(f"the log has no channel {channel!r}; its channels: {have}",
                             path=log_path, key="--channel")
    return frames.take(frames.on_channel(channel))


def _panels(signals: Sequence[LogSignal]) -> list[list[LogSignal]]:
    """Signals grouped by unit (in the order first seen); each one without a unit alone."""
    groups: dict[str, list[LogSignal]] = {}
    for i, s in enumerate(signals):
        groups.setdefault(s.unit or f"\0{i}", []).append(s)
    return list(groups.values())


def plot_signals(signals: Sequence[LogSignal], fig: Figure | None = None) -> Figure:
    """Each signal over time, one panel per unit (a signal without a unit alone), the panels
    one above the other on a shared time axis.

    Parameters
    ----------
    signals : sequence of LogSignal
        The decoded signals (:func:`decode_signals`).
    fig : matplotlib.figure.Figure, optional
        Where to draw (default: a new figure, no pyplot state); a figure of several
        panels, hence a Figure, not an Axes.

    Returns
    -------
    matplotlib.figure.Figure
    """
    panels = _panels(signals)
    if fig is None:
        fig = Figure(figsize=(6.89, 1.2 + 1.6 * len(panels)), layout="constrained")
        FigureCanvasAgg(fig)
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, group in zip(axes, panels, strict=True):
        for s in group:
            ax.plot(*envelope(s.t, s.value), lw=0.7, drawstyle="steps-post",
                    label=s.qualified_name if len(group) > 1 else None)
        unit = group[0].unit
        ax.set_ylabel(f"{group[0].name} ({unit})" if len(group) == 1 and unit
                      else unit or group[0].name)
        if len(group) > 1:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small",
                      frameon=False)
    axes[-1].set_xlabel("time from the log's first frame (s)")
    return fig
