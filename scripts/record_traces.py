"""Record the reference study in ``data/``: the simulated rig, recorded by ``evtribo acquire``.

Three simulated subjects (different friction coefficient, air gap and target normal force)
each do five trials of a 10 kHz square voltage at 60, 80, 100, 120 and 140 V, alternating
OFF/ON every 2 s, and one trial of a 10 Hz sine at 140 V, alternating too. Each trial is
played in real time by the simulator (:meth:`Simulator.run`, what ``evtribo simulate``
runs) on python-can's ``virtual`` bus, channel ``vcan0``, and recorded from a second bus
object on that channel by :func:`record_trial` (what ``evtribo acquire`` runs): the logs
hold the timestamps of a software logger, as on a real ``vcan0``. Each log is then
gzip-compressed to ``run-XX.log.gz`` (its sidecar ``run-XX.json`` says so), and the
simulator's truth of every trial goes to ``truth.json`` at the study's top level.

Usage::

    .venv/bin/python scripts/record_traces.py                 # data/reference-study
    .venv/bin/python scripts/record_traces.py --out /tmp/s --duration 4 --subjects 1

Takes about (duration + 0.6 s) x 18 trials of real time (some 4 minutes by default).
"""

from __future__ import annotations

import argparse
import dataclasses
import gzip
import json
import logging
import shutil
import sys
import threading
import time
from pathlib import Path
from typing import Any

import can

import evtribo
from evtribo.acquisition.buses.bus import BusSettings
from evtribo.acquisition.rigfile import create_study, default_rig_path, load_rig_toml
from evtribo.acquisition.simulator import RunStats, Simulator, SubjectParams, TrialConfig
from evtribo.acquisition.trial import TrialInfo, record_trial
from evtribo.study import write_sidecar

log = logging.getLogger("record_traces")

#: The reference study's subjects: different skin (mu), air gap and pressing force.
SUBJECTS = (
    SubjectParams(name="P01", mu=0.42, h_L=4e-6, normal_force_N=0.5, force_drift=0.04,
                  sliding_speed_m_s=0.02),
    SubjectParams(name="P02", mu=0.55, h_L=6e-6, normal_force_N=0.8, force_drift=0.05,
                  sliding_speed_m_s=0.025, reversal_s=0.12),
    SubjectParams(name="P03", mu=0.33, h_L=8e-6, normal_force_N=1.1, force_drift=0.06,
                  sliding_speed_m_s=0.018, reversal_s=0.18),
)
AMPLITUDES_V = (60.0, 80.0, 100.0, 120.0, 140.0)
CHANNEL = "vcan0"
#: Recording continues this long after the simulated trial ends, s.
TAIL_S = 0.5


def trial_plan(duration_s: float, seed: int) -> list[tuple[str, TrialConfig]]:
    """The trials of one subject: ``(name, config)``, square sweep then the sine."""
    base = TrialConfig(duration_s=duration_s, waveform="square", frequency_Hz=10_000.0,
                       condition="alternating", on_s=2.0, off_s=2.0, start_on=False,
                       fz_rate_Hz=1000.0, fx_rate_Hz=1000.0, hv_rate_Hz=50.0,
                       drop_probability=0.002, foreign_rate_Hz=5.0, channel=CHANNEL,
                       seed=seed)
    plan = [dataclasses.replace(base, amplitude_V=a) for a in AMPLITUDES_V]
    plan.append(dataclasses.replace(base, waveform="sine", frequency_Hz=10.0,
                                    amplitude_V=max(AMPLITUDES_V)))
    return [(f"run-{i + 1:02d}", dataclasses.replace(c, seed=seed * 1000 + i))
            for i, c in enumerate(plan)]


def record_one(study: Path, subject: SubjectParams, trial: str, config: TrialConfig,
               *, force: bool) -> tuple[dict[str, Any], RunStats, dict[str, Any]]:
    """Play one trial on the virtual bus and record it; returns (sidecar, stats, truth)."""
    sim = Simulator(subject, config)
    stats: dict[str, RunStats] = {}
    # the recorder's bus first, so that it sees the simulator's first frame
    rx = can.Bus(interface="virtual", channel=CHANNEL)
    tx = can.Bus(interface="virtual", channel=CHANNEL)
    runner = threading.Thread(
        target=lambda: stats.setdefault("run", sim.run(tx, duration=config.duration_s)),
        name=f"simulate {subject.name}/{trial}", daemon=True)
    info = TrialInfo(waveform=config.waveform, frequency_Hz=config.frequency_Hz,
                     amplitude_V=config.amplitude_V, condition=config.condition,
                     notes=f"simulated subject {subject.name} (evtribo simulate, seed "
                           f"{config.seed}) recorded with evtribo acquire over python-can's "
                           f"virtual bus; the simulator's truth is in truth.json")
    try:
        result = record_trial(rx, study, subject.name, trial,
                              duration=config.duration_s + TAIL_S, info=info, force=force,
                              settings=BusSettings(interface="virtual", channel=CHANNEL),
                              log_channel=CHANNEL, started=lambda _paths: runner.start())
        runner.join()
    finally:
        rx.shutdown()
        tx.shutdown()
    if result.exit_code != 0:
        raise RuntimeError(f"{subject.name}/{trial}: recording ended {result.ended}: "
                           f"{result.error}")
    assert sim.generator is not None
    return result.sidecar, stats["run"], sim.generator.truth().to_dict()


