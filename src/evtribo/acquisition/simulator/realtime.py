"""The simulated rig in real time: its frames paced by the clock, on a bus or an slcan pty."""

from __future__ import annotations

import dataclasses
import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import can
import numpy as np

from evtribo.acquisition.command import CommandDecoder
from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig
from evtribo.acquisition.simulator.core import OBEY_CHUNK_S, TrialGenerator
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import Rig, default_rig
from evtribo.errors import ConfigError

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.acquisition.buses.slcan import SlcanPtyAdapter

__all__ = ["MAX_DURATION_S", "RunStats", "Simulator"]

log = logging.getLogger(__name__)

#: A run without a duration stops after this long (one day), s.
MAX_DURATION_S = 86_400.0
#: Longest wait between two looks at the clock (and at the pty's commands), s.
TICK_S = 0.005


@dataclass
class RunStats:
    """What a real-time run did.

    Attributes
    ----------
    generated : int
        Frames the rig produced while the run lasted.
    sent : int
        Frames handed to the bus or written to the pty.
    not_sent : int
        Frames lost on the way: send errors, the pty's port closed, or its buffer full
        (a real adapter drops them too).
    elapsed_s : float, s
        Length of the run.
    """

    generated: int = 0
    sent: int = 0
    not_sent: int = 0
    elapsed_s: float = 0.0


Deliver = Callable[[FrameTable, int, int], int]


