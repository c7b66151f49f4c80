"""Open any python-can bus from command-line style options.

``interface``, ``channel`` and ``bitrate`` go to :class:`can.Bus`; extra ``KEY=VALUE``
options are passed as keyword arguments, their values read as Python literals when they are
(``sleep_after_open=0`` is the number 0, ``receive_own_messages=True`` a bool) and as
strings otherwise. Anything not given is left to python-can's own configuration (the
``CAN_INTERFACE``/``CAN_CHANNEL``/``CAN_BITRATE`` environment variables, ``~/.canrc``...).
"""

from __future__ import annotations

import ast
import errno
import logging
import queue
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import can
import can.util
from can.interfaces.slcan import slcanBus

from evtribo.errors import AcquisitionError, ConfigError

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.acquisition.buses.socketcan import ReceiveQueue

log = logging.getLogger(__name__)


def parse_bus_options(items: Iterable[str] | None) -> dict[str, Any]:
    """``["sleep_after_open=0", "tty_baudrate=115200"]`` -> ``{"sleep_after_open": 0, ...}``.

    Parameters
    ----------
    items : iterable of str or None
        ``KEY=VALUE`` items (values read as numbers or booleans when they look like ones).

    Returns
    -------
    dict
        ``{key: value}``.

    Raises
    ------
    ConfigError
        For an item without ``=`` or with an empty key (key ``--bus-option``).
    """
    options: dict[str, Any] = {}
    for item in items or ():
        key, sep, raw = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise ConfigError(f"expected KEY=VALUE, got {item!r}", key="--bus-option")
        try:
            value: Any = ast.literal_eval(raw)
        except (ValueError, SyntaxError):
            value = raw
        if raw.lower() in ("true", "false"):
            value = raw.lower() == "true"
        options[key] = value
    return options


