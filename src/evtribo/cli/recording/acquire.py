"""``evtribo acquire``: record one trial from any python-can bus into a study folder."""

from __future__ import annotations

import argparse
import logging
import math
import sys
from pathlib import Path
from typing import Any

from evtribo.acquisition.buses.bus import open_bus
from evtribo.acquisition.live.monitor import Monitor
from evtribo.acquisition.rigfile import (
    AcquisitionRig,
    check_name,
    default_rig_path,
    open_study,
    refuse_misspelt_study,
)
from evtribo.acquisition.trial import (
    CONDITIONS,
    RIG_DATA_TIMEOUT_S,
    WAVEFORMS,
    StopFlag,
    TrialInfo,
    TrialPaths,
    record_trial,
    trial_lock,
)
from evtribo.acquisition.trialdata import StopOnSignals
from evtribo.cli.recording._bounds import check_bounds, say_bounds
from evtribo.cli.recording._bus import add_bus_arguments, bus_settings, start_view
from evtribo.errors import ConfigError, OutputExistsError

log = logging.getLogger(__name__)

#: Finger-lifted stretch at the start of a trial, s.
DEFAULT_TARE_S = 1.5


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo acquire``."""
    p = subparsers.add_parser(
        "acquire", help="record one trial from a CAN bus into a study folder",
        description="Record every frame of a python-can bus into STUDY/SUBJECT/TRIAL.log "
                    "(candump -L) and its sidecar STUDY/SUBJECT/TRIAL.json, with a live "
                    "display of the normal force. Stops after --duration, or on Ctrl-C / "
                    "SIGTERM (exit 0); exit 1 if the bus or the disk fails mid-trial, or if "
                    f"none of the rig's load-cell messages arrives within "
                    f"{RIG_DATA_TIMEOUT_S:g} s (what was received is kept); 2 for bad usage, "
                    "an existing trial without --force, or a trial another process is "
                    "recording.")
    p.add_argument("--study", required=True, metavar="DIR",
                   help="study folder (created with a study.toml for --rig if new)")
    p.add_argument("--new-study", action="store_true",
                   help="make --study a new study even when one of a similar name is beside "
                        "it (without it, my-stuyd beside my-study is refused as a typo)")
    p.add_argument("--subject", required=True, help="subject name (letters, digits, - and _)")
    p.add_argument("--trial", required=True, help="trial name, e.g. run-01")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="recording time in s (default: until Ctrl-C / SIGTERM)")
    p.add_argument("--tare-s", type=float, default=None, metavar="S",
                   help="the first S seconds are recorded with the finger lifted off the "
                        "screen (the display says when to slide); the analysis takes the "
                        f"load cells' zero offsets from them (default {DEFAULT_TARE_S:g}, at "
                        "most half of --duration; 0: no tare)")
    add_bus_arguments(p)
    meta = p.add_argument_group("trial metadata (sidecar)")
    meta.add_argument("--waveform", choices=WAVEFORMS)
    meta.add_argument("--frequency", type=float, metavar="HZ", help="excitation frequency, Hz")
    meta.add_argument("--amplitude", type=float, metavar="V", help="excitation amplitude, V")
    meta.add_argument("--condition", choices=CONDITIONS)
    meta.add_argument("--notes", help="free text")
    p.add_argument("--rig", metavar="RIG.toml",
                   help="rig description for a new study (default: the simulator's rig)")
    p.add_argument("--force", action="store_true",
                   help="replace an existing trial, once the new one holds frames of the "
                        "rig's load cells (until then, and if it ends without any, the old "
                        "one stays as it was)")
    disp = p.add_argument_group("display")
    disp.add_argument("--target-force", type=float, metavar="N",
                      help="target normal force shown as a band, N")
    disp.add_argument("--band", type=float, default=0.1, metavar="N",
                      help="half-width of the target band, N (default 0.1)")
    disp.add_argument("--quiet", action="store_true", help="no display, no summary")
    say_bounds(p, _BOUNDED)
    p.set_defaults(func=run)
    return p


#: The options of acquire whose numbers are bounded (:mod:`evtribo.cli.recording._bounds`).
_BOUNDED = ("--duration", "--frequency", "--amplitude", "--target-force", "--band", "--tare-s")


def _check_finite(args: argparse.Namespace) -> None:
    """Non-finite numbers (``inf``, ``nan``) would run forever or break the sidecar."""
    for flag in ("--duration", "--frequency", "--amplitude", "--target-force", "--band",
                 "--tare-s"):
        value = getattr(args, flag[2:].replace("-", "_"))
        if value is not None and not math.isfinite(value):
            raise ConfigError(f"expected a finite number, got {value}", key=flag)


def summary_counts(side: dict[str, Any]) -> str:
    """The recording's counts in words, from its sidecar: frames, drops (by the receive
    queue), bus errors by kind and the controller's worst state, frames discarded as
    queued before the trial, and what the load cells' counters do where it is worth saying
    (a period learnt from the frames, a counter that does not count).

    Parameters
    ----------
    side : dict
        The sidecar as the recording wrote it.

    Returns
    -------
    str
    """
    text = (f"{side['frames']} frames in {side['duration_s']:.1f} s, "
            f"{side['dropped_frames']} dropped")
    if side.get("queue_dropped_frames"):
        text += f" ({side['queue_dropped_frames']} by the receive queue: a bigger one, " \
                "--bus-option receive_buffer=BYTES, or a less busy machine)"
    text += f", {side['bus_errors']} bus errors"
    details = [f"{kind} {n}" for kind, n in (side.get("error_frames_by_kind") or {}).items()]
    if side["damaged_lines"]:
        details.append(f"{side['damaged_lines']} damaged lines")
    if details:
        text += f" ({', '.join(details)})"
    worst = side.get("worst_controller_state")
    if worst in ("error-passive", "bus-off"):
        text += f"; the CAN controller went {worst}: frames may be missing while it was"
    if side.get("discarded_before_start"):
        text += (f"; {side['discarded_before_start']} frames queued before the trial were "
                 "discarded")
    for note in (side.get("counter_notes") or {}).values():
        text += f"; {note}"
    return text


def run(args: argparse.Namespace) -> int:
    """Record the trial; return 0 (completed or stopped), 1 (bus or disk failed, or no
    frame of the rig's load cells)."""
    check_name(args.subject, "subject")
    check_name(args.trial, "trial")
    _check_finite(args)
    if args.duration is not None and args.duration <= 0:
        raise ConfigError(f"expected a positive duration, got {args.duration}", key="--duration")
    if args.band < 0:
        raise ConfigError(f"expected a band >= 0 N, got {args.band}", key="--band")
    if args.tare_s is None:
        args.tare_s = DEFAULT_TARE_S if args.duration is None else min(DEFAULT_TARE_S,
                                                                         args.duration / 2)
    elif args.tare_s < 0 or (args.duration is not None and args.tare_s >= args.duration):
        raise ConfigError(f"expected a tare stretch >= 0 s and shorter than the trial, got "
                          f"{args.tare_s}", key="--tare-s")
    check_bounds(args, _BOUNDED)
    info = TrialInfo(waveform=args.waveform, frequency_Hz=args.frequency,
                     amplitude_V=args.amplitude, condition=args.condition, notes=args.notes,
                     tare_s=args.tare_s)
    info.check()
    # everything the user can get wrong is checked before the bus opens and before the
    # study folder is created
    refuse_misspelt_study(args.study, new=args.new_study)
    rig: AcquisitionRig = open_study(args.study, args.rig, create=False)
    paths = TrialPaths.of(args.study, args.subject, args.trial)
    trial_lock(paths, args.subject, args.trial).check()  # --force included
    existing = paths.existing()
    if existing and not args.force:
        raise OutputExistsError("trial already recorded (use --force to replace it): "
                                + ", ".join(str(p) for p in existing), path=existing[0])
    if args.rig is None and not (Path(args.study) / "study.toml").exists():
        print(f"evtribo acquire: {args.study} has no study.toml: it is made for the default "
              f"rig, {default_rig_path()}: {rig.describe()} (give --rig RIG.toml for "
              "another rig)", file=sys.stderr)
    settings = bus_settings(args)
    view = start_view(args)
    try:
        bus = open_bus(settings)
    except BaseException:
        if view is not None:
            view.stop()
        raise
    flag = StopFlag()
    monitor = None
    if not args.quiet or view is not None:
        monitor = Monitor(rig, sys.stdout, duration=args.duration, target=args.target_force,
                          band=args.band, title=f"{args.subject}/{args.trial}",
                          tare_s=args.tare_s, rig_data_timeout=RIG_DATA_TIMEOUT_S,
                          view=view, quiet=args.quiet)
    try:
        with StopOnSignals(flag):
            result = record_trial(
                bus, args.study, args.subject, args.trial, duration=args.duration, info=info,
                rig=args.rig, force=args.force, settings=settings,
                log_channel=args.log_channel, should_stop=flag, monitor=monitor)
    finally:
        if view is not None:
            view.stop()
        try:
            bus.shutdown()
        except Exception as err:  # a vanished adapter may fail to close
            log.warning("closing the bus failed: %s", err)
    side = result.sidecar
    if result.kept_previous:
        kept = ", ".join(str(p) for p in result.paths.existing())
        print(f"evtribo acquire: {'error: ' if result.exit_code else ''}no frame of the rig's "
              f"load cells arrived ({side['end_detail']}; {side['frames']} other frames): "
              f"nothing of this recording was kept; the trial recorded before is, as it was: "
              f"{kept}", file=sys.stderr)
        return result.exit_code
    summary = f"{args.subject}/{args.trial}: {result.ended}, " + summary_counts(side) \
        + f" -> {result.paths.log}"
    if result.exit_code:
        print(f"evtribo acquire: error: {side.get('end_detail', result.ended)}; "
              f"what was received is kept.\n{summary}", file=sys.stderr)
    elif not args.quiet:
        print(summary)
    return result.exit_code