class Simulator:
    """The simulated rig, streaming the frames of
    :func:`~evtribo.acquisition.simulator.core.simulate_trial` in real time.

    Parameters
    ----------
    subject : SubjectParams, optional
    config : TrialConfig, optional
        Its ``duration_s`` and ``start_time`` are replaced by those of each run.
    dbc : path-like, optional
        The rig's DBC (default: the default rig).
    speed : float
        Time-lapse factor: 1 sends the frames in real time, 4 four times faster (their
        timestamps still follow the trial's own clock; a virtual bus opened with
        ``preserve_timestamps=True`` passes them on).
    rig : Rig, optional
        The rig to speak (its DBC and roles; default: the default rig). When it names
        ``excitation_command_*`` signals, the simulated amplifier obeys the command frames it
        receives (on the bus, or written to the pty), from the next second of the stream on,
        and its status reports what it was commanded.

    Examples
    --------
    >>> bus = can.Bus(interface="virtual", channel="vcan0")  # doctest: +SKIP
    >>> Simulator(config=TrialConfig(amplitude_V=100)).run(bus, duration=10)  # doctest: +SKIP
    """

    def __init__(self, subject: SubjectParams | None = None, config: TrialConfig | None = None,
                 dbc: str | os.PathLike[str] | None = None, *, speed: float = 1.0,
                 rig: Rig | None = None) -> None:
        if not speed > 0:
            raise ConfigError(f"{speed!r} is not allowed: the speed must be > 0", key="speed")
        self.subject = subject or SubjectParams()
        self.config = config or TrialConfig()
        self.dbc = dbc
        self.speed = float(speed)
        self.rig = rig
        self.generator: TrialGenerator | None = None
        spoken = rig or default_rig()
        roles = {r: ref.qualified_name for r, ref in spoken.roles.items()}
        self.commands = CommandDecoder(spoken.database, roles) if spoken.has_command \
            else None
        self.obeyed = 0

    def obey(self, arbitration_id: int, is_extended: bool, data: bytes) -> bool:
        """Apply a received frame if it is the rig's excitation command; True if it was.

        Parameters
        ----------
        arbitration_id : int
        is_extended : bool
        data : bytes

        Returns
        -------
        bool
        """
        if self.commands is None or self.generator is None:
            return False
        fields = self.commands.decode(arbitration_id, is_extended, data)
        if fields is None:
            return False
        self.generator.command(**fields)  # type: ignore[arg-type]
        self.obeyed += 1
        return True

    def _generator(self, duration: float | None) -> TrialGenerator:
        cfg = dataclasses.replace(self.config, duration_s=float(duration or MAX_DURATION_S),
                                  start_time=time.time())
        self.generator = TrialGenerator(self.subject, cfg, self.dbc, rig=self.rig)
        return self.generator

    def _pace(self, gen: TrialGenerator, deliver: Deliver, stop_event: threading.Event | None,
              wait: Callable[[float], None]) -> RunStats:
        stats = RunStats()
        speed = self.speed
        m0 = time.monotonic()
        start = gen.config.start_time
        try:
            for chunk in gen.chunks():
                rel = chunk.timestamp - start
                i, n = 0, len(chunk)
                stats.generated += n
                while i < n:
                    if stop_event is not None and stop_event.is_set():
                        stats.generated -= n - i
                        return stats
                    now = (time.monotonic() - m0) * speed
                    j = int(np.searchsorted(rel, now, side="right"))
                    if j > i:
                        sent = deliver(chunk, i, j)
                        stats.sent += sent
                        stats.not_sent += (j - i) - sent
                        i = j
                    else:
                        wait(min((float(rel[i]) - now) / speed, TICK_S))
            return stats
        finally:
            stats.elapsed_s = time.monotonic() - m0

    def run(self, bus: can.BusABC, duration: float | None = None,
            stop_event: threading.Event | None = None) -> RunStats:
        """Send the rig's frames on *bus* as their time comes.

        Parameters
        ----------
        bus : can.BusABC
            Any python-can bus.
        duration : float, optional, s
            Length of the run (default: until *stop_event* is set, at most a day).
        stop_event : threading.Event, optional
            Set it to stop the run.

        Returns
        -------
        RunStats
        """
        gen = self._generator(duration)
        errors = 0

        def listen() -> None:
            """Obey the command frames that have arrived (without waiting)."""
            while (msg := bus.recv(timeout=0.0)) is not None:
                self.obey(msg.arbitration_id, msg.is_extended_id, bytes(msg.data))

        def deliver(table: FrameTable, i: int, j: int) -> int:
            nonlocal errors
            if self.commands is not None:  # a rig running late still hears its commands
                listen()
            sent = 0
            for k in range(i, j):
                dlc = int(table.dlc[k])
                msg = can.Message(
                    timestamp=float(table.timestamp[k]),
                    arbitration_id=int(table.arbitration_id[k]),
                    is_extended_id=bool(table.is_extended[k]),
                    is_remote_frame=bool(table.is_remote[k]), is_fd=bool(table.is_fd[k]),
                    dlc=dlc, data=None if table.is_remote[k] else table.data[k, :dlc].tobytes(),
                    channel=table.channel)
                try:
                    bus.send(msg)
                    sent += 1
                except can.CanError as err:
                    errors += 1
                    if errors == 1 or errors % 1000 == 0:
                        log.warning("could not send frame (%d so far): %s", errors, err)
            return sent

        def wait(seconds: float) -> None:
            if self.commands is not None:  # listen for the amplifier's command meanwhile
                deadline = time.monotonic() + max(seconds, 0.0)
                while (msg := bus.recv(timeout=max(deadline - time.monotonic(), 0.0))) \
                        is not None:
                    self.obey(msg.arbitration_id, msg.is_extended_id, bytes(msg.data))
                    if time.monotonic() >= deadline:
                        break
                return
            if stop_event is not None:
                stop_event.wait(max(seconds, 0.0))
            elif seconds > 0:
                time.sleep(seconds)

        return self._pace(gen, deliver, stop_event, wait)

    def run_pty(self, adapter: SlcanPtyAdapter, duration: float | None = None,
                stop_event: threading.Event | None = None) -> RunStats:
        """Stream the rig's frames through an emulated slcan adapter.

        The trial's clock starts when a client opens the channel (``O``); frames that come
        due while the channel is closed are not sent (counted in ``not_sent``).

        Parameters
        ----------
        adapter : SlcanPtyAdapter
        duration : float, optional, s
            Length of the trial from the first ``O`` (default: until *stop_event*).
        stop_event : threading.Event, optional
        """
        while not adapter.is_open:
            if stop_event is not None and stop_event.is_set():
                return RunStats()
            adapter.poll(0.05)
        log.info("slcan channel opened: streaming")
        gen = self._generator(duration)
        adapter.on_transmit = self.obey
        # each later recording on the channel starts, as the first did, with the finger
        # lifted for the trial's tare stretch
        gen.chunk_s = OBEY_CHUNK_S
        adapter.on_open = lambda: gen.lift(self.config.tare_s)

        def deliver(table: FrameTable, i: int, j: int) -> int:
            # a rig running late (a busy machine) still hears the client: its amplifier
            # commands, and C, after which it sends nothing until the next O
            adapter.poll(0.0)
            return adapter.send_frames(table, i, j)

        stats = self._pace(gen, deliver, stop_event, adapter.poll)
        # what is written reaches a client that keeps reading, however busy the machine
        adapter.drain(timeout=120.0, stalled=5.0)
        return stats
