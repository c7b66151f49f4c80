"""The rig's CAN database, the frames' bits and the candump ``-L`` text.

The DBC is this generator's own (Motorola and Intel signals, signed and unsigned, a 4-bit
counter, the amplifier's status on an extended identifier with a value table), read with
cantools. Frames are packed from cantools' signal definitions with numpy, a whole stream at
once; ``test_generator.py`` holds the packing against ``cantools``' ``Message.encode`` bit
for bit.
"""

from __future__ import annotations

from pathlib import Path

import cantools
import numpy as np

DBC_TEXT = """VERSION "heldout-rig-1"

NS_ :

BS_:

BU_: NCELL TCELL HVAMP DAQ

BO_ 385 PadNormal: 8 NCELL
 SG_ Normal : 7|24@0- (2e-05,0) [-167.77216|167.77214] "N" DAQ
 SG_ Seq : 32|8@1+ (1,0) [0|255] "" DAQ
 SG_ Overload : 40|1@1+ (1,0) [0|1] "" DAQ

BO_ 386 PadShear: 8 TCELL
 SG_ Shear : 0|20@1- (5e-06,0) [-2.62144|2.621435] "N" DAQ
 SG_ Seq : 24|4@1+ (1,0) [0|15] "" DAQ
 SG_ TempC : 39|12@0- (0.05,20) [-82.4|122.35] "degC" DAQ

BO_ 2566869157 HvMonitor: 8 HVAMP
 SG_ Active : 0|1@1+ (1,0) [0|1] "" DAQ
 SG_ Shape : 1|2@1+ (1,0) [0|3] "" DAQ
 SG_ Volts : 8|16@1+ (0.01,0) [0|655.35] "V" DAQ
 SG_ Hertz : 24|24@1+ (0.1,0) [0|1677721.5] "Hz" DAQ

CM_ SG_ 385 Normal "Normal force on the screen, positive pressing into it";
CM_ SG_ 386 Shear "Tangential force on the screen, sign follows the sliding direction";
CM_ SG_ 2566869157 Active "1 while the high voltage is applied";
VAL_ 2566869157 Shape 0 "sine" 1 "square" 2 "triangle" 3 "dc" ;
"""

#: The study.toml roles of this rig.
ROLES = {
    "normal_force": "PadNormal.Normal",
    "tangential_force": "PadShear.Shear",
    "normal_force_counter": "PadNormal.Seq",
    "tangential_force_counter": "PadShear.Seq",
}
EXCITATION_ROLES = {
    "excitation_enabled": "HvMonitor.Active",
    "excitation_amplitude": "HvMonitor.Volts",
    "excitation_frequency": "HvMonitor.Hertz",
    "excitation_waveform": "HvMonitor.Shape",
}
WAVE_CODE = {"sine": 0, "square": 1}
HEARTBEAT_ID = 0x701  # not in the DBC: traffic the rig does not describe


def database() -> cantools.database.can.Database:
    """The rig's DBC, parsed by cantools."""
    return cantools.database.load_string(DBC_TEXT, database_format="dbc")


def write_dbc(path: Path) -> None:
    """Write the DBC file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(DBC_TEXT)


def _raw(signal, values: np.ndarray) -> np.ndarray:
    """Physical values → unsigned raw bit patterns of the signal's length (uint64)."""
    scale = float(signal.scale)
    offset = float(signal.offset)
    raw = np.rint((np.asarray(values, dtype=float) - offset) / scale).astype(np.int64)
    n = signal.length
    lo, hi = (-(1 << (n - 1)), (1 << (n - 1)) - 1) if signal.is_signed else (0, (1 << n) - 1)
    raw = np.clip(raw, lo, hi)
    return (raw & ((1 << n) - 1)).astype(np.uint64)


def pack(message, values: dict[str, np.ndarray], count: int) -> np.ndarray:
    """Pack ``count`` frames of ``message``: (count, length) uint8 payloads.

    Signals missing from ``values`` are 0. Intel signals are placed in the payload read as
    a little-endian integer (bit ``start`` upward); Motorola signals in the payload read as
    a big-endian integer, the DBC's start bit being the signal's most significant bit.
    """
    little = np.zeros(count, dtype=np.uint64)
    big = np.zeros(count, dtype=np.uint64)
    for signal in message.signals:
        if signal.name not in values:
            continue
        raw = _raw(signal, np.broadcast_to(values[signal.name], (count,)))
        if signal.byte_order == "little_endian":
            little |= raw << np.uint64(signal.start)
        else:
            msb = (signal.start // 8) * 8 + (7 - signal.start % 8)
            big |= raw << np.uint64(64 - msb - signal.length)
    payload = little.astype("<u8").view(np.uint8).reshape(count, 8)
    payload = payload | big.astype(">u8").view(np.uint8).reshape(count, 8)
    return payload[:, : message.length]


_HEX = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)


def _digits(values: np.ndarray, width: int, base: int) -> np.ndarray:
    """(N, width) ASCII digits of non-negative integers, most significant first."""
    powers = base ** np.arange(width - 1, -1, -1, dtype=np.int64)
    d = (values[:, None] // powers[None, :]) % base
    return _HEX[d]


def candump_lines(stamps_us: np.ndarray, ids: np.ndarray, extended: np.ndarray,
                  payloads: np.ndarray, dlcs: np.ndarray, *, channel: str = "can0") -> bytes:
    """candump ``-L`` text of frames, one line each, in the order given.

    ``stamps_us`` are integer microseconds since the epoch; ``payloads`` an (N, 8) uint8
    array of which the first ``dlcs[i]`` bytes are written.
    """
    n = stamps_us.size
    head = len(channel) + 21  # "(" 10 "." 6 ") " channel " "
    width = head + 8 + 1 + 16 + 1
    mat = np.full((n, width), ord(" "), dtype=np.uint8)
    mat[:, 0] = ord("(")
    mat[:, 1:11] = _digits(stamps_us // 1_000_000, 10, 10)
    mat[:, 11] = ord(".")
    mat[:, 12:18] = _digits(stamps_us % 1_000_000, 6, 10)
    mat[:, 18] = ord(")")
    mat[:, 20 : 20 + len(channel)] = np.frombuffer(channel.encode(), dtype=np.uint8)
    id_len = np.where(extended, 8, 3)
    lengths = head + id_len + 1 + 2 * dlcs + 1
    for ext, w in ((False, 3), (True, 8)):
        rows = np.flatnonzero(extended == ext)
        if rows.size == 0:
            continue
        mat[rows, head : head + w] = _digits(ids[rows].astype(np.int64), w, 16)
        mat[rows, head + w] = ord("#")
        nib = np.empty((rows.size, 16), dtype=np.uint8)
        nib[:, 0::2] = _HEX[payloads[rows] >> 4]
        nib[:, 1::2] = _HEX[payloads[rows] & 0x0F]
        mat[rows, head + w + 1 : head + w + 17] = nib
    mat[np.arange(n), lengths - 1] = ord("\n")
    keep = np.arange(width)[None, :] < lengths[:, None]
    return mat[keep].tobytes()
