"""Throughput of ``evtribo acquire`` at a saturated 1 Mbit/s bus (~8,400 frames/s).

Records the simulated rig (FzCell 2,800 Hz + FxCell 5,550 Hz + HvStatus 50 Hz of 8-byte
frames) for ``--duration`` s through

(a) python-can's ``virtual`` bus, the simulator sending from a thread of this process;
(b) an slcan adapter emulated on a pty by ``evtribo simulate --pty`` (another process), read
    with python-can's ``slcan`` driver and with evtribo's ``slcan_bulk``;

and prints frames/s sustained, the backlog (frames sent but not yet read when the trial
ended: the reader falling behind), frames lost (by the load cells' rolling counters, or, on the
pty, dropped by the emulated adapter when the reader falls behind, whichever is more) and CPU
time per frame: ``time.process_time`` of this process, and the part spent in the logger's
two threads (receive loop and writer; for (a) the rest is the simulator's sender).

Usage: ``python benchmarks/acquire.py [--duration 10] [--only virtual,slcan,slcan_bulk]``
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import can

from evtribo.acquisition import logger as logger_mod
from evtribo.acquisition.buses.bus import BusSettings, open_bus
from evtribo.acquisition.simulator import Simulator, TrialConfig
from evtribo.acquisition.trial import record_trial

FZ_RATE, FX_RATE, HV_RATE = 2800.0, 5550.0, 50.0


class _ThreadCPU:
    """CPU time, s, of the logger's writer thread (wrapped around ``LogWriter._run``)."""

    def __init__(self) -> None:
        self.writer_cpu = 0.0
        original = logger_mod.LogWriter._run

        def timed(writer: logger_mod.LogWriter) -> None:
            t0 = time.thread_time()
            try:
                original(writer)
            finally:
                self.writer_cpu += time.thread_time() - t0

        logger_mod.LogWriter._run = timed  # type: ignore[method-assign]


def _record(bus: can.BusABC, study: Path, trial: str, duration: float,
            settings: BusSettings, *, started=None) -> tuple[dict, float, float]:
    cpu = _ThreadCPU()
    p0, t0 = time.process_time(), time.thread_time()
    result = record_trial(bus, study, "BENCH", trial, duration=duration, settings=settings,
                          started=started)
    recv_cpu = time.thread_time() - t0
    process_cpu = time.process_time() - p0
    return result.sidecar, process_cpu, recv_cpu + cpu.writer_cpu


def bench_virtual(study: Path, duration: float) -> dict:
    channel = "bench_acquire_virtual"
    cfg = TrialConfig(fz_rate_Hz=FZ_RATE, fx_rate_Hz=FX_RATE, hv_rate_Hz=HV_RATE)
    sim = Simulator(config=cfg)
    tx = can.Bus(interface="virtual", channel=channel)
    out: dict = {}
    sender = threading.Thread(target=lambda: out.update(stats=sim.run(tx, duration=duration)))
    with can.Bus(interface="virtual", channel=channel) as rx:
        side, process_cpu, logger_cpu = _record(
            rx, study, "virtual", duration + 1.0, BusSettings("virtual", channel),
            started=lambda _paths: sender.start())
    sender.join()
    tx.shutdown()
    stats = out["stats"]
    return {"path": "virtual", "sent": stats.sent, **_figures(side, process_cpu, logger_cpu,
                                                                stats.elapsed_s)}


