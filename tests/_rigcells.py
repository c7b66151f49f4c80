"""The default rig's load cells heard on python-can's virtual bus as a trial starts: a trial
that hears none of them ends as ``no-rig-data``, never ``completed``; a test whose subject is
something else (its files, its lock, its sidecar) gives it their frames this way, at a
moment that does not depend on how busy the machine is."""

from __future__ import annotations

from collections.abc import Callable

import can

#: The default rig's load-cell messages (FzCell, FxCell): a trial that hears none of them
#: ends as ``no-rig-data``, never ``completed``.
RIG_CELLS = (0x0C1, 0x0C2)


def rig_frames_on(channel: str) -> None:
    """Put one frame of each of the default rig's load cells on python-can's virtual
    *channel* (every bus open on it receives them now)."""
    with can.Bus(interface="virtual", channel=channel) as bus:
        for ident in RIG_CELLS:
            bus.send(can.Message(arbitration_id=ident, is_extended_id=False, data=bytes(8)))


def rig_heard(channel: str, then: Callable[..., None] | None = None) -> Callable[..., None]:
    """A ``started`` hook of :func:`~evtribo.acquisition.trial.record_trial`: the rig's
    load cells are heard on *channel* as the trial starts (after what the bus held was
    discarded), whatever the machine's load; *then* runs after."""
    def started(paths):
        rig_frames_on(channel)
        if then is not None:
            then(paths)
    return started
