"""``evtribo simulate``: the simulated rig, on a python-can bus, an slcan pty, or to a study.

Examples::

    evtribo simulate --interface virtual --channel vcan0 --duration 30
    evtribo simulate --interface socketcan --channel vcan0 --amplitude 100 --condition on
    evtribo simulate --pty            # prints the pty's path, then acts as an slcan adapter
    evtribo simulate --study my-study --subject P01 --trial run-01   # offline, no waiting
    evtribo simulate --study my-study --subject P01 --trial run-02 --ideal
    evtribo simulate --study my-study --subject P00 --trial press --press-only  # calibrate
    evtribo simulate --study pop-study --subjects 8 --air-gap-spread 0.3   # a population

By default the rig is a real one (:mod:`evtribo.acquisition.simulator.realism`): its load
cells have zero offsets (drawn with ``--seed`` up to +/-50 mN), drift and 50 Hz hum, the
finger is lifted for ``--tare-s`` at the start, and the subject's strokes are a person's
(irregular, resting at the reversals, lifting now and then). ``--ideal`` gives exact load
cells and a machine's strokes; each of the options below sets one imperfection.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

from evtribo.cli.recording._bounds import BOUNDS, MAX_OFFLINE_FRAMES, check_bounds, say_bounds
from evtribo.cli.recording._simulate_population import add_population_options, simulate_population
from evtribo.errors import ConfigError

# Option of each SubjectParams / TrialConfig field, to name it in error messages.
_SUBJECT_OPTIONS = {
    "mu": "--mu", "h_L": "--air-gap", "normal_force_N": "--target-force",
    "force_drift": "--force-drift", "drift_time_s": "--drift-time",
    "sliding_speed_m_s": "--speed", "stroke_length_m": "--stroke-length",
    "reversal_s": "--reversal-time", "stroke_jitter": "--stroke-jitter", "dwell_s": "--dwell",
    "lifts_per_min": "--lifts-per-min", "lift_s": "--lift-time",
}
_TRIAL_OPTIONS = {
    "duration_s": "--duration", "waveform": "--waveform", "frequency_Hz": "--frequency",
    "amplitude_V": "--amplitude", "condition": "--condition", "on_s": "--on-time",
    "off_s": "--off-time", "fz_rate_Hz": "--fz-rate", "fx_rate_Hz": "--fx-rate",
    "hv_rate_Hz": "--hv-rate", "fz_ppm": "--fz-ppm", "fx_ppm": "--fx-ppm",
    "hv_ppm": "--hv-ppm", "noise_N": "--noise", "jitter_s": "--jitter",
    "drop_probability": "--drop-probability", "foreign_rate_Hz": "--foreign-rate",
    "tare_s": "--tare-s", "fz_offset_N": "--offsets", "fx_offset_N": "--offsets",
    "fz_drift_N_per_s": "--drift", "fx_drift_N_per_s": "--drift", "fz_hum_N": "--hum",
    "fx_hum_N": "--hum", "mains_Hz": "--mains", "crosstalk": "--crosstalk",
}


def _add_output_options(p: argparse.ArgumentParser) -> None:
    """Where the frames go: a python-can bus, an slcan pty or a study folder."""
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
    out.add_argument("--subject", help="subject name with --study (P01)")
    out.add_argument("--trial", help="trial name with --study (run-01)")
    out.add_argument("--force", action="store_true", help="overwrite a trial with --study")
    out.add_argument("--new-study", action="store_true",
                     help="with --study: a new study even when one of a similar name is "
                          "beside it (without it, my-stuyd beside my-study is refused)")
    out.add_argument("--rig", metavar="PATH",
                     help="speak this rig: a rig TOML, or a study folder or study.toml (its "
                          "[rig]); its DBC and roles encode the frames, whatever their IDs, "
                          "byte order and scales, and the amplifier obeys its "
                          "excitation_command_* message. With --study: the rig of a new "
                          "study (an existing study speaks its own rig)")


def _add_trial_options(p: argparse.ArgumentParser) -> None:
    """The trial: its length, the drive and the schedule of ON and OFF."""
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
    trial.add_argument("--press-only", action="store_true",
                       help="a calibration recording for `evtribo calibrate --press`: after "
                            "the tare stretch the finger presses without sliding, from 40 %% "
                            "to 160 %% of --target-force and back every 4 s; the amplifier "
                            "off (--condition off)")
    trial.add_argument("--seed", type=int, default=0, help="random seed (0)")


def _add_subject_options(p: argparse.ArgumentParser) -> None:
    """The subject: friction, air gap, force and strokes."""
    subj = p.add_argument_group(
        "the subject (defaults: a person's strokes, drawn with --seed; with --ideal, a "
        "machine's)")
    subj.add_argument("--mu", type=float, default=0.5, help="friction coefficient (0.5)")
    subj.add_argument("--air-gap", type=float, default=5e-6,
                      help="equivalent air gap h_L, m (5e-6)")
    subj.add_argument("--target-force", type=float, default=0.5, help="normal force, N (0.5)")
    subj.add_argument("--force-drift", type=float,
                      help="relative wander of the normal force (0.08-0.15; ideal 0.05)")
    subj.add_argument("--drift-time", type=float, default=1.5, help="its time constant, s")
    subj.add_argument("--speed", type=float, help="sliding speed, m/s (0.03-0.06; ideal 0.02)")
    subj.add_argument("--stroke-length", type=float, default=0.04, help="m (0.04)")
    subj.add_argument("--reversal-time", type=float, default=0.15, help="s (0.15)")
    subj.add_argument("--stroke-jitter", type=float,
                      help="stroke-to-stroke spread of durations (0.2-0.35; ideal 0.1)")
    subj.add_argument("--dwell", type=float, metavar="S",
                      help="mean rest at a reversal, s (0.1-0.25; ideal 0)")
    subj.add_argument("--lifts-per-min", type=float, metavar="RATE",
                      help="finger lift-offs per minute (2-4; ideal 0)")
    subj.add_argument("--lift-time", type=float, metavar="S",
                      help="mean time off the screen per lift-off, s (0.3-0.5)")
    subj.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                      dest="model_set",
                      help="a parameter of the subject's model, SI units (repeatable; "
                           "evtribo model --list), e.g. --set r_g=80 for a gap that leaks "
                           "(the force then depends on the drive's frequency)")


def _add_rig_options(p: argparse.ArgumentParser) -> None:
    """The rig: the nodes' rates and clocks, noise, jitter and lost frames."""
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