def bench_slcan(study: Path, duration: float, interface: str) -> dict:
    sim = subprocess.Popen(
        [sys.executable, "-m", "evtribo", "simulate", "--pty", "--fz-rate", str(FZ_RATE),
         "--fx-rate", str(FX_RATE), "--hv-rate", str(HV_RATE)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        path = sim.stdout.readline().strip() if sim.stdout else ""
        settings = BusSettings(interface, path, 1_000_000, {"sleep_after_open": 0})
        bus = open_bus(settings)
        try:
            side, process_cpu, logger_cpu = _record(bus, study, interface, duration, settings)
        finally:
            bus.shutdown()
        sim.send_signal(signal.SIGTERM)
        _out, err = sim.communicate(timeout=30)
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
    full = err.strip().splitlines()[-1] if err.strip() else ""
    figures = _figures(side, process_cpu, logger_cpu, side["duration_s"])
    # Frames the emulated adapter had to drop because the reader fell behind: they come in
    # runs that can span whole 256-frame counter periods, invisible to the counters.
    m = re.search(r"(\d+) to a full buffer", full)
    at_adapter = int(m.group(1)) if m else 0
    sent = re.search(r"(\d+) frames sent", full)
    # frames the adapter sent that the reader had not taken when the trial ended: it was
    # falling behind (a longer trial fills the adapter's buffer and frames are dropped)
    figures["backlog"] = max(int(sent.group(1)) - figures["frames"], 0) if sent else 0
    if at_adapter > figures["lost"]:
        figures["lost"] = at_adapter
        figures["lost_pct"] = 100.0 * at_adapter / max(figures["frames"] + at_adapter, 1)
    return {"path": f"slcan pty, {interface}", "simulator": full,
            "dropped_at_adapter": at_adapter, **figures}


def _figures(side: dict, process_cpu: float, logger_cpu: float, span: float) -> dict:
    frames = side["frames"]
    rig = side["frames_by_id"].get("0C1", 0) + side["frames_by_id"].get("0C2", 0)
    return {
        "frames": frames,
        "frames_per_s": frames / span if span else 0.0,
        "lost_by_counters": side["dropped_frames"],
        "lost": side["dropped_frames"],
        "backlog": 0,
        "lost_pct": 100.0 * side["dropped_frames"] / max(rig + side["dropped_frames"], 1),
        "process_cpu_us_per_frame": 1e6 * process_cpu / max(frames, 1),
        "logger_cpu_us_per_frame": 1e6 * logger_cpu / max(frames, 1),
        "ended": side["ended"],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0, help="s per run (10)")
    parser.add_argument("--only", default="virtual,slcan,slcan_bulk",
                        help="comma-separated runs among virtual, slcan, slcan_bulk")
    parser.add_argument("--json", action="store_true", help="print JSON lines")
    args = parser.parse_args()
    runs = args.only.split(",")
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        study = Path(tmp) / "bench"
        for name in runs:
            if name == "virtual":
                results.append(bench_virtual(study, args.duration))
            elif name in ("slcan", "slcan_bulk"):
                results.append(bench_slcan(study, args.duration, name))
            else:
                parser.error(f"unknown run {name!r}")
            if args.json:
                print(json.dumps(results[-1]), flush=True)
    if not args.json:
        print(f"evtribo acquire, {args.duration:.0f} s per run, offered "
              f"{FZ_RATE + FX_RATE + HV_RATE:.0f} frames/s of 8-byte frames")
        print(f"{'path':<24} {'frames/s':>9} {'lost':>7} {'lost %':>7} {'backlog':>8} "
              f"{'CPU us/frame':>13} {'logger us/frame':>16}")
        for r in results:
            print(f"{r['path']:<24} {r['frames_per_s']:9.0f} {r['lost']:7d} "
                  f"{r['lost_pct']:7.2f} {r['backlog']:8d} {r['process_cpu_us_per_frame']:13.1f} "
                  f"{r['logger_cpu_us_per_frame']:16.1f}")
            if r.get("simulator"):
                print(f"    ({r['simulator']})")
        by_path = {r["path"].split(", ")[-1]: r for r in results}
        base, bulk = by_path.get("slcan"), by_path.get("slcan_bulk")
        if base and bulk:  # the baseline: python-can's own slcan driver, same run
            print(f"ratio slcan_bulk / python-can slcan: "
                  f"{bulk['frames_per_s'] / base['frames_per_s']:.2f}x frames/s, "
                  f"{base['logger_cpu_us_per_frame'] / bulk['logger_cpu_us_per_frame']:.1f}x "
                  f"less CPU per frame; lost {bulk['lost_pct']:.2f} % vs {base['lost_pct']:.2f} %, "
                  f"unread at the end {bulk['backlog']} vs {base['backlog']} frames")
    return 0


if __name__ == "__main__":
    sys.exit(main())
