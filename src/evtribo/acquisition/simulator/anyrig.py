"""The simulated rig speaking any rig's DBC: its frames re-encoded by role.

The simulator generates the default rig's frames (``FzCell``, ``FxCell``, ``HvStatus``);
:class:`RigEncoder` turns them, chunk by chunk, into the frames of another rig: each role of
the target rig (``normal_force``, ``tangential_force``, their counters, the
``excitation_*`` status signals) carries the same physical value, encoded with cantools'
layout of the target's signal (any ID, byte order, scale, offset, width; a CAN FD message
as an FD frame of its length) by :func:`~evtribo.acquisition.simulator.encode.pack_signals`.
A message of the target is sent at the times of the node its first role comes from (the
normal cell, the tangential cell or the amplifier); a role from another node holds that
node's latest value. A counter counts the frames its node sent, lost ones too. Waveforms go
through the value tables by name (``"square"``). Traffic of other nodes passes through,
unless it collides with one of the target's identifiers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from cantools.database.can import Message

from evtribo.acquisition.simulator.encode import pack_signals
from evtribo.canlog.decode import message_mask
from evtribo.canlog.frame_match import is_fd_message
from evtribo.canlog.io.ids import frame_key, frame_keys
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import Rig, SignalRef, default_rig
from evtribo.canlog.signal_codec import SignalCodec

__all__ = ["RigEncoder"]

#: The default rig's node of each role, and the node's signal carrying it.
_SOURCE = {
    "normal_force": ("FzCell", "Fz"), "tangential_force": ("FxCell", "Fx"),
    "excitation_enabled": ("HvStatus", "HvOn"), "excitation_amplitude": ("HvStatus", "HvAmp"),
    "excitation_frequency": ("HvStatus", "HvFreq"),
    "excitation_waveform": ("HvStatus", "HvWave"),
}
_COUNTER_OF = {"normal_force_counter": "normal_force",
               "tangential_force_counter": "tangential_force"}
#: The default rig's rolling counter of each node.
_NODE_COUNTER = {"FzCell": "FzCounter", "FxCell": "FxCounter", "HvStatus": "HvCounter"}
#: Which node clocks a message holding several roles: the first of these it holds.
_CLOCK_ORDER = ("normal_force", "tangential_force", "excitation_enabled",
                "excitation_amplitude", "excitation_frequency", "excitation_waveform")


@dataclass
class _Target:
    """One message of the target rig and the roles it carries."""

    message: Message
    roles: dict[str, str] = field(default_factory=dict)   # role -> signal name
    clock: str = ""                                       # the default node sending it


def _wave_map(source: SignalRef | None, target: SignalRef | None
              ) -> npt.NDArray[np.int64] | None:
    """Lookup table: default waveform code to the target's, by value-table name (None: the
    codes are kept)."""
    if target is None or source is None or not target.signal.choices \
            or not source.signal.choices:
        return None
    by_name = {str(v).lower(): int(k) for k, v in target.signal.choices.items()}
    table = np.arange(1 << source.signal.length, dtype=np.int64)
    for k, v in source.signal.choices.items():
        table[int(k)] = by_name.get(str(v).lower(), int(k))
    return table


class RigEncoder:
    """Re-encode the default simulated rig's frames for *rig*.

    Parameters
    ----------
    rig : Rig
        The target rig (a study's ``[rig]``, or a rig TOML).

    Examples
    --------
    >>> enc = RigEncoder(load_rig("my-rig.toml"))                 # doctest: +SKIP
    >>> frames = FrameTable.concat([enc.convert(c) for c in generator.chunks()])  # doctest: +SKIP
    """

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.source = default_rig()
        db = self.source.database
        self._codecs = {name: {s.name: SignalCodec.from_signal(s) for s in m.signals}
                        for name in ("FzCell", "FxCell", "HvStatus")
                        for m in [db.get_message_by_name(name)]}
        self._messages = {name: db.get_message_by_name(name) for name in self._codecs}
        self._last: dict[str, float] = {}
        self._counted: dict[str, tuple[int, int]] = {}
        self.targets: list[_Target] = []
        by_message: dict[str, _Target] = {}
        roles = dict(rig.measured_roles)  # what the rig sends (not the command it obeys)
        for cell in ("normal", "tangential"):
            counter = rig.counter(cell)
            if counter is not None:
                roles[f"{cell}_force_counter"] = counter
        for role, ref in roles.items():
            tgt = by_message.setdefault(ref.message.name, _Target(ref.message))
            tgt.roles[role] = ref.signal.name
        for tgt in by_message.values():
            clock = next((r for r in _CLOCK_ORDER if r in tgt.roles), None)
            if clock is None:  # only counters: clocked by their force's cell
                clock = next(_COUNTER_OF[r] for r in tgt.roles if r in _COUNTER_OF)
            tgt.clock = _SOURCE[clock][0]
            self.targets.append(tgt)
        mine = [t.message for t in self.targets] + list(self._messages.values())
        self._taken = np.array([frame_key(m.frame_id, bool(m.is_extended_frame))
                                for m in mine], dtype=np.int64)
        self._wave = _wave_map(self.source.excitation_waveform, rig.excitation_waveform)

    def nodes(self, default: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
        """The simulator's record of each default node, told as the target rig's messages.

        Parameters
        ----------
        default : dict
            Per default node (``FzCell``, ``FxCell``, ``HvStatus``): its ``frame_id``,
            rate, clock offset, frames sent and dropped.

        Returns
        -------
        dict
            Per message of the target rig: its own ``frame_id``, and the rate, clock offset,
            frames and drops of the node that clocks it.
        """
        return {t.message.name: {**default[t.clock], "frame_id": t.message.frame_id}
                for t in self.targets if t.clock in default}

    def _values(self, frames: FrameTable) -> dict[str, tuple[npt.NDArray[np.float64],
                                                             dict[str, npt.NDArray[np.float64]]]]:
        """Each default node's frame times and physical values in *frames*."""
        out = {}
        for name, message in self._messages.items():
            idx = np.flatnonzero(message_mask(frames, message))
            data = frames.data[idx]
            values = {s: c.decode(data) for s, c in self._codecs[name].items()}
            values["_counter"] = self._codecs[name][_NODE_COUNTER[name]].raw(data).astype(
                np.float64)
            out[name] = (frames.timestamp[idx], values)
        return out

    def _count(self, node: str, raw: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
        """Frames *node* has sent, at each of its frames: its rolling counter unwrapped
        (frames lost on the way still count, as on a real rig)."""
        bits = self._messages[node].get_signal_by_name(_NODE_COUNTER[node]).length
        r = raw.astype(np.int64)
        prev_k, prev_raw = self._counted.get(node, (-1, -1))
        if r.size == 0:
            return r
        first = (r[0] - prev_raw) % (1 << bits) if prev_raw >= 0 else 1
        steps = np.concatenate([[first], np.diff(r) % (1 << bits)])
        k = prev_k + np.cumsum(steps)
        self._counted[node] = (int(k[-1]), int(r[-1]))
        return k

    def _role_at(self, role: str, t: npt.NDArray[np.float64],
                 nodes: dict[str, tuple[npt.NDArray[np.float64],
                                        dict[str, npt.NDArray[np.float64]]]]
                 ) -> npt.NDArray[np.float64]:
        """The value of *role* at times *t*: its node's latest value (held)."""
        node, signal = _SOURCE[role]
        ts, values = nodes[node]
        v = values[signal]
        pos = np.searchsorted(ts, t, side="right") - 1
        held = np.where(pos >= 0, v[np.maximum(pos, 0)] if v.size else np.nan,
                        self._last.get(role, 0.0))
        if v.size:
            self._last[role] = float(v[-1])
        return np.asarray(held, dtype=np.float64)

    def convert(self, frames: FrameTable) -> FrameTable:
        """One chunk of the default rig's frames, as the target rig's.

        Parameters
        ----------
        frames : FrameTable
            A chunk of :meth:`~evtribo.acquisition.simulator.TrialGenerator.chunks`, in
            reception order (chunks must be converted in order: counters and held values
            carry over).

        Returns
        -------
        FrameTable
            The target rig's frames and the other nodes' traffic, in reception order.
        """
        nodes = self._values(frames)
        counts = {name: self._count(name, values["_counter"])
                  for name, (_, values) in nodes.items()}
        tables = []
        for tgt in self.targets:
            t = nodes[tgt.clock][0]
            values: dict[str, npt.ArrayLike] = {}
            for role, signal in tgt.roles.items():
                if role in _COUNTER_OF:
                    values[signal + "_raw"] = counts[tgt.clock]
                    continue
                node, name = _SOURCE[role]
                if node == tgt.clock:  # its own node's frames: the values themselves
                    v = nodes[node][1][name]
                    if v.size:
                        self._last[role] = float(v[-1])
                else:
                    v = self._role_at(role, t, nodes)
                if role == "excitation_waveform" and self._wave is not None:
                    values[signal + "_raw"] = self._wave[v.astype(np.int64)]
                    continue
                values[signal] = v
            for sig in tgt.message.signals:
                key = sig.name + "_raw"
                if key in values:
                    values[key] = np.asarray(values[key], np.int64) % (1 << sig.length)
            tables.append(_table(tgt.message, t, values, frames.channel))
        keys = frame_keys(frames.arbitration_id, frames.is_extended)
        tables.append(frames.take(np.flatnonzero(~np.isin(keys, self._taken))))
        return FrameTable.concat(tables).sorted_by_time()


def _table(message: Message, t: npt.NDArray[np.float64], values: dict[str, npt.ArrayLike],
           channel: str | None) -> FrameTable:
    """*message*'s frames at times *t* carrying *values*."""
    n = t.size
    data = pack_signals(message, values, n) if n else \
        np.zeros((0, max(8, -(-message.length // 8) * 8)), np.uint8)
    return FrameTable(
        timestamp=t.copy(), arbitration_id=np.full(n, message.frame_id, np.uint32),
        is_extended=np.full(n, bool(message.is_extended_frame)), is_remote=np.zeros(n, bool),
        is_error=np.zeros(n, bool), is_fd=np.full(n, is_fd_message(message)),
        dlc=np.full(n, message.length, np.uint8), data=data, channel=channel)