def _add_real_rig_options(p: argparse.ArgumentParser) -> None:
    """A real rig's load cells: offsets, drift, hum, cross-talk and the tare stretch."""
    real = p.add_argument_group(
        "a real rig's load cells (defaults drawn with --seed; all off with --ideal)")
    real.add_argument("--ideal", action="store_true",
                      help="exact load cells, no tare stretch, a machine's strokes")
    real.add_argument("--tare-s", type=float, metavar="S",
                      help="finger lifted at the start of the trial, s (1.5; ideal 0)")
    real.add_argument("--offsets", type=float, nargs=2, metavar=("FN", "FT"),
                      help="zero offsets of the normal and tangential cells, N "
                           "(drawn in +/-0.05)")
    real.add_argument("--drift", type=float, nargs=2, metavar=("FN", "FT"),
                      help="linear drift of each cell's zero over the trial, N "
                           "(drawn in +/-0.01, with a thermal part)")
    real.add_argument("--hum", type=float, metavar="N",
                      help="mains hum on each cell, N (0.01)")
    real.add_argument("--mains", type=float, choices=(50.0, 60.0), help="mains, Hz (50)")
    real.add_argument("--crosstalk", type=float, nargs=2, metavar=("N_FROM_T", "T_FROM_N"),
                      help="cross-talk: share of the tangential force the normal cell "
                           "reads, and of the normal force the tangential cell reads (0 0)")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo simulate``."""
    p = subparsers.add_parser(
        "simulate", help="run the simulated rig (bus, slcan pty, or study folder)",
        description="Send the default rig's frames (two load cells and the amplifier's "
                    "status) from the seed paper's model, in real time on a python-can bus "
                    "or an emulated slcan adapter, or write a simulated trial to a study.",
    )
    _add_output_options(p)
    _add_trial_options(p)
    _add_subject_options(p)
    _add_rig_options(p)
    _add_real_rig_options(p)
    add_population_options(p)
    say_bounds(p, [f for f in BOUNDS if f != "--band"])
    p.set_defaults(func=run)
    return p


def _check_numbers(args: argparse.Namespace) -> None:
    """Every number within its bounds (:mod:`evtribo.cli.recording._bounds`), and a trial
    written offline within :data:`MAX_OFFLINE_FRAMES`."""
    check_bounds(args, [f for f in BOUNDS if f != "--band"])
    if args.study is not None:
        seconds = args.duration or 30.0
        frames = seconds * (args.fz_rate + args.fx_rate + args.hv_rate + args.foreign_rate)
        if frames > MAX_OFFLINE_FRAMES:
            raise ConfigError(f"{seconds:g} s at {frames / seconds:g} frames/s is not "
                              f"allowed with --study: a trial written offline holds at most "
                              f"{MAX_OFFLINE_FRAMES:,} frames (it is made in memory); "
                              "record a longer one on a bus", key="--duration")


def _build(args: argparse.Namespace, duration: float, trial_s: float) -> tuple[Any, Any]:
    """The subject and the trial the options ask for; *trial_s* is the time over which the
    cells' drift accrues (the trial's length, or a nominal one for an open-ended stream)."""
    import dataclasses

    from evtribo.acquisition.simulator import SubjectParams, TrialConfig
    from evtribo.acquisition.simulator.realism import IDEAL_SUBJECT, human, realistic_rig

    subject_kw: dict[str, Any] = {"name": args.subject or "P01", "mu": args.mu,
                  "h_L": args.air_gap,
                  "normal_force_N": args.target_force, "drift_time_s": args.drift_time,
                  "stroke_length_m": args.stroke_length, "reversal_s": args.reversal_time}
    given_subject = {k: v for k, v in (
        ("force_drift", args.force_drift), ("sliding_speed_m_s", args.speed),
        ("stroke_jitter", args.stroke_jitter), ("dwell_s", args.dwell),
        ("lifts_per_min", args.lifts_per_min), ("lift_s", args.lift_time)) if v is not None}
    trial_kw = {"duration_s": duration, "waveform": args.waveform,
                "frequency_Hz": args.frequency, "amplitude_V": args.amplitude,
                "condition": "off" if args.press_only else args.condition,
                "press_only": args.press_only, "on_s": args.on_time, "off_s": args.off_time,
                "start_on": args.start_on, "fz_rate_Hz": args.fz_rate,
                "fx_rate_Hz": args.fx_rate, "hv_rate_Hz": args.hv_rate,
                "fz_ppm": args.fz_ppm, "fx_ppm": args.fx_ppm, "hv_ppm": args.hv_ppm,
                "noise_N": args.noise, "jitter_s": args.jitter,
                "drop_probability": args.drop_probability,
                "foreign_rate_Hz": args.foreign_rate, "seed": args.seed}
    if args.channel:
        trial_kw["channel"] = args.channel
    given_rig: dict[str, Any] = {}
    if args.tare_s is not None:
        given_rig["tare_s"] = args.tare_s
    if args.offsets is not None:
        given_rig.update(fz_offset_N=args.offsets[0], fx_offset_N=args.offsets[1])
    if args.drift is not None:
        given_rig.update(fz_drift_N_per_s=args.drift[0] / trial_s,
                         fx_drift_N_per_s=args.drift[1] / trial_s,
                         fz_thermal_N=0.0, fx_thermal_N=0.0)
    if args.hum is not None:
        given_rig.update(fz_hum_N=args.hum, fx_hum_N=args.hum)
    if args.mains is not None:
        given_rig["mains_Hz"] = args.mains
    if args.crosstalk is not None:
        given_rig["crosstalk"] = ((1.0, args.crosstalk[0]), (args.crosstalk[1], 1.0))
    options = {**_SUBJECT_OPTIONS, **_TRIAL_OPTIONS}
    try:
        if args.model_set:
            from evtribo.model import TABLE_1

            changed = TABLE_1.with_assignments(args.model_set)
            given_subject["model"] = {k: v for k, v in changed.as_dict().items()
                                      if v != getattr(TABLE_1, k) and k not in ("mu", "h_L")}
            for name in ("mu", "h_L"):  # the subject's own: --mu, --air-gap
                if getattr(changed, name) != getattr(TABLE_1, name):
                    subject_kw[name] = getattr(changed, name)
        ideal: dict[str, Any] = dict(IDEAL_SUBJECT)
        subject = SubjectParams(**subject_kw, **ideal)
        config = TrialConfig(**trial_kw)
        if not args.ideal:
            subject = human(subject, seed=args.seed)
            config = realistic_rig(config, trial_s=trial_s)
        return (dataclasses.replace(subject, **given_subject),
                dataclasses.replace(config, **given_rig))
    except ConfigError as err:
        field = (err.key or "").rpartition(".")[2]
        raise ConfigError(err.message, key=options.get(field, err.key)) from err


def _say_new_study(study: str) -> None:
    """Say which rig a new study is made for (the simulator's, the default rig)."""
    from pathlib import Path

    from evtribo.acquisition.rigfile import default_rig_path, load_rig_toml

    if not (Path(study) / "study.toml").exists():
        rig = load_rig_toml(default_rig_path())
        print(f"evtribo simulate: {study} has no study.toml: it is made for the default rig, "
              f"{default_rig_path()}: {rig.describe()}", file=sys.stderr)


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
    from evtribo.study import study_rig

    if sum((args.pty, args.study is not None, args.interface is not None)) > 1:
        raise ConfigError("choose one of --interface, --pty and --study", key="--pty")
    if args.bus_option and (args.pty or args.study is not None):
        raise ConfigError("only for a python-can bus (--interface)", key="--bus-option")
    _check_numbers(args)
    if args.press_only and args.condition != "alternating":
        raise ConfigError("a press-only recording is made with the amplifier off: leave "
                          "--condition out", key="--condition")
    if args.subjects is not None:
        if args.press_only:
            raise ConfigError("a population's study is of sliding trials: record a press "
                              "with --study --subject --trial", key="--press-only")
        return simulate_population(args)
    if args.study is not None:
        from evtribo.acquisition.rigfile import refuse_misspelt_study
        from evtribo.acquisition.simulator import write_trial

        refuse_misspelt_study(args.study, new=args.new_study)

        subject, config = _build(args, args.duration or 30.0, args.duration or 30.0)
        rig = study_rig(args.rig) if args.rig else None
        if rig is None:
            _say_new_study(args.study)
        trial = args.trial or "run-01"
        truth = write_trial(args.study, trial, subject, config, force=args.force, rig=rig)
        nodes = truth.nodes
        print(f"{args.study}/{subject.name}/{trial}.log: "
              f"{sum(int(n['frames']) for n in nodes.values()) + truth.foreign_frames} frames")
        return 0

    from evtribo.acquisition.simulator import Simulator

    # an open-ended stream: the cells drift as they would over a 30-s trial
    subject, config = _build(args, args.duration or 30.0, args.duration or 30.0)
    sim = Simulator(subject, config, rig=study_rig(args.rig) if args.rig else None)
    if args.pty:
        from evtribo.acquisition.buses.slcan import SlcanPtyAdapter

        with _stop_on_signals() as stop, SlcanPtyAdapter() as adapter:
            print(adapter.path, flush=True)
            stats = sim.run_pty(adapter, duration=args.duration, stop_event=stop)
            dropped = adapter.dropped
    else:
        from evtribo.acquisition.buses.bus import BusSettings, open_bus, parse_bus_options

        bus = open_bus(BusSettings(interface=args.interface, channel=args.channel,
                                   bitrate=args.bitrate,
                                   options=parse_bus_options(args.bus_option)))
        try:
            with _stop_on_signals() as stop:
                stats = sim.run(bus, duration=args.duration, stop_event=stop)
        finally:
            bus.shutdown()
        dropped = 0
    print(f"evtribo simulate: {stats.sent} frames sent in {stats.elapsed_s:.1f} s"
          + _not_sent(stats.not_sent, dropped, pty=args.pty), file=sys.stderr)
    return 0


def _not_sent(not_sent: int, dropped: int, *, pty: bool) -> str:
    """The frames the rig made but did not send, by why (each as a real rig would)."""
    if not not_sent:
        return ", none lost"
    if not pty:
        return (f", {not_sent} not sent: the bus refused them (no other node acknowledging, "
                "or its transmit queue full), as a real node's would be lost")
    parts = []
    if dropped:
        parts.append(f"{dropped} to a full buffer (the client did not read them in time)")
    if not_sent > dropped:
        parts.append(f"{not_sent - dropped} while no client had the channel open (before "
                     "its 'O', between recordings: a real adapter sends nothing then)")
    return f", {not_sent} not sent: " + "; ".join(parts)
