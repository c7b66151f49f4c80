"""The ``evtribo`` command line: one module per subcommand.

Each module ``evtribo.cli.<name>`` exposes ``add_parser(subparsers)`` (returning its parser,
with ``func`` set to its ``run(args)`` through ``set_defaults``) and ``run(args) -> int``.
A subcommand whose module (or one of its optional dependencies) fails to import is still
listed, and explains why when it is called; the rest of the tool keeps working.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Callable, Sequence

from evtribo import __version__
from evtribo.errors import EvtriboError

SUBCOMMANDS: tuple[str, ...] = (
    "model",
    "simulate",
    "acquire",
    "inspect",
    "decode",
    "analyze",
    "compare",
    "report",
    "demo",
)

log = logging.getLogger(__name__)


def _add_common(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("diagnostics")
    group.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                       help="more messages (-vv for debug messages)")
    group.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show tracebacks and debug messages")


def _unavailable(name: str, err: BaseException) -> Callable[[argparse.Namespace], int]:
    def run(_args: argparse.Namespace) -> int:
        print(f"evtribo {name}: unavailable here: {err}", file=sys.stderr)
        return 1

    return run


def build_parser() -> argparse.ArgumentParser:
    """The ``evtribo`` parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="evtribo",
        description="Tribometer experiments on electrovibration: acquire, analyse, compare.",
    )
    parser.add_argument("--version", action="version", version=f"evtribo {__version__}")
    _add_common(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(f"evtribo.cli.{name}")
        except ImportError as err:
            p = sub.add_parser(name, help=f"(unavailable: {err})")
            p.set_defaults(func=_unavailable(name, err))
            p.add_argument("rest", nargs=argparse.REMAINDER)
            continue
        p = module.add_parser(sub)
        _add_common(p)
    return parser


def _configure_logging(verbose: int, debug: bool) -> None:
    level = logging.DEBUG if debug or verbose >= 2 else logging.INFO if verbose else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s: %(message)s", stream=sys.stderr)
    logging.captureWarnings(True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``evtribo`` with *argv*; return the exit code (0 done, 1 failed, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    debug = bool(getattr(args, "debug", False))
    _configure_logging(int(getattr(args, "verbose", 0) or 0), debug)
    try:
        code = args.func(args)
    except EvtriboError as err:
        if debug:
            raise
        print(f"evtribo {args.command}: error: {err}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print(f"evtribo {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as err:
        if debug:
            raise
        print(f"evtribo {args.command}: failed: {type(err).__name__}: {err}\n"
              "(run again with --debug for the traceback)", file=sys.stderr)
        return 1
    return int(code or 0)


def entry() -> None:  # pragma: no cover - console script
    sys.exit(main())
