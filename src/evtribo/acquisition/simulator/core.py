"""The simulated rig's frames, generated chunk by chunk: offline in one call, or streamed.

Each node (normal-force cell, tangential-force cell, amplifier) samples the trial's physics
on its own clock (nominal rate, ppm error, random phase) and its frames reach the logger
after a fixed latency plus exponential jitter. The load cells report the true forces through
their cross-talk, zero offset, drift and hum (:mod:`~evtribo.acquisition.simulator.physics`).
Frames are produced in reception order, one chunk of :data:`CHUNK_S` seconds of true time at
a time, so that the offline trial and the real-time stream give the same frames for the same
seed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cantools
import numpy as np
import numpy.typing as npt

from evtribo.acquisition.simulator.anyrig import RigEncoder
from evtribo.acquisition.simulator.cells import Creep
from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig
from evtribo.acquisition.simulator.delivery import Delivery
from evtribo.acquisition.simulator.encode import pack_signals
from evtribo.acquisition.simulator.finger import SimulatedFriction, contact_time, press_cycle
from evtribo.acquisition.simulator.physics import (
    CONTACT_RAMP_S,
    FORCE_STEP_S,
    CellZero,
    Contact,
    NormalForceProcess,
    Strokes,
    drive_force,
    excitation_gate,
    expected_electrostatic_force,
    measured,
    model_parameters,
    on_off_schedule,
)
from evtribo.acquisition.simulator.truth import FEL_BIN_S, TrialTruth
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import Rig, default_rig
from evtribo.errors import RigConfigError

log = logging.getLogger(__name__)

__all__ = ["CHUNK_S", "DEFAULT_DBC", "TrialGenerator", "TrialTruth", "simulate_trial"]

#: The default rig's CAN database (FzCell 0x0C1, FxCell 0x0C2, HvStatus 0x1A0).
DEFAULT_DBC = Path(__file__).resolve().parents[2] / "data" / "rigs" / "default.dbc"
#: Frames are generated this many seconds of trial time at a time.
CHUNK_S = 1.0
#: ... and this many once the amplifier obeys commands (its answer's delay at most).
OBEY_CHUNK_S = 0.05
#: Ids of other nodes on the bus when foreign traffic is asked for (standard and extended).
FOREIGN_IDS = ((0x123, False), (0x7E8, False), (0x18FEF100, True), (0x0CF00400, True))
#: Rolling counter of each message (+1 per frame, modulo its bit width).
COUNTERS = {"FzCell": "FzCounter", "FxCell": "FxCounter", "HvStatus": "HvCounter"}
#: Waveform code in HvStatus.HvWave (the DBC's value table).
WAVE_CODE = {"sine": 0, "square": 1}
#: Nominal leakage current reported by the amplifier at 140 V, uA (not modelled further).
LEAK_UA_AT_140V = 4.0

#: A finger pressing without sliding still shears the skin a little: this share of its
#: target force, slowly wandering.
PRESS_SHEAR = 0.02
#: Contact above this counts as full contact in the truth's means.
FULL_CONTACT = 0.999

# Independent random streams, by purpose (seeded as [seed, stream, chunk]).
(_S_CLOCK, _S_STROKE, _S_FORCE, _S_NOISE, _S_DROP, _S_FOREIGN, _S_FORCE0, _S_DWELL, _S_LIFT,
 _S_HUM, _S_SPEED, _S_FINGER, _S_DELIVERY, _S_SPIKE) = range(14)


@dataclass
class _Node:
    name: str  # message name in the DBC
    message: Any  # cantools Message
    rate_eff: float  # Hz, nominal rate with the clock error
    offset: float  # s, true time of sample 0
    last_rx: float = -math.inf  # reception time of the node's last frame
    frames: int = 0
    dropped: int = 0

    def indices(self, t0: float, t1: float) -> npt.NDArray[np.int64]:
        k0 = max(0, math.ceil((t0 - self.offset) * self.rate_eff))
        k1 = max(k0, math.ceil((t1 - self.offset) * self.rate_eff))
        return np.arange(k0, k1, dtype=np.int64)


#: The CAN databases parsed, by their file's name and bytes (a study's trials share one).
_PARSED: dict[tuple[str, bytes], Any] = {}


def _load_dbc(dbc: str | os.PathLike[str] | None) -> Any:
    path = Path(dbc) if dbc is not None else DEFAULT_DBC
    try:
        key = (path.suffix.lower(), hashlib.sha256(path.read_bytes()).digest())
        db = _PARSED.get(key)
        if db is None:  # read-only here: only its messages are looked up
            db = _PARSED[key] = cantools.database.load_file(str(path))
    except (OSError, cantools.database.UnsupportedDatabaseFormatError) as err:
        raise RigConfigError(f"cannot load the CAN database: {err}", path=path) from err
    if not isinstance(db, cantools.database.can.Database):
        raise RigConfigError("not a CAN database (a DBC, KCD, ARXML or SYM file)", path=path)
    for name in ("FzCell", "FxCell", "HvStatus"):
        try:
            db.get_message_by_name(name)
        except KeyError as err:
            raise RigConfigError(f"the simulated rig needs message {name!r}, which the DBC "
                                 "lacks", path=path, key=name) from err
    return db


def _speaks_default(rig: Rig) -> bool:
    """Whether *rig* is the default rig (the same DBC bytes and roles): no re-encoding."""
    return rig.fingerprint() == default_rig().fingerprint()


class TrialGenerator:
    """Frames of one simulated trial, chunk after chunk, in reception order.

    Parameters
    ----------
    subject : SubjectParams
    config : TrialConfig
    dbc : path-like, optional
        The rig's DBC (default: the default rig). It must have the default rig's messages
        ``FzCell`` (``Fz``, ``FzCounter``), ``FxCell`` (``Fx``, ``FxCounter``) and
        ``HvStatus`` (``HvOn``, ``HvWave``, ``HvAmp``, ``HvFreq``, ``HvCounter``).
    rig : Rig, optional
        Another rig to speak: the frames are re-encoded through its DBC and roles
        (:class:`~evtribo.acquisition.simulator.anyrig.RigEncoder`).
    """

    def __init__(self, subject: SubjectParams, config: TrialConfig,
                 dbc: str | os.PathLike[str] | None = None, *,
                 record_electrostatic: bool = False, rig: Rig | None = None) -> None:
        self.subject, self.config = subject, config
        self.record_electrostatic = record_electrostatic
        self.db = _load_dbc(dbc)
        self.encoder = None if rig is None or _speaks_default(rig) else RigEncoder(rig)
        self.params = model_parameters(subject)
        seed = config.seed
        clock_rng = np.random.default_rng([seed, _S_CLOCK])
        self.nodes = []
        for name, rate, ppm in (("FzCell", config.fz_rate_Hz, config.fz_ppm),
                                ("FxCell", config.fx_rate_Hz, config.fx_ppm),
                                ("HvStatus", config.hv_rate_Hz, config.hv_ppm)):
            rate_eff = rate * (1 + ppm * 1e-6)
            self.nodes.append(_Node(name, self.db.get_message_by_name(name), rate_eff,
                                    float(clock_rng.uniform(0, 1 / rate_eff))))
        self.strokes = Strokes.draw(subject, config.duration_s,
                                    np.random.default_rng([seed, _S_STROKE]),
                                    np.random.default_rng([seed, _S_DWELL]),
                                    np.random.default_rng([seed, _S_SPEED]))
        self.friction = SimulatedFriction.of(subject, np.random.default_rng([seed, _S_FINGER]))
        self.delivery = Delivery.draw(config, np.random.default_rng([seed, _S_DELIVERY]))
        self.creep = {"normal": Creep(config.creep, config.creep_time_s),
                      "tangential": Creep(config.creep, config.creep_time_s)}
        self.contact = Contact.draw(subject, config.tare_s, config.duration_s,
                                    np.random.default_rng([seed, _S_LIFT]))
        phases = np.random.default_rng([seed, _S_HUM]).uniform(0, 2 * np.pi, 4)
        self.zeros = {
            "normal": CellZero(config.fz_offset_N, config.fz_drift_N_per_s,
                               config.fz_thermal_N, config.thermal_time_s, config.fz_hum_N,
                               config.mains_Hz, (float(phases[0]), float(phases[1]))),
            "tangential": CellZero(config.fx_offset_N, config.fx_drift_N_per_s,
                                   config.fx_thermal_N, config.thermal_time_s,
                                   config.fx_hum_N, config.mains_Hz,
                                   (float(phases[2]), float(phases[3]))),
        }
        self.force = NormalForceProcess(subject, np.random.default_rng([seed, _S_FORCE0]))
        self.foreign_frames = 0
        self._sums = {"fn_on": 0.0, "n_on": 0, "fn_off": 0.0, "n_off": 0, "fel": 0.0,
                      "n_fel": 0}
        self._fel_sum: list[npt.NDArray[np.float64]] = []
        self._fel_count: list[npt.NDArray[np.int64]] = []
        self._mu_sum: list[npt.NDArray[np.float64]] = []
        self._first_rx: float | None = None
        self._carry = FrameTable.empty(channel=config.channel)
        self._chunk = 0
        self._t_next = 0.0
        self.chunk_s = CHUNK_S
        self._done = False

    # -- one node's frames -------------------------------------------------------------
    def _rx_times(self, node: _Node, t: npt.NDArray[np.float64],
                  rng: np.random.Generator) -> npt.NDArray[np.float64]:
        rx = t + self.config.latency_s
        if self.config.jitter_s > 0:
            rx = rx + rng.exponential(self.config.jitter_s, t.shape)
        rx = np.maximum.accumulate(np.concatenate([[node.last_rx], rx]))[1:]
        if rx.size:
            node.last_rx = float(rx[-1])
        return rx

    def _frames(self, node: _Node, k: npt.NDArray[np.int64], rx: npt.NDArray[np.float64],
                values: dict[str, Any], rng: np.random.Generator) -> FrameTable:
        counter = node.message.get_signal_by_name(COUNTERS[node.name])
        values[counter.name + "_raw"] = k % (1 << counter.length)
        data = pack_signals(node.message, values, k.size)
        keep = np.ones(k.size, dtype=bool)
        if self.config.drop_probability > 0:
            keep = rng.random(k.size) >= self.config.drop_probability
        node.frames += int(keep.sum())
        node.dropped += int(k.size - keep.sum())
        n = int(keep.sum())
        return FrameTable(
            timestamp=rx[keep], arbitration_id=np.full(n, node.message.frame_id, np.uint32),
            is_extended=np.full(n, node.message.is_extended_frame), is_remote=np.zeros(n, bool),
            is_error=np.zeros(n, bool), is_fd=np.zeros(n, bool),
            dlc=np.full(n, node.message.length, np.uint8), data=data[keep],
            channel=self.config.channel)

    def _foreign(self, t0: float, t1: float, rng: np.random.Generator) -> FrameTable:
        n = int(rng.poisson(self.config.foreign_rate_Hz * (t1 - t0)))
        which = rng.integers(0, len(FOREIGN_IDS), n)
        dlc = rng.integers(0, 9, n).astype(np.uint8)
        data = rng.integers(0, 256, (n, 8), dtype=np.uint8)
        data[np.arange(8)[None, :] >= dlc[:, None]] = 0
        self.foreign_frames += n
        return FrameTable(
            timestamp=np.sort(rng.uniform(t0, t1, n)) + self.config.latency_s,
            arbitration_id=np.array([FOREIGN_IDS[i][0] for i in which], dtype=np.uint32),
            is_extended=np.array([FOREIGN_IDS[i][1] for i in which], dtype=bool),
            is_remote=np.zeros(n, bool), is_error=np.zeros(n, bool), is_fd=np.zeros(n, bool),
            dlc=dlc, data=data, channel=self.config.channel)

    def _friction(self, t: npt.NDArray[np.float64], fn: npt.NDArray[np.float64],
                  contact: npt.NDArray[np.float64], interval_s: float
                  ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """True friction force (signed) and electrostatic force at times *t*, N, as a cell
        sampling every *interval_s* reports them, given the true normal force *fn* there
        and the finger's contact."""
        press = np.where(contact > 0, fn / np.maximum(contact, 1e-12), 0.0)
        fel = contact * drive_force(t, press, self.config, self.params, interval_s)
        if self.config.press_only:  # no sliding: the skin's small shear only
            shear = PRESS_SHEAR * self.subject.normal_force_N * np.sin(2 * np.pi * t / 7.0)
            return np.where(contact > 0, shear, 0.0), fel
        return self.friction.force(self.mu_at(t), fn + fel) * self.strokes.factor(t), fel

    def mu_at(self, t: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The finger's friction coefficient at times *t* (s from the trial's start), at
        the law's reference load (:class:`~evtribo.acquisition.simulator.finger.
        SimulatedFriction`)."""
        law = self.friction
        if law.constant:
            return np.full(t.shape, law.mu0)
        i = self.strokes.index(t)
        tc = contact_time(t, self.contact.start, self.contact.end, CONTACT_RAMP_S)
        return law.mu(tc, self.strokes.speed[i], self.strokes.direction[i])

    def _reading(self, cell: str, row: tuple[float, float], fn: npt.NDArray[np.float64],
                 ft: npt.NDArray[np.float64] | float, t: npt.NDArray[np.float64], *,
                 rng: np.random.Generator) -> npt.NDArray[np.float64]:
        """What a cell reads of the true forces at times *t*: cross-talk, creep, its zero,
        noise and spikes, N."""
        cfg = self.config
        load = self.creep[cell](t, row[0] * fn + row[1] * np.asarray(ft))
        out = measured((1.0, 0.0), load, 0.0, self.zeros[cell], t) \
            + cfg.noise_N * rng.standard_normal(t.size)
        if cfg.spike_rate_Hz > 0 and t.size:
            spikes = np.random.default_rng([cfg.seed, _S_SPIKE, self._chunk,
                                            0 if cell == "normal" else 1])
            n = int(spikes.poisson(cfg.spike_rate_Hz * t.size / self.nodes[
                0 if cell == "normal" else 1].rate_eff))
            where = spikes.integers(0, t.size, n)
            out[where] += spikes.uniform(-cfg.spike_N, cfg.spike_N, n)
        return out

    # -- one chunk -----------------------------------------------------------------------
    def _chunk_frames(self, t0: float, t1: float) -> FrameTable:
        cfg, seed, c = self.config, self.config.seed, self._chunk
        noise = np.random.default_rng([seed, _S_NOISE, c])
        drop = np.random.default_rng([seed, _S_DROP, c])
        # the normal force on its grid, covering [t0, t1]
        j0 = self.force.index
        j1 = math.ceil(t1 / FORCE_STEP_S)
        grid_f = self.force.advance(j1 - j0, np.random.default_rng([seed, _S_FORCE, c]))
        grid_t = np.arange(j0, j1 + 1) * FORCE_STEP_S

        def fn_at(t: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
            fn = np.maximum(np.interp(t, grid_t, grid_f), 0.0)
            return fn * press_cycle(t) if cfg.press_only else fn

        fz, fx, hv = self.nodes
        tables = []
        xtalk = cfg.crosstalk
        # normal-force cell
        k = fz.indices(t0, t1)
        t = fz.offset + k / fz.rate_eff
        contact = self.contact.factor(t)
        fn = contact * fn_at(t)
        gate = excitation_gate(t, cfg)
        full = contact >= FULL_CONTACT
        s = self._sums
        s["fn_on"] += float(fn[gate & full].sum())
        s["n_on"] += int((gate & full).sum())
        s["fn_off"] += float(fn[~gate & full].sum())
        s["n_off"] += int((~gate & full).sum())
        ft = self._friction(t, fn, contact, 1 / fz.rate_eff)[0] if xtalk[0][1] else 0.0
        values: dict[str, Any] = {"Fz": self._reading("normal", xtalk[0], fn, ft, t, rng=noise),
                  "FzTemp": 24.0 + 0.5 * np.sin(2 * np.pi * t / 600.0)}
        tables.append(self._frames(fz, k, self._rx_times(fz, t, noise), values, drop))
        # tangential-force cell
        k = fx.indices(t0, t1)
        t = fx.offset + k / fx.rate_eff
        contact = self.contact.factor(t)
        fn = contact * fn_at(t)
        ft, fel = self._friction(t, fn, contact, 1 / fx.rate_eff)
        on = excitation_gate(t, cfg)
        full = contact >= FULL_CONTACT
        s["fel"] += float(fel[on & full].sum())
        s["n_fel"] += int((on & full).sum())
        if self.record_electrostatic:
            b0 = round(t0 / FEL_BIN_S)
            bins = np.floor(t / FEL_BIN_S).astype(np.int64) - b0
            size = max(round(t1 / FEL_BIN_S) - b0, int(bins.max()) + 1 if bins.size else 0)
            self._fel_sum.append(np.bincount(bins, weights=fel, minlength=size)[:size]
                                 .astype(np.float64, copy=False))
            self._fel_count.append(np.bincount(bins, minlength=size)[:size])
            mu = self.friction.coefficient_at(self.mu_at(t), fn)  # F_t / F_n when OFF
            self._mu_sum.append(np.bincount(bins, weights=mu, minlength=size)[:size]
                                .astype(np.float64, copy=False))
        values = {"Fx": self._reading("tangential", xtalk[1], fn, ft, t, rng=noise),
                  "FxTemp": 24.5 + 0.5 * np.sin(2 * np.pi * t / 700.0)}
        tables.append(self._frames(fx, k, self._rx_times(fx, t, noise), values, drop))
        # amplifier status
        k = hv.indices(t0, t1)
        t = hv.offset + k / hv.rate_eff
        on = excitation_gate(t, cfg)
        values = {"HvOn_raw": on.astype(np.int64), "HvWave_raw": WAVE_CODE[cfg.waveform],
                  "HvAmp": cfg.amplitude_V, "HvFreq": cfg.frequency_Hz,
                  "HvCurrent": np.where(on, LEAK_UA_AT_140V * cfg.amplitude_V / 140.0, 0.0)}
        tables.append(self._frames(hv, k, self._rx_times(hv, t, noise), values, drop))
        if cfg.foreign_rate_Hz > 0:
            tables.append(self._foreign(t0, t1, np.random.default_rng([seed, _S_FOREIGN, c])))
        return FrameTable.concat(tables)

    def command(self, *, enabled: bool | None = None, amplitude_V: float | None = None,
                frequency_Hz: float | None = None, waveform: str | None = None) -> None:
        """Obey the amplifier's command from the next chunk on (what is not given stays);
        chunks are :data:`OBEY_CHUNK_S` long from then on.

        Parameters
        ----------
        enabled : bool, optional
            The high voltage on (the trial's condition becomes ``on``) or off (``off``).
        amplitude_V, frequency_Hz : float, optional
        waveform : str, optional
            ``"sine"`` or ``"square"`` (another name is ignored, with a warning).
        """
        changes: dict[str, Any] = {}
        if enabled is not None:
            changes["condition"] = "on" if enabled else "off"
        if amplitude_V is not None:
            changes["amplitude_V"] = float(amplitude_V)
        if frequency_Hz is not None and frequency_Hz > 0:
            changes["frequency_Hz"] = float(frequency_Hz)
        if waveform is not None:
            if waveform in WAVE_CODE:
                changes["waveform"] = waveform
            else:
                log.warning("the simulated amplifier cannot apply a %r waveform", waveform)
        if changes:
            self.config = dataclasses.replace(self.config, **changes)
        self.chunk_s = OBEY_CHUNK_S  # from now on the amplifier answers within this

    def lift(self, duration_s: float) -> None:
        """The finger lifted for *duration_s* from the next chunk on (a new recording's tare
        stretch, when the simulated rig runs on for several trials).

        Parameters
        ----------
        duration_s : float, s
        """
        if duration_s > 0:
            self.contact = self.contact.lifted_at(self._t_next, duration_s)

    def chunks(self) -> Iterator[FrameTable]:
        """Frames in reception order, about :data:`CHUNK_S` s at a time (:data:`OBEY_CHUNK_S`
        once the amplifier has been commanded), to the trial's end.

        Timestamps are ``config.start_time`` plus the reception time in the trial.
        """
        cfg = self.config
        while self._t_next < cfg.duration_s:
            t0 = self._t_next
            t1 = min(t0 + self.chunk_s, cfg.duration_s)
            new = self._chunk_frames(t0, t1)
            self._chunk += 1
            self._t_next = t1
            table = FrameTable.concat([self._carry, new]).sorted_by_time()
            last = t1 >= cfg.duration_s
            cut = len(table) if last else int(np.searchsorted(table.timestamp, t1, "left"))
            self._carry = table.take(np.arange(cut, len(table)))
            out = table.take(np.arange(cut))
            if not self.delivery.ideal:
                out = out.take(np.flatnonzero(~self.delivery.lost(out.timestamp)))
                out.timestamp = self.delivery.stamps(out.timestamp)
            if self._first_rx is None and len(out):
                self._first_rx = float(out.timestamp[0])
            out.timestamp = out.timestamp + cfg.start_time
            yield out if self.encoder is None else self.encoder.convert(out)
        self._done = True

    def truth(self) -> TrialTruth:
        """The truth record (complete once :meth:`chunks` is exhausted)."""
        s, cfg = self._sums, self.config
        fn_on = s["fn_on"] / s["n_on"] if s["n_on"] else None
        fel_model = None
        if fn_on is not None:
            fel_model = expected_electrostatic_force(fn_on, cfg, self.params)
        sine_on = cfg.waveform == "sine" and s["n_on"] > 0 and cfg.amplitude_V > 0
        nodes = {n.name: {"frame_id": n.message.frame_id, "rate_Hz": n.rate_eff,
                          "clock_offset_s": n.offset, "frames": n.frames,
                          "dropped": n.dropped} for n in self.nodes}
        return TrialTruth(
            subject=self.subject, config=cfg, schedule=on_off_schedule(cfg),
            slides=self.strokes.slides(cfg.duration_s),
            slide_speeds_m_s=[v for *_, v in self.strokes.slides_with_speed(cfg.duration_s)],
            friction=dataclasses.asdict(self.friction),
            outages=self.delivery.periods(),
            normal_force_on_N=fn_on,
            normal_force_off_N=s["fn_off"] / s["n_off"] if s["n_off"] else None,
            electrostatic_force_N=fel_model,
            electrostatic_force_mean_N=s["fel"] / s["n_fel"] if s["n_fel"] else None,
            friction_modulation_Hz=2 * cfg.frequency_Hz if sine_on else None,
            nodes=nodes if self.encoder is None else self.encoder.nodes(nodes),
            foreign_frames=self.foreign_frames,
            lifted=self.contact.lifted(cfg.duration_s),
            contact_lost=self.contact.periods(cfg.duration_s),
            steady=self._steady(),
            cells={name: {"offset_N": z.offset_N, "drift_N_per_s": z.drift_N_per_s,
                          "thermal_N": z.thermal_N, "thermal_time_s": z.thermal_time_s,
                          "hum_N": z.hum_N, "mains_Hz": z.mains_Hz,
                          "mean_offset_N": z.mean_offset(0.0, cfg.duration_s)}
                   for name, z in self.zeros.items()},
            crosstalk=[list(row) for row in cfg.crosstalk],
            calibration_matrix=np.linalg.inv(np.asarray(cfg.crosstalk)).tolist(),
            first_frame_s=self._first_rx,
            fel_sum=np.concatenate(self._fel_sum) if self._fel_sum else None,
            fel_count=np.concatenate(self._fel_count) if self._fel_count else None,
            mu_sum=np.concatenate(self._mu_sum) if self._mu_sum else None,
        )

    def _steady(self) -> list[tuple[float, float, int, bool]]:
        """Steady sliding in one condition: slides less contact losses, cut at switches."""
        lost = self.contact.periods(self.config.duration_s)
        out = []
        for a, b, d in self.strokes.slides(self.config.duration_s):
            pieces = [(a, b)]
            for la, lb in lost:
                pieces = [q for p0, p1 in pieces
                          for q in ((p0, min(p1, la)), (max(p0, lb), p1)) if q[1] > q[0]]
            for p0, p1 in pieces:
                for s0, s1, on in on_off_schedule(self.config):
                    lo, hi = max(p0, s0), min(p1, s1)
                    if hi > lo:
                        out.append((lo, hi, d, on))
        return out


def simulate_trial(subject: SubjectParams | None = None, config: TrialConfig | None = None,
                   dbc: str | os.PathLike[str] | None = None, *, rig: Rig | None = None
                   ) -> tuple[FrameTable, TrialTruth]:
    """Simulate one trial offline: every frame the logger would receive, and the truth.

    Parameters
    ----------
    subject : SubjectParams, optional
        The subject (default: Table 1's mu and air gap, 0.5 N).
    config : TrialConfig, optional
        The trial (default: 30 s, 140 V square at 10 kHz, alternating 2 s / 2 s).
    dbc : path-like, optional
        The rig's DBC (default: the default rig).
    rig : Rig, optional
        Another rig to speak (its DBC and roles).

    Returns
    -------
    frames : FrameTable
        In reception order; timestamps in s since the epoch (``config.start_time`` + t).
    truth : TrialTruth
        What the analysis should recover.
    """
    gen = TrialGenerator(subject or SubjectParams(), config or TrialConfig(), dbc,
                         record_electrostatic=True, rig=rig)
    frames = FrameTable.concat(list(gen.chunks()))
    frames.channel = gen.config.channel
    return frames, gen.truth()
