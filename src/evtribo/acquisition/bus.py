"""Open any python-can bus from command-line style options.

``interface``, ``channel`` and ``bitrate`` go to :class:`can.Bus`; extra ``KEY=VALUE``
options are passed as keyword arguments, their values read as Python literals when they are
(``sleep_after_open=0`` is the number 0, ``receive_own_messages=True`` a bool) and as
strings otherwise. Anything not given is left to python-can's own configuration (the
``CAN_INTERFACE``/``CAN_CHANNEL``/``CAN_BITRATE`` environment variables, ``~/.canrc``...).
"""

from __future__ import annotations

import ast
import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import can
import can.util

from evtribo.errors import AcquisitionError, ConfigError

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


def open_bus(settings: BusSettings) -> can.BusABC:
    """Open the python-can bus *settings* describe; fill in what python-can's config chose.

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
        bus = can.Bus(**kwargs)
    except can.CanInterfaceNotImplementedError as err:
        raise ConfigError(f"python-can cannot use interface {settings.interface!r}: {err}",
                          key="--interface") from err
    except can.CanInitializationError as err:
        raise AcquisitionError(f"cannot open {settings.interface or 'the bus'} "
                               f"{settings.channel or ''}: {err}".replace("  ", " ")) from err
    except (TypeError, ValueError) as err:
        raise ConfigError(f"the bus refused its settings {kwargs}: {err}",
                          key="--bus-option") from err
    except OSError as err:
        raise AcquisitionError(f"cannot open {settings.interface or 'the bus'} "
                               f"{settings.channel or ''}: {err}") from err
    log.info("opened %s", bus.channel_info)
    return bus


__all__ = ["BusSettings", "open_bus", "parse_bus_options"]
