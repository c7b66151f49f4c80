"""The amplifier under command: the rig's ``excitation_command_*`` message, sent on the bus.

A rig whose DBC has a message the amplifier obeys (the default rig's ``HvCmd``: ``HvOn``,
``HvWave``, ``HvAmp``, ``HvFreq``) names its signals in ``[rig]``
(``excitation_command_enabled = "HvCmd.HvOn"``...). :class:`ExcitationCommand` encodes the
wanted state with cantools and sends it; :meth:`ExcitationCommand.hold` keeps sending it
(at :data:`COMMAND_RATE_HZ`, so a lost frame costs nothing) while a trial records, and runs
an alternating trial's ON/OFF schedule: off during the tare stretch, then OFF and ON phases in
turn.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass

import can
from cantools.database.can import Database, Message

from evtribo.errors import RigConfigError

log = logging.getLogger(__name__)

__all__ = ["COMMAND_RATE_HZ", "COMMAND_ROLES", "CommandDecoder", "Excitation", "ExcitationCommand"]

#: Commands per second while a trial records.
COMMAND_RATE_HZ = 10.0
#: The command roles of spec §1, by the field of :class:`Excitation` they carry.
COMMAND_ROLES = {"enabled": "excitation_command_enabled",
                 "amplitude_V": "excitation_command_amplitude",
                 "frequency_Hz": "excitation_command_frequency",
                 "waveform": "excitation_command_waveform"}


@dataclass(frozen=True)
class Excitation:
    """What the amplifier is asked to apply.

    Attributes
    ----------
    enabled : bool
    amplitude_V : float, V
    frequency_Hz : float, Hz
    waveform : str
        ``"sine"`` or ``"square"`` (a name of the command's value table).
    """

    enabled: bool
    amplitude_V: float
    frequency_Hz: float
    waveform: str


class ExcitationCommand:
    """Send the rig's excitation command.

    Parameters
    ----------
    bus : can.BusABC
        An open bus.
    database : cantools Database
        The rig's DBC.
    roles : mapping of str to str
        The rig's roles (``{"excitation_command_enabled": "HvCmd.HvOn", ...}``); those of
        :data:`COMMAND_ROLES` it names must be signals of one message.

    Raises
    ------
    RigConfigError
        The command roles are spread over several messages.
    """

    def __init__(self, bus: can.BusABC | None, database: Database,
                 roles: Mapping[str, str]) -> None:
        self.bus = bus
        named = {f: roles[r] for f, r in COMMAND_ROLES.items() if r in roles}
        messages = {name.split(".", 1)[0] for name in named.values()}
        if len(messages) > 1:
            raise RigConfigError("the excitation_command_* signals must be in one message, "
                                 f"not {', '.join(sorted(messages))}",
                                 key="excitation_command_enabled")
        self.message: Message | None = (database.get_message_by_name(messages.pop())
                                        if messages else None)
        self.signals = {f: name.split(".", 1)[1] for f, name in named.items()}
        self.sent = 0
        self.errors = 0

    @classmethod
    def available(cls, roles: Mapping[str, str]) -> bool:
        """Whether a rig with *roles* has an amplifier under command."""
        return any(r in roles for r in COMMAND_ROLES.values())

    def frame(self, state: Excitation) -> can.Message:
        """The command frame for *state*.

        Parameters
        ----------
        state : Excitation

        Returns
        -------
        can.Message
        """
        assert self.message is not None
        values: dict[str, float | int | str] = {s.name: 0 for s in self.message.signals}
        for field_name, signal in self.signals.items():
            value = getattr(state, field_name)
            if field_name == "enabled":
                value = int(bool(value))
            elif field_name == "waveform":
                sig = self.message.get_signal_by_name(signal)
                codes = {str(v).lower(): int(k) for k, v in (sig.choices or {}).items()}
                if value.lower() not in codes:
                    raise RigConfigError(f"the command's value table has no waveform "
                                         f"{value!r} (it has {', '.join(codes) or 'none'})",
                                         key=COMMAND_ROLES["waveform"])
                value = codes[value.lower()]
            values[signal] = value
        data = self.message.encode(values, scaling=True, strict=False)
        return can.Message(arbitration_id=self.message.frame_id, data=data,
                           is_extended_id=bool(self.message.is_extended_frame))

    def send(self, state: Excitation) -> bool:
        """Send *state* once; False (and a warning, the first time) when the bus refuses."""
        if self.message is None or self.bus is None:
            return False
        try:
            self.bus.send(self.frame(state))
        except can.CanError as err:
            self.errors += 1
            if self.errors == 1:
                log.warning("could not send the excitation command: %s", err)
            return False
        self.sent += 1
        return True

    def hold(self, state: Excitation, condition: str, *, off_first_s: float = 0.0,
             on_s: float = 2.0, off_s: float = 2.0, begin: bool = True) -> _Holder:
        """Keep commanding *state* in a background thread until :meth:`_Holder.stop`.

        Parameters
        ----------
        state : Excitation
            Amplitude, frequency and waveform; its ``enabled`` is what *condition* says.
        condition : {"on", "off", "alternating"}
            ``alternating`` switches OFF for *off_s*, ON for *on_s*, and so on.
        off_first_s : float, s
            Off this long first (the tare stretch).
        on_s, off_s : float, s
            Phases of an alternating trial.
        begin : bool
            Start the phases now; False: command off until :meth:`_Holder.begin` (the
            recording's start, however long opening its files took).

        Returns
        -------
        _Holder
            A context manager; leaving it (or ``stop()``) sends the amplifier off.
        """
        holder = _Holder(self, state, condition, off_first_s=off_first_s, on_s=on_s,
                         off_s=off_s)
        holder.start(begin=begin)
        return holder


class _Holder:
    """The thread that keeps sending the command (see :meth:`ExcitationCommand.hold`)."""

    def __init__(self, command: ExcitationCommand, state: Excitation, condition: str, *,
                 off_first_s: float, on_s: float, off_s: float) -> None:
        self.command, self.state, self.condition = command, state, condition
        self.off_first_s, self.on_s, self.off_s = off_first_s, on_s, off_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="evtribo-hv-command",
                                        daemon=True)
        self._t0: float | None = None

    def enabled_at(self, t: float) -> bool:
        """Whether the amplifier is commanded on *t* s after the start."""
        if self.condition == "off" or t < self.off_first_s:
            return False
        if self.condition == "on":
            return True
        phase = (t - self.off_first_s) % (self.on_s + self.off_s)
        return phase >= self.off_s

    def start(self, begin: bool = True) -> None:
        self._t0 = time.monotonic() if begin else None
        self._thread.start()

    def begin(self) -> None:
        """Start the phases now (the off stretch first): the recording has started."""
        self._t0 = time.monotonic()

    def _run(self) -> None:
        period = 1.0 / COMMAND_RATE_HZ
        while not self._stop.is_set():
            t0 = self._t0
            on = t0 is not None and self.enabled_at(time.monotonic() - t0)
            self.command.send(Excitation(on, self.state.amplitude_V, self.state.frequency_Hz,
                                         self.state.waveform))
            self._stop.wait(period)

    def stop(self) -> None:
        """Stop sending, and command the amplifier off."""
        self._stop.set()
        self._thread.join(timeout=2)
        self.command.send(Excitation(False, self.state.amplitude_V, self.state.frequency_Hz,
                                     self.state.waveform))

    def __enter__(self) -> _Holder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class CommandDecoder:
    """What an excitation command frame asks for (the simulated amplifier obeys it).

    Parameters
    ----------
    database : cantools Database
        The rig's DBC.
    roles : mapping of str to str
        The rig's roles (``{"excitation_command_enabled": "HvCmd.HvOn", ...}``).
    """

    def __init__(self, database: Database, roles: Mapping[str, str]) -> None:
        probe = ExcitationCommand(None, database, roles)
        self.message, self.signals = probe.message, probe.signals

    def decode(self, arbitration_id: int, is_extended: bool, data: bytes
               ) -> dict[str, object] | None:
        """The command's fields (``enabled``, ``amplitude_V``, ``frequency_Hz``,
        ``waveform``: those the rig names), or None for another frame or a damaged one.

        Parameters
        ----------
        arbitration_id : int
        is_extended : bool
        data : bytes

        Returns
        -------
        dict or None
        """
        m = self.message
        if m is None or arbitration_id != m.frame_id \
                or bool(is_extended) != bool(m.is_extended_frame):
            return None
        try:
            values = m.decode(bytes(data), decode_choices=True)
        except Exception as err:  # a frame too short, a damaged one: not a command
            log.warning("ignored a damaged excitation command frame: %s", err)
            return None
        if not isinstance(values, dict):
            return None
        out: dict[str, object] = {}
        for field_name, signal in self.signals.items():
            value = values.get(signal)
            if value is None:
                continue
            if field_name == "waveform":
                out[field_name] = str(value).lower()
            elif isinstance(value, int | float):
                out[field_name] = bool(value) if field_name == "enabled" else float(value)
            else:  # a value-table name where a number was expected
                out[field_name] = str(value).lower() in ("on", "1", "true", "enabled") \
                    if field_name == "enabled" else None
        return out
