"""What the live display shows: a :class:`Snapshot` of the trial, and its renderings.

Pure functions of a snapshot: :func:`render_status` (the block a terminal redraws in place,
every line fitted to the terminal's width, 70 columns included), :func:`render_line` (one
line for pipes and log files), :func:`view_state` (what the live view in the browser gets),
and their parts (:func:`render_band`, :func:`band_state`, :func:`instruction`,
:func:`hv_text`). :class:`~evtribo.acquisition.live.monitor.Monitor` makes the snapshots.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field
from typing import Any

from evtribo.canlog.io.ids import key_id

__all__ = ["Snapshot", "band_state", "hv_text", "instruction", "no_rig_data_alert",
           "render_band", "render_line", "render_status", "view_state"]

_GREEN, _RED, _YELLOW, _RESET = "\x1b[32m", "\x1b[31m", "\x1b[33m", "\x1b[0m"
_ANSI = re.compile(r"\x1b\[[0-9;]*m")
#: Narrowest gauge drawn, characters between its brackets.
MIN_GAUGE = 11


@dataclass
class Snapshot:
    """What the display shows at one instant.

    Attributes
    ----------
    elapsed_s : float, s
    remaining_s : float or None, s
        None when the trial has no set duration.
    normal_force_N, tangential_force_N : float or None, N
        Latest decoded values (None before the first frame).
    rates_Hz : dict
        Frames per second per message name (``"other"`` for frames the rig does not describe).
    frames, dropped, bus_errors : int
    tare_left_s : float or None, s
        Time left of the tare stretch (finger lifted): positive while it lasts, 0 once it is
        over, None for a trial without one.
    damaged_lines : int
        Lines from the adapter that could not be parsed (counted in *bus_errors* too).
    alert : str
        Something wrong the operator must see (``NO DATA FROM THE RIG ...``), or empty.
    hv_on : bool or None
        The amplifier's status: the high voltage applied (None: the rig does not say).
    hv_amplitude_V, hv_frequency_Hz : float or None
    hv_waveform : str or None
        Its value-table name (``"square"``).
    queue_dropped : int or None
        Frames the receive queue dropped (SocketCAN: the kernel's count), counted in
        *dropped* too; None when the bus does not count them.
    controller : str or None
        The CAN controller's state its error frames reported (``"bus-off"``,
        ``"error-passive"``...), None while none said.
    counters : dict
        What the load cells' counters whose count is not simply theirs say, by message
        name (a period not known yet: that cell's frames lost left out of *dropped*; a
        counter that does not count), :meth:`~evtribo.acquisition.counters.CounterTracker.states`.
    """

    elapsed_s: float
    remaining_s: float | None = None
    normal_force_N: float | None = None
    tangential_force_N: float | None = None
    rates_Hz: dict[str, float] = field(default_factory=dict)
    frames: int = 0
    dropped: int = 0
    bus_errors: int = 0
    tare_left_s: float | None = None
    damaged_lines: int = 0
    alert: str = ""
    hv_on: bool | None = None
    hv_amplitude_V: float | None = None
    hv_frequency_Hz: float | None = None
    hv_waveform: str | None = None
    queue_dropped: int | None = None
    controller: str | None = None
    counters: dict[str, str] = field(default_factory=dict)


def instruction(snap: Snapshot) -> str:
    """What the operator should do now: ``LIFT THE FINGER`` during the tare stretch,
    ``SLIDE`` after it, nothing for a trial without one.

    Parameters
    ----------
    snap : Snapshot

    Returns
    -------
    str
        The instruction, or ``""``.
    """
    if snap.tare_left_s is None:
        return ""
    if snap.tare_left_s > 0:
        return f"LIFT THE FINGER off the screen (taring, {snap.tare_left_s:.1f} s)"
    return "SLIDE"


def band_state(value: float | None, target: float, band: float) -> str:
    """``"in"``, ``"low"``, ``"high"`` (or ``"none"`` without a value) for target ± band, N.

    Parameters
    ----------
    value : float or None, N
        The current normal force.
    target, band : float, N
        Target and half-width of the band.

    Returns
    -------
    str
    """
    if value is None or math.isnan(value):
        return "none"
    if value < target - band:
        return "low"
    if value > target + band:
        return "high"
    return "in"


def render_band(value: float | None, target: float, band: float, width: int = 41) -> str:
    """A one-line gauge of *value* against ``target ± band`` (all in N).

    The gauge spans ``target ± 4·band``: ``-`` outside the band, ``=`` inside, ``|`` at the
    target, ``O`` at the value (``<`` / ``>`` at the ends when it is off the scale).

    Parameters
    ----------
    value : float or None, N
        Current normal force (None: no marker).
    target, band : float, N
        Target force and half-width of the band.
    width : int
        Characters between the brackets.

    Returns
    -------
    str
        For instance ``"[--------========|=====O==--------]"``.
    """
    half = 4 * band if band > 0 else max(abs(target), 1e-3)
    lo, hi = target - half, target + half

    def col(x: float) -> int:
        return round((x - lo) / (hi - lo) * (width - 1))

    cells = ["-"] * width
    for i in range(max(col(target - band), 0), min(col(target + band), width - 1) + 1):
        cells[i] = "="
    cells[col(target)] = "|"
    if value is not None and not math.isnan(value):
        if value < lo:
            cells[0] = "<"
        elif value > hi:
            cells[-1] = ">"
        else:
            cells[col(value)] = "O"
    return "[" + "".join(cells) + "]"


def _fmt(value: float | None, unit: str = "N") -> str:
    return "   --   " if value is None or math.isnan(value) else f"{value:8.3f} {unit}"


def hv_text(snap: Snapshot) -> str:
    """The high voltage's state in words: ``"ON  100 V square 10000 Hz"``, ``"off"``, or
    ``""`` when the rig does not broadcast it.

    Parameters
    ----------
    snap : Snapshot

    Returns
    -------
    str
    """
    if snap.hv_on is None:
        return ""
    if not snap.hv_on:
        return "off"
    parts = ["ON"]
    if snap.hv_amplitude_V is not None:
        parts.append(f" {snap.hv_amplitude_V:.0f} V")
    if snap.hv_waveform:
        parts.append(f" {snap.hv_waveform}")
    if snap.hv_frequency_Hz is not None:
        parts.append(f" {snap.hv_frequency_Hz:g} Hz")
    return "".join(parts)


def _visible(text: str) -> int:
    """Characters *text* takes on a terminal (colour codes take none)."""
    return len(_ANSI.sub("", text))


def _fit(text: str, columns: int) -> str:
    """*text* cut to *columns* - 1 visible characters (a full last column makes terminals
    wrap), with ``...`` where it was cut; colour codes are kept whole."""
    room = columns - 1
    if _visible(text) <= room:
        return text
    plain = _ANSI.sub("", text)  # a line too long loses its colours, never its sense
    return plain[: max(room - 3, 0)] + "..."


def _band_word(snap: Snapshot, target: float, band: float, colour: bool) -> str:
    state = band_state(snap.normal_force_N, target, band)
    word = {"in": "IN BAND", "low": "TOO LOW", "high": "TOO HIGH", "none": "NO DATA"}[state]
    if snap.tare_left_s is not None and snap.tare_left_s > 0 and state != "none":
        state, word = "tare", "TARING"
    if colour:
        word = (_GREEN if state in ("in", "tare") else _RED) + word + _RESET
    return word


def render_status(snap: Snapshot, *, target: float | None = None, band: float = 0.1,
                  columns: int = 80, colour: bool = False, title: str = "") -> list[str]:
    """The display's lines for *snap* (no newlines, no cursor movement), each fitted to
    *columns* so that a terminal redraws the block in place without wrapping.

    Parameters
    ----------
    snap : Snapshot
    target : float or None, N
        Target normal force; None shows the value without a gauge.
    band : float, N
        Half-width of the target band.
    columns : int
        The terminal's width; the gauge takes what the line leaves.
    colour : bool
        Colour the band verdict, the instruction and the high voltage with ANSI codes.
    title : str
        First words of the first line (``P01/run-01``).

    Returns
    -------
    list of str
    """
    remaining = "" if snap.remaining_s is None else f"   remaining {snap.remaining_s:6.1f} s"
    lines = [f"{title}   elapsed {snap.elapsed_s:6.1f} s{remaining}".strip()]
    todo = instruction(snap)
    if todo:
        text = f">> {todo} <<"
        lines.append((_YELLOW if todo != "SLIDE" else _GREEN) + text + _RESET if colour
                     else text)
    normal = f"normal force     {_fmt(snap.normal_force_N)}"
    if target is not None:
        word = _band_word(snap, target, band, colour)
        width = max(columns - 1 - len(normal) - 6 - _visible(word), MIN_GAUGE)
        normal += f"  {render_band(snap.normal_force_N, target, band, width)}  {word}"
    lines.append(normal)
    tangential = f"tangential force {_fmt(snap.tangential_force_N)}"
    if target is not None:
        tangential += f"   target {target:.3f} ± {band:.3f} N"
    lines.append(tangential)
    hv = hv_text(snap)
    if hv:
        lines.append("high voltage     " + (_YELLOW + hv + _RESET if colour and snap.hv_on
                                            else hv))
    rates = "   ".join(f"{name} {rate:6.0f}" for name, rate in snap.rates_Hz.items())
    lines.append(f"frames/s   {rates or '--'}")
    lines.append(_counts_line(snap, colour))
    for name, text in snap.counters.items():  # wrapped, never cut, as the alert
        lines += _wrapped(f"counter {name}: {text}", columns)
    if snap.alert:
        lines += [f"{_RED}{line}{_RESET}" if colour else line
                  for line in _wrapped(snap.alert, columns)]
    return [_fit(line, columns) for line in lines]


def _wrapped(text: str, columns: int) -> list[str]:
    """*text*'s words in lines narrower than *columns*, never cut: the operator must read
    all of it."""
    lines, line = [], ""
    for w in text.split():
        if line and len(line) + 1 + len(w) > columns - 1:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}".strip()
    return [*lines, line]


def _queue_text(snap: Snapshot) -> str:
    """`` (receive queue 12)`` when the queue dropped frames, else empty."""
    return f" (receive queue {snap.queue_dropped})" if snap.queue_dropped else ""


def _counters_text(snap: Snapshot) -> str:
    """`` [FzCell: period not yet learnt, ...]`` where a counter's count is not simply its
    own."""
    if not snap.counters:
        return ""
    return " [" + "; ".join(f"{name}: {text}" for name, text in snap.counters.items()) + "]"


def _controller_text(snap: Snapshot) -> str:
    """`` controller BUS-OFF`` when the controller is not error-active, else empty."""
    if snap.controller in (None, "error-active"):
        return ""
    return f"  controller {str(snap.controller).upper()}"


def _counts_line(snap: Snapshot, colour: bool) -> str:
    """Frames, dropped (and by the receive queue), bus errors, the controller's state."""
    damaged = f" ({snap.damaged_lines} damaged lines)" if snap.damaged_lines else ""
    controller = _controller_text(snap)
    if colour and controller:
        controller = _RED + controller + _RESET
    return (f"frames {snap.frames}   dropped {snap.dropped}{_queue_text(snap)}   bus errors "
            f"{snap.bus_errors}" + damaged + controller)


