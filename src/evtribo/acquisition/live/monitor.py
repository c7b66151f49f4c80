"""Live display while a trial records: the normal force against its target band, and the bus.

A trial may start with a tare stretch (``evtribo acquire --tare-s``): for its first seconds
the display asks the operator to keep the finger off the screen (``LIFT THE FINGER``), then
to slide (``SLIDE``); the analysis takes the load cells' zero offsets from that stretch.

When none of the rig's load-cell messages has arrived a few seconds into the trial, the
display says so (``NO DATA FROM THE RIG``): the bus is the wrong one, or the study's DBC is
not this rig's (the trial then ends as ``no-rig-data``).

The display runs in its own thread, reading the writer's :class:`~evtribo.acquisition.logger.
LogStats` a few times a second (never in the receive path). On a terminal it redraws a small
block with ANSI escapes, fitted to the terminal's width; on a pipe or file it writes one line
every few seconds. With a :class:`~evtribo.acquisition.live.liveview.LiveView` it also publishes
the state to the browser :data:`VIEW_RATE_HZ` times a second. It shows the high voltage's
state when the rig broadcasts the amplifier's status. What it draws comes from
:mod:`evtribo.acquisition.live.display` (pure functions of a :class:`Snapshot`).
"""

from __future__ import annotations

import logging
import shutil
import threading
import time
from typing import TYPE_CHECKING, Any, TextIO

from evtribo.acquisition.live.display import (
    Snapshot,
    band_state,
    instruction,
    no_rig_data_alert,
    render_band,
    render_line,
    render_status,
    view_state,
)
from evtribo.acquisition.logger import LogStats
from evtribo.canlog.io.ids import frame_key

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.acquisition.live.liveview import LiveView
    from evtribo.acquisition.rigfile import AcquisitionRig

log = logging.getLogger(__name__)

