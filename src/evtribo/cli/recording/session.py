"""``evtribo session PROTOCOL --study DIR --subject NAME``: a subject's whole protocol.

Records every trial of the protocol file, one after another (spec §7): the tare stretch at
each trial's start, the excitation set through the rig's command message or by asking the
operator, a check of each trial by the analysis with the choice to redo it, pauses between
trials. Trials are named run-01, run-02, ... in the order recorded; SUBJECT/session.json
keeps the plan and what is done. Ctrl-C stops and keeps every finished trial; the same
command again goes on with the first trial not done.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from evtribo.cli.recording._bounds import BOUNDS, check_bounds
from evtribo.cli.recording._bus import add_bus_arguments, bus_settings, start_view
from evtribo.errors import ConfigError

log = logging.getLogger(__name__)


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``session``."""
    p = subparsers.add_parser(
        "session", help="record a subject's whole protocol, trial after trial",
        description=__doc__.split("\n\n")[1].replace("\n", " ")
        + " Exit 0 when every trial is done or the session was stopped; 1 when the bus or "
          "the disk failed (what was recorded is kept); 2 for a bad protocol, study or name.")
    examples = Path(__file__).parents[2] / "data" / "protocols"  # package data
    p.add_argument("protocol", metavar="PROTOCOL",
                   help=f"the protocol file (TOML, spec §7; examples to copy and edit, "
                        f"installed with evtribo: {examples}{os.sep}meyer2013.toml, "
                        "frequency-sweep.toml, friction-law.toml)")
    p.add_argument("--study", required=True, metavar="DIR",
                   help="study folder (created with a study.toml for --rig if new)")
    p.add_argument("--new-study", action="store_true",
                   help="make --study a new study even when one of a similar name is beside "
                        "it (without it, my-stuyd beside my-study is refused as a typo)")
    p.add_argument("--subject", required=True, help="subject name (letters, digits, - and _)")
    p.add_argument("--rig", metavar="RIG.toml",
                   help="rig description for a new study (default: the simulator's rig)")
    p.add_argument("--yes", action="store_true",
                   help="ask nothing: keep every trial, go on after each pause (scripts)")
    p.add_argument("--no-check", action="store_true",
                   help="do not analyse each trial after recording it")
    p.add_argument("--quiet", action="store_true", help="no live display in the terminal")
    add_bus_arguments(p)
    p.set_defaults(func=run)
    return p


@contextmanager
def _stop_on_signals() -> Iterator[Callable[[], bool] | None]:
    """While a trial records, Ctrl-C and SIGTERM end it as ``interrupted`` (its log saved)."""
    from evtribo.acquisition.trialdata import StopFlag, StopOnSignals

    flag = StopFlag()
    with StopOnSignals(flag):
        yield flag


#: Most trials a protocol may plan for a subject.
MAX_TRIALS = 10_000
#: The protocol's numbers and the option whose bounds they keep to.
_PROTOCOL_BOUNDS = {"trial_s": "--duration", "tare_s": "--tare-s", "on_s": "--on-time",
                    "off_s": "--off-time", "pause_s": "--dwell", "step_s": "--on-time",
                    "target_force_N": "--target-force", "band_N": "--band",
                    "target_steps_N": "--target-force"}


def _check_numbers(protocol: Any, path: str) -> None:
    """The protocol's numbers within the bounds acquire keeps to (a trial it records is one
    analyze reads): naming the protocol and the key."""
    def check(value: Any, key: str, flag: str) -> None:
        try:
            check_bounds(argparse.Namespace(value=value), ["--value"], bound=BOUNDS[flag])
        except ConfigError as err:
            raise ConfigError(err.message, path=path, key=key) from None

    for name, flag in _PROTOCOL_BOUNDS.items():
        check(getattr(protocol.session, name), f"session.{name}", flag)
    for i, spec in enumerate(protocol.trials):
        check(spec.amplitude_V, f"trial[{i}].amplitude_V", "--amplitude")
        check(spec.frequency_Hz, f"trial[{i}].frequency_Hz", "--frequency")
    planned = protocol.session.repetitions * sum(
        len(t.amplitude_V) * len(t.frequency_Hz) for t in protocol.trials)
    if planned > MAX_TRIALS:
        raise ConfigError(f"{protocol.session.repetitions!r} is not allowed: the protocol would "
                          f"plan {planned:,} trials, at most {MAX_TRIALS:,} (no subject sits "
                          "through more)", path=path, key="session.repetitions")


def run(args: argparse.Namespace) -> int:
    """Run the session; return the exit code."""
    from evtribo.acquisition.buses.bus import open_bus
    from evtribo.acquisition.protocol import read_protocol
    from evtribo.acquisition.rigfile import refuse_misspelt_study
    from evtribo.session import SessionConfig, run_session

    _check_numbers(read_protocol(args.protocol), args.protocol)  # before the bus opens
    refuse_misspelt_study(args.study, new=args.new_study)
    settings = bus_settings(args)
    view = start_view(args)
    try:
        bus = open_bus(settings)
    except BaseException:
        if view is not None:
            view.stop()
        raise
    try:
        outcome = run_session(bus, SessionConfig(
            protocol=args.protocol, study=args.study, subject=args.subject, yes=args.yes,
            rig=args.rig, settings=settings, view=view, display=not args.quiet,
            check=not args.no_check, stop_guard=_stop_on_signals))
    finally:
        if view is not None:
            view.stop()
        try:
            bus.shutdown()
        except Exception as err:  # a vanished adapter may fail to close
            log.warning("closing the bus failed: %s", err)
    if outcome.stopped in ("bus-error", "disk-error", "no-rig-data"):
        print(f"evtribo session: error: the last trial ended in a fault ({outcome.stopped}); "
              "what was recorded is kept, run the same command again to go on",
              file=sys.stderr)
        return 1
    return 0
