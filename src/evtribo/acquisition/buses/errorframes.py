"""CAN error frames in words: what went wrong on the bus, and the controller's state.

A SocketCAN error frame (``CAN_ERR_FLAG`` set in its identifier) carries its error classes
in the identifier's low bits and the details in its payload (Linux ``<linux/can/error.h>``):
a controller that reached error-passive sets ``CAN_ERR_CRTL`` and ``CAN_ERR_CRTL_RX_PASSIVE``
in byte 1, one that went bus-off sets ``CAN_ERR_BUSOFF``. python-can delivers them as
messages with ``is_error_frame`` and the class bits as ``arbitration_id``; the log keeps them
as ``200000XX#...`` lines. :class:`ErrorTally` counts them by kind and follows the
controller's state, for the sidecar, the display and the summary.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["CLASSES", "CONTROLLER", "STATES", "ErrorTally", "error_kinds"]

#: Error classes (``can_id`` bits) by name.
CLASSES = {0x001: "tx-timeout", 0x002: "lost-arbitration", 0x004: "controller",
           0x008: "protocol-violation", 0x010: "transceiver", 0x020: "no-ack",
           0x040: "bus-off", 0x080: "bus-error", 0x100: "restarted", 0x200: "error-counters"}
#: The controller's problems (payload byte 1 of a ``controller`` error frame).
CONTROLLER = {0x01: "rx-overflow", 0x02: "tx-overflow", 0x04: "rx-warning",
              0x08: "tx-warning", 0x10: "rx-error-passive", 0x20: "tx-error-passive",
              0x40: "error-active"}
#: The controller's states, from the best to the worst.
STATES = ("error-active", "error-warning", "error-passive", "bus-off")
_CLASS_MASK = 0x1FFFFFFF


def error_kinds(arbitration_id: int, data: bytes | bytearray) -> list[str]:
    """What one error frame reports, in words.

    Parameters
    ----------
    arbitration_id : int
        Its identifier without ``CAN_ERR_FLAG`` (the class bits).
    data : bytes
        Its payload.

    Returns
    -------
    list of str
        One name per class bit (``"bus-off"``), a ``controller`` class as its problems
        (``"controller rx-error-passive"``); ``["error"]`` for a frame without a class.
    """
    bits = arbitration_id & _CLASS_MASK
    kinds = []
    for bit, name in CLASSES.items():
        if not bits & bit:
            continue
        problems = [f"controller {what}" for flag, what in CONTROLLER.items()
                    if bit == 0x004 and len(data) > 1 and data[1] & flag]
        kinds += problems or [name]
    return kinds or ["error"]


def _state(arbitration_id: int, data: bytes | bytearray) -> str | None:
    """The controller's state an error frame reports, or None when it reports none."""
    bits = arbitration_id & _CLASS_MASK
    if bits & 0x040:
        return "bus-off"
    status = data[1] if bits & 0x004 and len(data) > 1 else 0
    if status & 0x30:
        return "error-passive"
    if status & 0x0C:
        return "error-warning"
    if status & 0x40 or bits & 0x100:
        return "error-active"
    return None


@dataclass
class ErrorTally:
    """Error frames counted by kind, and the controller's state they report.

    Attributes
    ----------
    by_kind : dict
        Frames per kind (:func:`error_kinds`; a frame of two classes counts in both).
    state : str or None
        The controller's latest state (:data:`STATES`), None while no frame said.
    worst : str or None
        The worst state it reported.
    error_counters : tuple of int or None
        The latest transmit and receive error counters (payload bytes 6 and 7 of a frame
        with ``error-counters``).
    """

    by_kind: dict[str, int] = field(default_factory=dict)
    state: str | None = None
    worst: str | None = None
    error_counters: tuple[int, int] | None = None

    def add(self, arbitration_id: int, data: bytes | bytearray) -> None:
        """Account for one error frame."""
        for kind in error_kinds(arbitration_id, data):
            self.by_kind[kind] = self.by_kind.get(kind, 0) + 1
        state = _state(arbitration_id, data)
        if state is not None:
            self.state = state
            if self.worst is None or STATES.index(state) > STATES.index(self.worst):
                self.worst = state
        if arbitration_id & 0x200 and len(data) >= 8:
            self.error_counters = (data[6], data[7])

    def describe(self) -> str:
        """``"bus-off 1, controller rx-error-passive 2"`` (empty without error frames)."""
        return ", ".join(f"{kind} {n}" for kind, n in sorted(self.by_kind.items()))
