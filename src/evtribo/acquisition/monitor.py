"""Live display while a trial records: the normal force against its target band, and the bus.

A trial may start with a tare stretch (``evtribo acquire --tare-s``): for its first seconds
the display asks the operator to keep the finger off the screen (``LIFT THE FINGER``), then
to slide (``SLIDE``); the analysis takes the load cells' zero offsets from that stretch.

When none of the rig's load-cell messages has arrived a few seconds into the trial, the
display says so (``NO DATA FROM THE RIG``): the bus is the wrong one, or the study's DBC is
not this rig's (the trial then ends as ``no-rig-data``).

The display runs in its own thread, reading the writer's :class:`~evtribo.acquisition.logger.
LogStats` a few times a second (never in the receive path). On a terminal it redraws a small
block with ANSI escapes; on a pipe or file it writes one line every few seconds.
:func:`render_band` and :func:`render_status` are pure functions of a :class:`Snapshot`.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TextIO

from evtribo.acquisition.logger import LogStats
from evtribo.frames.ids import frame_key, key_id

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.acquisition.rigfile import AcquisitionRig

log = logging.getLogger(__name__)

_GREEN, _RED, _YELLOW, _RESET = "\x1b[32m", "\x1b[31m", "\x1b[33m", "\x1b[0m"


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


def render_status(snap: Snapshot, *, target: float | None = None, band: float = 0.1,
                  width: int = 41, colour: bool = False, title: str = "") -> list[str]:
    """The display's lines for *snap* (no newlines, no cursor movement).

    Parameters
    ----------
    snap : Snapshot
    target : float or None, N
        Target normal force; None shows the value without a gauge.
    band : float, N
        Half-width of the target band.
    width : int
        Width of the gauge.
    colour : bool
        Colour the band verdict with ANSI codes.
    title : str
        First words of the first line (``P01/run-01``).

    Returns
    -------
    list of str
    """
    remaining = "" if snap.remaining_s is None else f"   remaining {snap.remaining_s:6.1f} s"
    todo = instruction(snap)
    if todo:
        lifting = todo != "SLIDE"
        todo = f"   >> {todo} <<"
        if colour:
            todo = (_YELLOW if lifting else _GREEN) + todo + _RESET
    lines = [f"{title}   elapsed {snap.elapsed_s:6.1f} s{remaining}{todo}".strip()]
    normal = f"normal force     {_fmt(snap.normal_force_N)}"
    if target is not None:
        state = band_state(snap.normal_force_N, target, band)
        word = {"in": "IN BAND", "low": "TOO LOW", "high": "TOO HIGH", "none": "NO DATA"}[state]
        if snap.tare_left_s is not None and snap.tare_left_s > 0 and state != "none":
            state, word = "tare", "TARING"
        if colour:
            word = (_GREEN if state in ("in", "tare") else _RED) + word + _RESET
        normal += (f"  {render_band(snap.normal_force_N, target, band, width)}  {word}"
                   f"  (target {target:.3f} ± {band:.3f} N)")
    lines.append(normal)
    lines.append(f"tangential force {_fmt(snap.tangential_force_N)}")
    rates = "   ".join(f"{name} {rate:6.0f}" for name, rate in snap.rates_Hz.items())
    lines.append(f"frames/s   {rates or '--'}")
    damaged = f" ({snap.damaged_lines} damaged lines)" if snap.damaged_lines else ""
    lines.append(f"frames {snap.frames}   dropped {snap.dropped}   bus errors {snap.bus_errors}"
                 + damaged)
    if snap.alert:
        lines.append(f"{_RED}{snap.alert}{_RESET}" if colour else snap.alert)
    return lines


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
    return (f"t={snap.elapsed_s:.1f} s  Fn={fn}  Ft={ft}  frames={snap.frames} "
            f"({total:.0f}/s)  dropped={snap.dropped}  bus errors={snap.bus_errors}"
            + (f"  {todo}" if todo else "") + (f"  {snap.alert}" if snap.alert else ""))


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


class Monitor:
    """A thread that shows the trial's state on *stream* while it records.

    Parameters
    ----------
    rig : AcquisitionRig
        For decoding the force signals and naming messages.
    stream : text file
        Where to write (the terminal).
    duration : float or None, s
        Planned duration (for the remaining time).
    target, band : float, N
        Target normal force and half-width of its band; ``target=None`` for no gauge.
    tty : bool or None
        Redraw in place (default: ``stream.isatty()``).
    interval : float, s
        Refresh period on a terminal; a line every ``line_interval`` s otherwise.
    title : str
        Shown on the first line.
    tare_s : float, s
        Length of the tare stretch at the start (0: none): the display asks for the finger
        to be lifted that long, then to slide.
    rig_data_timeout : float or None, s
        Say so (:attr:`Snapshot.alert`) when none of the rig's load-cell messages arrived
        within this time; None: never.
    """

    def __init__(self, rig: AcquisitionRig, stream: TextIO, *, duration: float | None = None,
                 target: float | None = None, band: float = 0.1, tty: bool | None = None,
                 interval: float = 0.25, line_interval: float = 5.0, title: str = "",
                 tare_s: float = 0.0, rig_data_timeout: float | None = None) -> None:
        self.rig = rig
        self.stream = stream
        self.duration = duration
        self.target = target
        self.band = band
        self.tty = stream.isatty() if tty is None else tty
        self.interval = interval if self.tty else line_interval
        self.title = title
        self.tare_s = tare_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._stats: LogStats | None = None
        self._t0 = 0.0
        self._last: tuple[float, dict[str, int]] = (0.0, {})
        self._drawn = 0
        self._forces = [self._signal(key) for key in ("normal_force", "tangential_force")]
        self.rig_data_timeout = rig_data_timeout
        self._cells = rig.role_messages() if rig_data_timeout is not None else {}

    def _signal(self, key: str) -> tuple[int, str, str] | None:
        """(frame key, message, signal) of a role."""
        spec = self.rig.signals.get(key)
        if spec is None:
            return None
        message, signal = spec.split(".")
        msg = self.rig.database.get_message_by_name(message)
        return frame_key(int(msg.frame_id), bool(msg.is_extended_frame)), message, signal

    def start(self, stats: LogStats, t0: float | None = None) -> Monitor:
        """Show *stats* from now on; *t0* is the trial's start (``time.monotonic()``)."""
        self._stats = stats
        self._t0 = time.monotonic() if t0 is None else t0
        self._last = (self._t0, {})
        if self.tare_s > 0 and not self.tty:  # a pipe or a file: say it at once
            self.stream.write(f"lift the finger off the screen for {self.tare_s:g} s "
                              "(taring), then slide\n")
            self.stream.flush()
        self._thread = threading.Thread(target=self._run, name="evtribo-monitor", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop refreshing (after a last refresh on a terminal, or, on a pipe, a last line
        when there is an alert)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._stats is not None and (self.tty or self._alert()):
            self._draw(final=True)

    def _alert(self) -> str:
        """The no-rig-data alert, when it applies now."""
        if not self._cells or self._stats is None or self.rig_data_timeout is None:
            return ""
        if time.monotonic() - self._t0 < self.rig_data_timeout:
            return ""
        latest = self._stats.latest
        if any(key in latest for key in self._cells.values()):
            return ""
        return no_rig_data_alert(self._cells, self.rig_data_timeout)

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            try:
                self._draw()
            except Exception as err:  # the display must never stop the recording
                log.warning("display failed: %s", err)

    def _decode(self, latest: dict[int, Any], which: tuple[int, str, str] | None
                ) -> float | None:
        if which is None or which[0] not in latest:
            return None
        try:
            decoded = self.rig.database.get_message_by_name(which[1]).decode(
                bytes(latest[which[0]].data), decode_choices=False)
            value = decoded[which[2]] if isinstance(decoded, dict) else None
            return float(value) if isinstance(value, int | float) else None
        except Exception:
            return None

    def snapshot(self, final: bool = False) -> Snapshot:
        """The current state: frame rates over the time since the previous snapshot (or,
        with *final*, over the whole trial)."""
        stats = self._stats if self._stats is not None else LogStats()
        now = time.monotonic()
        elapsed = now - self._t0
        counts = dict(stats.frames_by_id)
        t_prev, prev = self._last
        if final:  # the last picture: mean rates over the whole trial
            t_prev, prev = self._t0, {}
        dt = max(now - t_prev, 1e-9)
        rates: dict[str, float] = {}
        for key, n in counts.items():
            name = None
            if key != "error":
                name = self.rig.message_name(int(key, 16), is_extended=len(key) == 8)
            name = name or "other"
            rates[name] = rates.get(name, 0.0) + (n - prev.get(key, 0)) / dt
        self._last = (now, counts)
        latest = dict(stats.latest)
        remaining = None if self.duration is None else max(self.duration - elapsed, 0.0)
        tare_left = max(self.tare_s - elapsed, 0.0) if self.tare_s > 0 else None
        return Snapshot(elapsed_s=elapsed, remaining_s=remaining,
                        normal_force_N=self._decode(latest, self._forces[0]),
                        tangential_force_N=self._decode(latest, self._forces[1]),
                        rates_Hz=rates, frames=stats.frames, dropped=stats.dropped,
                        bus_errors=stats.error_frames + stats.damaged_lines,
                        tare_left_s=tare_left, damaged_lines=stats.damaged_lines,
                        alert=self._alert())

    def _draw(self, final: bool = False) -> None:
        snap = self.snapshot(final)
        if not self.tty:
            self.stream.write(render_line(snap, target=self.target, band=self.band) + "\n")
            self.stream.flush()
            return
        lines = render_status(snap, target=self.target, band=self.band, colour=True,
                              title=self.title)
        out = f"\x1b[{self._drawn}F" if self._drawn else ""
        out += "".join(f"\x1b[2K{line}\n" for line in lines) + "\x1b[J"
        self.stream.write(out)
        self.stream.flush()
        self._drawn = len(lines)


__all__ = ["Monitor", "Snapshot", "band_state", "instruction", "no_rig_data_alert",
           "render_band", "render_line", "render_status"]