def render_line(snap: Snapshot, *, target: float | None = None, band: float = 0.1) -> str:
    """A one-line summary for logs and pipes.

    Parameters
    ----------
    snap : Snapshot
    target : float or None, N
        Target normal force (None: no band verdict).
    band : float, N
        Half-width of the target band.

    Returns
    -------
    str
        The line, without newline.
    """
    fn = "--" if snap.normal_force_N is None else f"{snap.normal_force_N:.3f} N"
    if target is not None:
        fn += f" ({band_state(snap.normal_force_N, target, band)})"
    ft = "--" if snap.tangential_force_N is None else f"{snap.tangential_force_N:.3f} N"
    total = sum(snap.rates_Hz.values())
    todo = instruction(snap)
    hv = hv_text(snap)
    return (f"t={snap.elapsed_s:.1f} s  Fn={fn}  Ft={ft}" + (f"  HV={hv}" if hv else "")
            + f"  frames={snap.frames} ({total:.0f}/s)  dropped={snap.dropped}"
            + _queue_text(snap) + _counters_text(snap) + f"  bus errors={snap.bus_errors}"
            + _controller_text(snap)
            + (f"  {todo}" if todo else "")
            + (f"  {snap.alert}" if snap.alert else ""))


def no_rig_data_alert(messages: dict[str, int], within: float) -> str:
    """The display's alert when none of *messages* (``{name: frame_key}``) came in
    *within* s.

    Parameters
    ----------
    messages : dict
        ``{message name: frame key}`` of the load cells.
    within : float, s

    Returns
    -------
    str
    """
    names = " or ".join(f"{name} (0x{key_id(key)[0]:03X})" for name, key in messages.items())
    return (f"NO DATA FROM THE RIG: no {names} frame in {within:g} s; wrong bus, or the "
            "study's DBC is not this rig's?")


def view_state(snap: Snapshot, *, target: float | None = None, band: float = 0.1,
               title: str = "", duration: float | None = None) -> dict[str, Any]:
    """What the live view in the browser shows of *snap* (JSON-ready).

    Parameters
    ----------
    snap : Snapshot
    target, band : float, N
        Target normal force and half-width of its band (target None: no band).
    title : str
    duration : float or None, s
        The trial's planned length (its progress bar).

    Returns
    -------
    dict
        The snapshot's fields, and ``target_N``, ``band_N``, ``band_state``, ``title``,
        ``duration_s``, ``instruction``.
    """
    state = "none" if target is None else band_state(snap.normal_force_N, target, band)
    if target is not None and snap.tare_left_s and state != "none":
        state = "tare"
    return {**asdict(snap), "target_N": target, "band_N": band if target is not None else None,
            "band_state": state, "title": title, "duration_s": duration,
            "instruction": instruction(snap)}
