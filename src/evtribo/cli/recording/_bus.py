"""The bus options of the commands that record (``acquire``, ``session``), and the live view's."""

from __future__ import annotations

import argparse

from evtribo.acquisition.buses.bus import BusSettings, parse_bus_options
from evtribo.acquisition.live.liveview import LiveView
from evtribo.errors import ConfigError

#: Port of ``--view`` given without a number.
VIEW_PORT = 8765


def _port(text: str) -> int:
    """A TCP port of ``--view`` (0: any free one), else argparse's usage error."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a TCP port, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"expected a TCP port from 1 to 65535 (0: any free "
                                         f"one), got {port}")
    return port


def add_bus_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the python-can bus options (``--interface``, ``--channel``, ``--bitrate``,
    ``--bus-option``, ``--log-channel``) and ``--view [PORT]`` to *parser*."""
    bus = parser.add_argument_group(
        "bus (python-can's configuration file/environment when omitted)")
    bus.add_argument("--interface", help="python-can interface: socketcan, slcan, slcan_bulk, "
                     "pcan, kvaser, virtual...")
    bus.add_argument("--channel", help="channel: can0, vcan0, /dev/ttyACM0, PCAN_USBBUS1...")
    bus.add_argument("--bitrate", type=int, help="bit/s, e.g. 1000000")
    bus.add_argument("--bus-option", action="append", default=[], metavar="KEY=VALUE",
                     help="extra argument of the python-can bus (repeatable), "
                     "e.g. sleep_after_open=0")
    bus.add_argument("--log-channel", metavar="NAME",
                     help="channel name written in the log (default: --channel)")
    parser.add_argument("--view", nargs="?", type=_port, const=VIEW_PORT, default=None,
                        metavar="PORT",
                        help="serve a live view of the recording on http://127.0.0.1:PORT/ "
                             f"(default port {VIEW_PORT}) for the subject's screen")


def bus_settings(args: argparse.Namespace) -> BusSettings:
    """The :class:`BusSettings` of the parsed options."""
    return BusSettings(interface=args.interface, channel=args.channel, bitrate=args.bitrate,
                       options=parse_bus_options(args.bus_option))


def start_view(args: argparse.Namespace) -> LiveView | None:
    """The live view ``--view`` asks for, serving (None without ``--view``).

    Raises
    ------
    ConfigError
        The port is taken or not allowed (key ``--view``).
    """
    if args.view is None:
        return None
    try:
        view = LiveView(args.view).start()
    except OSError as err:
        raise ConfigError(f"cannot serve the live view on 127.0.0.1:{args.view} ({err}); "
                          "give another port, --view PORT", key="--view") from err
    print(f"live view: {view.url}  (open it in a browser on this machine)", flush=True)
    return view
