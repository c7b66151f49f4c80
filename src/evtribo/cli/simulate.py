"""``evtribo simulate``: the simulated rig, on a python-can bus, an slcan pty, or to a study.

Examples::

    evtribo simulate --interface virtual --channel vcan0 --duration 30
    evtribo simulate --interface socketcan --channel vcan0 --amplitude 100 --condition on
    evtribo simulate --pty            # prints the pty's path, then acts as an slcan adapter
    evtribo simulate --study my-study --subject P01 --trial run-01   # offline, no waiting
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

from evtribo.errors import ConfigError

# Option of each SubjectParams / TrialConfig field, to name it in error messages.
_SUBJECT_OPTIONS = {
    "mu": "--mu", "h_L": "--air-gap", "normal_force_N": "--target-force",
    "force_drift": "--force-drift", "drift_time_s": "--drift-time",
    "sliding_speed_m_s": "--speed", "stroke_length_m": "--stroke-length",
    "reversal_s": "--reversal-time",
}
_TRIAL_OPTIONS = {
    "duration_s": "--duration", "waveform": "--waveform", "frequency_Hz": "--frequency",
    "amplitude_V": "--amplitude", "condition": "--condition", "on_s": "--on-time",
    "off_s": "--off-time", "fz_rate_Hz": "--fz-rate", "fx_rate_Hz": "--fx-rate",
    "hv_rate_Hz": "--hv-rate", "fz_ppm": "--fz-ppm", "fx_ppm": "--fx-ppm",
    "hv_ppm": "--hv-ppm", "noise_N": "--noise", "jitter_s": "--jitter",
    "drop_probability": "--drop-probability", "foreign_rate_Hz": "--foreign-rate",
}


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo simulate``."""
    p = subparsers.add_parser(
        "simulate", help="run the simulated rig (bus, slcan pty, or study folder)",
        description="Send the default rig's frames (two load cells and the amplifier's "
                    "status) from the seed paper's model, in real time on a python-can bus "
                    "or an emulated slcan adapter, or write a simulated trial to a study.",
    )
    out = p.add_argument_group("where the frames go (one of)")
    out.add_argument("--interface", "-i", help="python-can interface (virtual, socketcan, "
                     "slcan, pcan...; default: python-can's configuration)")
    out.add_argument("--channel", "-c", help="python-can channel (vcan0, can0, ...)")
    out.add_argument("--bitrate", "-b", type=int, help="bus bitrate, bit/s")
    out.add_argument("--bus-option", action="append", default=[], metavar="KEY=VALUE",
                     help="extra argument of the python-can bus (repeatable), "
                          "e.g. receive_own_messages=True")
    out.add_argument("--pty", action="store_true",
                     help="act as an slcan USB-CAN adapter on a new pseudo-terminal; its path "
                          "is the first line of stdout; frames flow once a client sends 'O'")
    out.add_argument("--study", metavar="DIR",
                     help="write one trial offline into this study folder (no waiting)")
    out.add_argument("--subject", default="P01", help="subject name with --study (P01)")
    out.add_argument("--trial", default="run-01", help="trial name with --study (run-01)")
    out.add_argument("--force", action="store_true", help="overwrite a trial with --study")

    trial = p.add_argument_group("the trial")
    trial.add_argument("--duration", type=float,
                       help="s (default: until Ctrl-C; 30 with --study)")
    trial.add_argument("--amplitude", type=float, default=140.0, help="V (140)")
    trial.add_argument("--waveform", choices=("sine", "square"), default="square")
    trial.add_argument("--frequency", type=float, default=10_000.0, help="Hz (10000)")
    trial.add_argument("--condition", choices=("on", "off", "alternating"),
                       default="alternating")
    trial.add_argument("--on-time", type=float, default=2.0, help="ON phase, s (2)")
    trial.add_argument("--off-time", type=float, default=2.0, help="OFF phase, s (2)")
    trial.add_argument("--start-on", action="store_true", help="alternate starting ON")
    trial.add_argument("--seed", type=int, default=0, help="random seed (0)")

    subj = p.add_argument_group("the subject")
    subj.add_argument("--mu", type=float, default=0.5, help="friction coefficient (0.5)")
    subj.add_argument("--air-gap", type=float, default=5e-6,
                      help="equivalent air gap h_L, m (5e-6)")
    subj.add_argument("--target-force", type=float, default=0.5, help="normal force, N (0.5)")
    subj.add_argument("--force-drift", type=float, default=0.05,
                      help="relative wander of the normal force (0.05)")
    subj.add_argument("--drift-time", type=float, default=1.5, help="its time constant, s")
    subj.add_argument("--speed", type=float, default=0.02, help="sliding speed, m/s (0.02)")
    subj.add_argument("--stroke-length", type=float, default=0.04, help="m (0.04)")
    subj.add_argument("--reversal-time", type=float, default=0.15, help="s (0.15)")

    rig = p.add_argument_group("the rig")
    rig.add_argument("--fz-rate", type=float, default=1000.0, help="normal cell, Hz (1000)")
    rig.add_argument("--fx-rate", type=float, default=2000.0,
                     help="tangential cell, Hz (2000)")
    rig.add_argument("--hv-rate", type=float, default=50.0, help="HvStatus frames, Hz (50)")
    rig.add_argument("--fz-ppm", type=float, default=40.0, help="normal cell's clock error")
    rig.add_argument("--fx-ppm", type=float, default=-25.0, help="tangential cell's clock")
    rig.add_argument("--hv-ppm", type=float, default=150.0, help="amplifier's clock error")
    rig.add_argument("--noise", type=float, default=1e-3, help="load cell noise, N (0.001)")
    rig.add_argument("--jitter", type=float, default=5e-5, help="reception jitter, s")
    rig.add_argument("--drop-probability", type=float, default=0.0,
                     help="probability that a frame is lost (0)")
    rig.add_argument("--foreign-rate", type=float, default=0.0,
                     help="frames/s from other nodes (0)")
    p.set_defaults(func=run)
    return p