@dataclass
class BusSettings:
    """How a bus was (or will be) opened; the sidecar records it.

    Attributes
    ----------
    interface, channel : str or None
        As given, or as python-can's configuration resolved them.
    bitrate : int or None, bit/s
    options : dict
        Extra keyword arguments.
    """

    interface: str | None = None
    channel: str | None = None
    bitrate: int | None = None
    options: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (option values that are not JSON types become strings)."""
        opts = {k: v if isinstance(v, (int, float, bool, str, type(None))) else repr(v)
                for k, v in self.options.items()}
        return {"interface": self.interface, "channel": self.channel,
                "bitrate": self.bitrate, "bus_options": opts}


#: Said when neither the command line nor python-can's configuration names an interface.
NO_INTERFACE = (
    "no interface given (and python-can's configuration names none): give --interface and "
    "--channel, e.g. --interface socketcan --channel can0 (a SocketCAN adapter on Linux), "
    "--interface slcan --channel /dev/ttyACM0 (an slcan USB adapter), --interface pcan "
    "--channel PCAN_USBBUS1, or --interface virtual --channel vcan0 (no hardware); "
    "docs/hardware.md shows each set-up")
#: What to check when a SocketCAN interface cannot be opened, by the error's number.
SOCKETCAN_HINTS = {
    errno.EAFNOSUPPORT: (
        "this machine's kernel offers no SocketCAN (Linux with the can and can_raw modules: "
        "`sudo modprobe can_raw`; on another system use the adapter's own python-can "
        "interface, e.g. --interface slcan or pcan); docs/hardware.md"),
    errno.ENODEV: (
        "no such interface: `ip -brief link show type can` lists this machine's CAN "
        "interfaces (`ip -brief link show type vcan` its virtual ones; `sudo modprobe vcan; "
        "sudo ip link add dev vcan0 type vcan; sudo ip link set up vcan0` makes one); "
        "docs/hardware.md"),
    errno.ENETDOWN: (
        "the interface is down: `sudo ip link set CHANNEL up type can bitrate 1000000` "
        "brings it up at the rig's bitrate; `ip -details link show CHANNEL` shows its "
        "state; docs/hardware.md"),
}


def _hint(settings: BusSettings, err: BaseException) -> str:
    """What to check, for an interface that could not be opened (or ``""``)."""
    if settings.interface != "socketcan":
        return ""
    number = next((e.errno for e in (err, err.__cause__, err.__context__)
                   if isinstance(e, OSError) and e.errno is not None), None)
    if number is None and "No such device" in str(err):
        number = errno.ENODEV
    hint = SOCKETCAN_HINTS.get(number) if number is not None else None
    if hint is None:
        return ""
    return " (" + hint.replace("CHANNEL", settings.channel or "can0") + ")"


def open_bus(settings: BusSettings) -> can.BusABC:
    """Open the python-can bus *settings* describe; fill in what python-can's config chose.

    ``socketcan`` is python-can's SocketCAN bus with its receive queue sized and the
    kernel's drop count read (:class:`evtribo.acquisition.buses.socketcan.SocketcanBus`).

    Parameters
    ----------
    settings : BusSettings
        Interface, channel, bitrate and options (``interface``/``channel`` filled in from
        python-can's configuration when not given).

    Returns
    -------
    can.BusABC
        The open bus (the caller shuts it down).

    Raises
    ------
    ConfigError
        Unknown interface, or arguments the interface refuses (key ``--interface`` or
        ``--bus-option``).
    AcquisitionError
        The interface exists but the device cannot be opened (not plugged in, busy...).
    """
    kwargs: dict[str, Any] = dict(settings.options)
    if settings.interface is not None:
        kwargs["interface"] = settings.interface
    if settings.channel is not None:
        kwargs["channel"] = settings.channel
    if settings.bitrate is not None:
        kwargs["bitrate"] = settings.bitrate
    try:
        # resolve what python-can's configuration (environment, config file) adds
        resolved = can.util.load_config(config=kwargs)
        settings.interface = str(resolved.get("interface"))
        channel = resolved.get("channel")
        settings.channel = None if channel is None else str(channel)
        settings.bitrate = resolved.get("bitrate")
        bus: can.BusABC
        if settings.interface == "socketcan":  # python-can's, with its queue sized
            from evtribo.acquisition.buses.socketcan import SocketcanBus

            args = {k: v for k, v in resolved.items() if k != "interface"}
            bus = SocketcanBus(str(args.pop("channel", "") or ""), **args)
        else:
            bus = can.Bus(**kwargs)
    except can.CanInterfaceNotImplementedError as err:
        if settings.interface in (None, "None"):
            raise ConfigError(NO_INTERFACE, key="--interface") from err
        raise ConfigError(f"python-can cannot use interface {settings.interface!r}: {err}",
                          key="--interface") from err
    except can.CanInitializationError as err:
        raise AcquisitionError(f"cannot open {settings.interface or 'the bus'} "
                               f"{settings.channel or ''}: {err}".replace("  ", " ")
                               + _hint(settings, err)) from err
    except (TypeError, ValueError) as err:
        raise ConfigError(f"the bus refused its settings {kwargs}: {err}",
                          key="--bus-option") from err
    except OSError as err:
        raise AcquisitionError(f"cannot open {settings.interface or 'the bus'} "
                               f"{settings.channel or ''}: {err}".replace("  ", " ")
                               + _hint(settings, err)) from err
    log.info("opened %s", bus.channel_info)
    return bus


@dataclass
class ReceiveCare:
    """How a bus receives, as far as the recording can tell (the sidecar's ``receive``).

    Attributes
    ----------
    timestamps : str
        Where the frames' times come from: ``"kernel"`` (SocketCAN: the time the kernel
        received the frame, this machine's clock), or ``"driver"`` (python-can's driver:
        the host's time when it read the frame, or the adapter's clock).
    local_clock : bool
        The times are this machine's clock at reception: a frame stamped before the trial
        started was queued before it.
    queue : ReceiveQueue or None
        The receive queue asked for and granted (None: python-can cannot size it here).
    drop_counter : str or None
        What counts the frames the receiving side dropped (``"SO_RXQ_OVFL"``), or None.
    dropped : callable or None
        Returns that count so far.
    discard : callable or None
        Reads away what the bus holds when a trial starts (queued before it) and returns
        how many frames that was (None: this bus cannot tell them from new ones; with
        *local_clock* the older frames are discarded as they are read).
    """

    timestamps: str = "driver"
    local_clock: bool = False
    queue: ReceiveQueue | None = None
    drop_counter: str | None = None
    dropped: Callable[[], int] | None = None
    discard: Callable[[], int] | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (without the count: the recording adds it)."""
        return {"timestamps": self.timestamps,
                "queue": None if self.queue is None else self.queue.as_dict(),
                "drop_counter": self.drop_counter}


def receive_care(bus: can.BusABC) -> ReceiveCare:
    """What *bus* tells about its receiving: the SocketCAN bus of :func:`open_bus` its
    kernel timestamps, receive queue and drop count (python-can's own its kernel timestamps);
    an slcan adapter and python-can's ``virtual`` bus how to discard what they hold; a bus
    with python-can's ``get_stats()`` (Kvaser) its overruns; any other, nothing.

    Parameters
    ----------
    bus : can.BusABC

    Returns
    -------
    ReceiveCare
    """
    sized, queue_dropped = getattr(bus, "receive_queue", None), getattr(bus, "queue_dropped",
                                                                         None)
    if sized is not None and callable(queue_dropped):  # evtribo's socketcan
        return ReceiveCare("kernel", True, sized, "SO_RXQ_OVFL", queue_dropped)
    if type(bus).__module__.startswith("can.interfaces.socketcan"):  # python-can's own
        return ReceiveCare("kernel", True)
    if isinstance(bus, slcanBus):
        from evtribo.acquisition.buses.slcan import discard_queued

        return ReceiveCare(discard=lambda: discard_queued(bus))
    pending = getattr(bus, "queue", None)
    if type(bus).__module__ == "can.interfaces.virtual" and isinstance(pending, queue.Queue):
        return ReceiveCare(discard=lambda: _discard_virtual(pending))
    stats = getattr(bus, "get_stats", None)
    if callable(stats):
        try:
            overruns = stats().overruns
        except Exception as err:  # a driver that cannot say: nothing is claimed
            log.debug("no statistics from %s: %s", type(bus).__name__, err)
        else:
            if isinstance(overruns, int):
                return ReceiveCare(drop_counter="overruns (python-can get_stats)",
                                   dropped=lambda: int(stats().overruns))
    return ReceiveCare()


def _discard_virtual(pending: queue.Queue[Any]) -> int:
    """Empty a python-can virtual bus's queue of the frames it holds now; how many."""
    count = 0
    for _ in range(pending.qsize()):
        try:
            pending.get_nowait()
        except queue.Empty:
            break
        count += 1
    return count


__all__ = ["BusSettings", "ReceiveCare", "open_bus", "parse_bus_options", "receive_care"]