def compress(log_path: Path, sidecar: dict[str, Any]) -> Path:
    """gzip *log_path* to ``<name>.gz`` (reproducible: no name, mtime 0); fix the sidecar."""
    gz = log_path.with_name(log_path.name + ".gz")
    with log_path.open("rb") as src, gz.open("wb") as raw, \
            gzip.GzipFile(filename="", mode="wb", fileobj=raw, compresslevel=9, mtime=0) as dst:
        shutil.copyfileobj(src, dst)
    log_path.unlink()
    sidecar = {**sidecar, "log": gz.name,
               "log_compressed": f"{log_path.name} gzip-compressed after recording"}
    write_sidecar(log_path.with_suffix(".json"), sidecar, force=True)
    return gz


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("data/reference-study"),
                   help="study folder to write (default: data/reference-study)")
    p.add_argument("--duration", type=float, default=12.0, help="s per trial (12)")
    p.add_argument("--subjects", type=int, default=len(SUBJECTS), help="how many (3)")
    p.add_argument("--force", action="store_true", help="replace existing trials")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    for name in ("evtribo", "can"):
        logging.getLogger(name).setLevel(logging.WARNING)

    study: Path = args.out
    if (study / "truth.json").exists() and not args.force:
        print(f"{study} exists; give --force to record it again", file=sys.stderr)
        return 2
    truth: dict[str, Any] = {
        "study": study.name,
        "generated_by": "scripts/record_traces.py",
        "evtribo_version": evtribo.__version__,
        "python_can_version": can.__version__,
        "recorded_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "how": "Simulator.run on python-can's virtual bus (channel vcan0), recorded by "
               "record_trial from a second bus object on the same channel; logs gzipped",
        "time_origin": "schedule and slides are in s from the simulator's start "
                       "(config.start_time); the log's first frame is within a few ms of it",
        "subjects": {s.name: s.to_dict() for s in SUBJECTS[:args.subjects]},
        "trials": {},
    }
    if not (study / "study.toml").exists():
        create_study(study, load_rig_toml(default_rig_path()),
                     name="reference voltage sweep (simulated rig, recorded)")
    t_begin = time.monotonic()
    for si, subject in enumerate(SUBJECTS[:args.subjects]):
        for trial, config in trial_plan(args.duration, seed=si + 1):
            sidecar, stats, sim_truth = record_one(study, subject, trial, config,
                                                   force=args.force)
            log_path = study / subject.name / sidecar["log"]
            gz = compress(log_path, sidecar)
            rig_frames = sum(int(n["frames"]) for n in sim_truth["nodes"].values())
            lost_in_transit = stats.sent - int(sidecar["frames"])
            truth["trials"][f"{subject.name}/{trial}"] = {
                "subject": subject.name, "trial": trial, "log": gz.name,
                "mu": subject.mu, "h_L_m": subject.h_L,
                "waveform": config.waveform, "frequency_Hz": config.frequency_Hz,
                "amplitude_V": config.amplitude_V, "condition": config.condition,
                "normal_force_on_N": sim_truth["normal_force_on_N"],
                "normal_force_off_N": sim_truth["normal_force_off_N"],
                "electrostatic_force_N": sim_truth["electrostatic_force_N"],
                "electrostatic_force_mean_N": sim_truth["electrostatic_force_mean_N"],
                "friction_modulation_Hz": sim_truth["friction_modulation_Hz"],
                "dropped_by_simulator": {k: int(v["dropped"])
                                         for k, v in sim_truth["nodes"].items()},
                "frames_sent": stats.sent, "frames_not_sent": stats.not_sent,
                "frames_recorded": int(sidecar["frames"]),
                "rig_frames_generated": rig_frames,
                "foreign_frames": sim_truth["foreign_frames"],
                "simulation": sim_truth,
            }
            log.info("%s/%s: %d frames sent, %d recorded (%d missing), %.1f kB gzipped",
                     subject.name, trial, stats.sent, sidecar["frames"], lost_in_transit,
                     gz.stat().st_size / 1e3)
    (study / "truth.json").write_text(json.dumps(truth, indent=1) + "\n", encoding="utf-8")
    size = sum(f.stat().st_size for f in study.rglob("*") if f.is_file())
    log.info("%s: %d trials in %.0f s of real time, %.2f MB", study, len(truth["trials"]),
             time.monotonic() - t_begin, size / 1e6)
    return 0


if __name__ == "__main__":
    sys.exit(main())