#: Updates per second of the live view in the browser.
VIEW_RATE_HZ = 20.0
#: Frame rates are counted over about this long, s.
RATE_WINDOW_S = 1.0


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
    steps : tuple of float, N
        Targets the band steps through after the tare stretch, each held *step_s*, in turn
        (empty: *target* all through).
    step_s : float, s
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
    view : LiveView, optional
        The live view in the browser, fed :data:`VIEW_RATE_HZ` times a second.
    quiet : bool
        Draw nothing on *stream* (the view alone).
    """

    def __init__(self, rig: AcquisitionRig, stream: TextIO, *, duration: float | None = None,
                 target: float | None = None, band: float = 0.1, tty: bool | None = None,
                 interval: float = 0.25, line_interval: float = 5.0, title: str = "",
                 tare_s: float = 0.0, rig_data_timeout: float | None = None,
                 view: LiveView | None = None, quiet: bool = False,
                 steps: tuple[float, ...] = (), step_s: float = 4.0) -> None:
        self.rig = rig
        self.steps, self.step_s = tuple(steps), step_s
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
        self._hv = {k: self._signal(f"excitation_{k}")
                    for k in ("enabled", "amplitude", "frequency", "waveform")}
        self.view, self.quiet = view, quiet
        self._rates: list[tuple[float, dict[str, int]]] = []
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
        if not self.tty and not self.quiet:  # a pipe or a file: say it at once
            self.stream.write(f"recording {self.title}".rstrip() + "\n")
            if self.tare_s > 0:
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
        tick = self.interval if self.view is None else min(self.interval, 1 / VIEW_RATE_HZ)
        next_draw = time.monotonic() + self.interval
        while not self._stop.wait(tick):
            try:
                now = time.monotonic()
                if self.view is not None:
                    self._publish(self.snapshot())
                if now >= next_draw and not self.quiet:
                    next_draw = now + self.interval
                    self._draw()
            except Exception as err:  # the display must never stop the recording
                log.warning("display failed: %s", err)

    def target_at(self, elapsed_s: float) -> float | None:
        """The target *elapsed_s* seconds into the trial, N: :attr:`target` during the tare
        stretch and without steps, else the step of that time."""
        if not self.steps or self.target is None or elapsed_s < self.tare_s:
            return self.target
        return self.steps[int((elapsed_s - self.tare_s) // self.step_s) % len(self.steps)]

    def _publish(self, snap: Snapshot) -> None:
        """Hand *snap* to the live view."""
        assert self.view is not None
        self.view.publish(view_state(snap, target=self.target_at(snap.elapsed_s), band=self.band,
                                     title=self.title, duration=self.duration))

    def _decode(self, latest: dict[int, Any], which: tuple[int, str, str] | None
                ) -> float | None:
        value = self._decoded(latest, which, choices=False)
        return float(value) if isinstance(value, int | float) else None

    def _decoded(self, latest: dict[int, Any], which: tuple[int, str, str] | None, *,
                 choices: bool) -> object:
        """The signal's latest value (its value-table name with *choices*), or None."""
        if which is None or which[0] not in latest:
            return None
        try:
            decoded = self.rig.database.get_message_by_name(which[1]).decode(
                bytes(latest[which[0]].data), decode_choices=choices)
            return decoded.get(which[2]) if isinstance(decoded, dict) else None
        except Exception:
            return None

    def _hv_fields(self, latest: dict[int, Any]) -> dict[str, Any]:
        """The amplifier's status from its latest frames (Nones where the rig is silent)."""
        on = self._decode(latest, self._hv["enabled"])
        wave = self._decoded(latest, self._hv["waveform"], choices=True)
        return {"hv_on": None if on is None else bool(on),
                "hv_amplitude_V": self._decode(latest, self._hv["amplitude"]),
                "hv_frequency_Hz": self._decode(latest, self._hv["frequency"]),
                "hv_waveform": None if wave is None else str(wave)}

    def _rates_Hz(self, now: float, counts: dict[str, int], final: bool) -> dict[str, float]:
        """Frames per second per message over the last second or so (over the whole trial
        with *final*)."""
        self._rates.append((now, counts))
        while len(self._rates) > 2 and now - self._rates[1][0] >= RATE_WINDOW_S:
            self._rates.pop(0)
        t_prev, prev = (self._t0, {}) if final or len(self._rates) < 2 else self._rates[0]
        dt = max(now - t_prev, 1e-9)
        rates: dict[str, float] = {}
        for key, n in counts.items():
            name = None
            if key != "error":
                name = self.rig.message_name(int(key, 16), is_extended=len(key) == 8)
            name = name or "other"
            rates[name] = rates.get(name, 0.0) + (n - prev.get(key, 0)) / dt
        return rates

    def snapshot(self, final: bool = False, *, now: float | None = None) -> Snapshot:
        """The current state: frame rates over the last second or so (or, with *final*,
        over the whole trial).

        Parameters
        ----------
        final : bool
            The last picture of the trial.
        now : float, optional
            The time of the picture on the trial's clock (``time.monotonic()``; default:
            now).

        Returns
        -------
        Snapshot
        """
        stats = self._stats if self._stats is not None else LogStats()
        now = time.monotonic() if now is None else now
        elapsed = now - self._t0
        rates = self._rates_Hz(now, dict(stats.frames_by_id), final)
        latest = dict(stats.latest)
        remaining = None if self.duration is None else max(self.duration - elapsed, 0.0)
        tare_left = max(self.tare_s - elapsed, 0.0) if self.tare_s > 0 else None
        return Snapshot(elapsed_s=elapsed, remaining_s=remaining,
                        normal_force_N=self._decode(latest, self._forces[0]),
                        tangential_force_N=self._decode(latest, self._forces[1]),
                        rates_Hz=rates, frames=stats.frames,
                        dropped=max(stats.dropped, stats.queue_dropped or 0),
                        bus_errors=stats.error_frames + stats.damaged_lines,
                        tare_left_s=tare_left, damaged_lines=stats.damaged_lines,
                        alert=self._alert(), queue_dropped=stats.queue_dropped,
                        controller=stats.errors.state, counters=dict(stats.counters),
                        **self._hv_fields(latest))

    def _draw(self, final: bool = False) -> None:
        snap = self.snapshot(final)
        if self.view is not None:
            self._publish(snap)
        if self.quiet:
            return
        if not self.tty:
            self.stream.write(render_line(snap, target=self.target_at(snap.elapsed_s),
                                          band=self.band) + "\n")
            self.stream.flush()
            return
        columns = shutil.get_terminal_size(fallback=(80, 24)).columns
        lines = render_status(snap, target=self.target_at(snap.elapsed_s), band=self.band,
                              colour=True,
                              title=self.title, columns=columns)
        out = f"\x1b[{self._drawn}F" if self._drawn else ""
        out += "".join(f"\x1b[2K{line}\n" for line in lines) + "\x1b[J"
        self.stream.write(out)
        self.stream.flush()
        self._drawn = len(lines)


__all__ = ["VIEW_RATE_HZ", "Monitor", "Snapshot", "band_state", "instruction",
           "no_rig_data_alert", "render_band", "render_line", "render_status"]