def _build(args: argparse.Namespace, duration: float) -> tuple[Any, Any]:
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig

    subject_kw = {"name": args.subject, "mu": args.mu, "h_L": args.air_gap,
                  "normal_force_N": args.target_force, "force_drift": args.force_drift,
                  "drift_time_s": args.drift_time, "sliding_speed_m_s": args.speed,
                  "stroke_length_m": args.stroke_length, "reversal_s": args.reversal_time}
    trial_kw = {"duration_s": duration, "waveform": args.waveform,
                "frequency_Hz": args.frequency, "amplitude_V": args.amplitude,
                "condition": args.condition, "on_s": args.on_time, "off_s": args.off_time,
                "start_on": args.start_on, "fz_rate_Hz": args.fz_rate,
                "fx_rate_Hz": args.fx_rate, "hv_rate_Hz": args.hv_rate,
                "fz_ppm": args.fz_ppm, "fx_ppm": args.fx_ppm, "hv_ppm": args.hv_ppm,
                "noise_N": args.noise, "jitter_s": args.jitter,
                "drop_probability": args.drop_probability,
                "foreign_rate_Hz": args.foreign_rate, "seed": args.seed}
    if args.channel:
        trial_kw["channel"] = args.channel
    options = {**_SUBJECT_OPTIONS, **_TRIAL_OPTIONS}
    try:
        return SubjectParams(**subject_kw), TrialConfig(**trial_kw)
    except ConfigError as err:
        field = (err.key or "").rpartition(".")[2]
        raise ConfigError(err.message, key=options.get(field, err.key)) from err


@contextlib.contextmanager
def _stop_on_signals() -> Iterator[threading.Event]:
    """An event set by SIGTERM or Ctrl-C while the block runs (handlers restored after)."""
    stop = threading.Event()

    def handler(_signum: int, _frame: object) -> None:
        stop.set()

    previous = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        yield stop
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo simulate``."""
    if sum((args.pty, args.study is not None, args.interface is not None)) > 1:
        raise ConfigError("choose one of --interface, --pty and --study", key="--pty")
    if args.bus_option and (args.pty or args.study is not None):
        raise ConfigError("only for a python-can bus (--interface)", key="--bus-option")
    if args.duration is not None and args.duration <= 0:
        raise ConfigError(f"{args.duration!r} is not allowed: must be > 0", key="--duration")
    if args.study is not None:
        from evtribo.acquisition.simulator import write_trial

        subject, config = _build(args, args.duration or 30.0)
        truth = write_trial(args.study, args.trial, subject, config, force=args.force)
        nodes = truth.nodes
        print(f"{args.study}/{subject.name}/{args.trial}.log: "
              f"{sum(int(n['frames']) for n in nodes.values()) + truth.foreign_frames} frames")
        return 0

    from evtribo.acquisition.simulator import Simulator

    subject, config = _build(args, args.duration or 1.0)
    sim = Simulator(subject, config)
    if args.pty:
        from evtribo.acquisition.slcan import SlcanPtyAdapter

        with _stop_on_signals() as stop, SlcanPtyAdapter() as adapter:
            print(adapter.path, flush=True)
            stats = sim.run_pty(adapter, duration=args.duration, stop_event=stop)
            dropped = adapter.dropped
    else:
        from evtribo.acquisition.bus import BusSettings, open_bus, parse_bus_options

        bus = open_bus(BusSettings(interface=args.interface, channel=args.channel,
                                   bitrate=args.bitrate,
                                   options=parse_bus_options(args.bus_option)))
        try:
            with _stop_on_signals() as stop:
                stats = sim.run(bus, duration=args.duration, stop_event=stop)
        finally:
            bus.shutdown()
        dropped = 0
    print(f"evtribo simulate: {stats.sent} frames sent in {stats.elapsed_s:.1f} s, "
          f"{stats.not_sent} not sent ({dropped} to a full buffer)", file=sys.stderr)
    return 0
