"""The ``evtribo`` command line: one module per subcommand, grouped by what it works on
(:data:`GROUPS`): :mod:`~evtribo.cli.recording`, :mod:`~evtribo.cli.setup`,
:mod:`~evtribo.cli.results`; ``demo`` and ``cite`` stand here.

Each subcommand's module (``evtribo.cli.results.analyze``...) exposes
``add_parser(subparsers)`` (returning its parser, with ``func`` set to its ``run(args)``
through ``set_defaults``) and ``run(args) -> int``.
A subcommand whose module (or one of its optional dependencies) fails to import is still
listed, and explains why when it is called; the rest of the tool keeps working.

A command whose standard output is closed early (``evtribo inspect run.log | head -1``)
stops quietly, as Unix tools do: no message, no traceback, exit code 141 (128 + SIGPIPE,
what a shell reports for a tool that SIGPIPE ended).
"""

from __future__ import annotations

import argparse
import importlib
import io
import logging
import os
import select
import sys
from collections.abc import Callable, Sequence
from typing import Any

from evtribo.cli._startup import one_blas_thread
from evtribo.errors import EvtriboError

__all__ = ["EXIT_BROKEN_PIPE", "GROUPS", "SUBCOMMANDS", "build_parser", "entry", "main"]

#: Subcommands in the order ``evtribo --help`` lists them, with a line of help each.
#: Only the module of the subcommand being run is imported (start-up stays fast).
SUBCOMMANDS: dict[str, str] = {
    "init": "create a study folder for your rig from its DBC (roles guessed, with reasons)",
    "plan": "size a study before recording: expected intervals and power, simulated",
    "model": "the seed paper's model at a point; its figures",
    "simulate": "run the simulated rig on a CAN bus, a pty (slcan) or into a study folder",
    "acquire": "record one trial from a CAN bus into a study folder",
    "session": "record a subject's whole protocol, trial after trial",
    "inspect": "what a CAN log holds: ids, counts, rates, gaps, what decodes to what",
    "decode": "decode a CAN log through a DBC into Parquet, CSV or MF4",
    "plot": "a trial's check (forces, ON/OFF, windows, exclusions), or any signal of a log",
    "analyze": "friction, windows and the inferred electrostatic force of a study",
    "calibrate": "the load cells' cross-talk matrix from calibration recordings",
    "export": "a study's aligned forces per trial as MF4",
    "compare": "fit the model to the results of analyze; figures",
    "report": "one self-contained HTML report of a study's results",
    "demo": "simulate, record, analyse, compare and report a small study",
    "cite": "how to cite evtribo and the model it implements (text, BibTeX)",
}

#: The package of each subcommand's module that is not directly in :mod:`evtribo.cli`:
#: recording (``acquire``...), a rig and its logs (``init``...), results (``analyze``...).
GROUPS: dict[str, str] = {
    **dict.fromkeys(("acquire", "session", "simulate"), "recording."),
    **dict.fromkeys(("init", "plan", "inspect", "calibrate", "decode"), "setup."),
    **dict.fromkeys(("analyze", "compare", "report", "plot", "model", "export"), "results."),
}

log = logging.getLogger(__name__)

#: Exit code of a command whose standard output was closed early (128 + SIGPIPE).
EXIT_BROKEN_PIPE = 141


class _Version(argparse.Action):
    """``--version``: evtribo's version, looked up only when asked for."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str = "show the version and exit"
                 ) -> None:
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        import evtribo

        print(f"evtribo {evtribo.__version__}")  # on standard output, as argparse's own
        parser.exit()


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


def _chosen(argv: Sequence[str]) -> str | None:
    """The subcommand named in *argv* (its first word that is one), if any."""
    return next((a for a in argv if a in SUBCOMMANDS), None)


def _unknown_command(argv: Sequence[str]) -> str | None:
    """The error for a first word that is no subcommand (``analyse``), with the closest
    ones; None when *argv* names a subcommand or none at all."""
    import difflib

    word = next((a for a in argv if not a.startswith("-")), None)
    if word is None or word in SUBCOMMANDS:
        return None
    close = difflib.get_close_matches(word.lower(), SUBCOMMANDS, n=2, cutoff=0.6)
    hint = (f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else
            f"; the commands: {', '.join(SUBCOMMANDS)}")
    return f"unknown command {word!r}{hint} (evtribo --help lists them)"


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``evtribo`` parser.

    Parameters
    ----------
    only : str, optional
        Import and register fully only this subcommand; the others are listed with their
        help line. By default every subcommand's module is imported.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = argparse.ArgumentParser(
        prog="evtribo",
        description="Tribometer experiments on electrovibration: acquire, analyse, compare.",
        epilog="Publishing results evtribo computed? `evtribo cite` says how to cite evtribo "
               "and the model it implements (`evtribo cite --bibtex` for BibTeX).",
    )
    parser.add_argument("--version", action=_Version)
    _add_common(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, help_line in SUBCOMMANDS.items():
        if only is not None and name != only:
            sub.add_parser(name, help=help_line, add_help=False)
            continue
        try:
            module = importlib.import_module(f"evtribo.cli.{GROUPS.get(name, '')}{name}")
        except ImportError as err:
            p = sub.add_parser(name, help=f"{help_line} (unavailable: {err})")
            p.set_defaults(func=_unavailable(name, err))
            p.add_argument("rest", nargs=argparse.REMAINDER)
            continue
        p = module.add_parser(sub)
        _add_common(p)
        _as_text(p)
    return parser


def _as_text(parser: argparse.ArgumentParser) -> None:
    """A subcommand's help as a terminal shows it: its docstring's reStructuredText
    literals (````code````) as `code`, as the rest of the help writes them."""
    for attr in ("description", "epilog"):
        text = getattr(parser, attr)
        if text:
            setattr(parser, attr, text.replace("``", "`"))
    for action in parser._actions:
        if isinstance(action.help, str):
            action.help = action.help.replace("``", "`")


def _configure_logging(verbose: int, debug: bool) -> None:
    level = logging.DEBUG if debug or verbose >= 2 else logging.INFO if verbose else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s: %(message)s", stream=sys.stderr)
    logging.captureWarnings(True)


def _any_name_printable() -> None:
    """A file name that is not UTF-8 text (bytes the system decodes as surrogates) printed as
    the system holds it on standard output, escaped on standard error: never what stops a
    command after its work is done."""
    for stream, errors in ((sys.stdout, "surrogateescape"), (sys.stderr, "backslashreplace")):
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors=errors)
            except (OSError, ValueError, io.UnsupportedOperation):  # a stream of its own
                pass


def _stdout_closed() -> bool:
    """Whether the reader of standard output has gone (a pipe whose other end is closed)."""
    try:
        fd = sys.stdout.fileno()
        poll = select.poll()
        poll.register(fd, select.POLLOUT)
        return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poll.poll(0))
    except (AttributeError, OSError, ValueError):  # no file descriptor (captured, closed)
        return False


def _quiet_exit() -> int:
    """Point standard output at /dev/null (Python's last flush at exit would fail again
    and print a warning) and return :data:`EXIT_BROKEN_PIPE`."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (AttributeError, OSError, ValueError):
        pass
    return EXIT_BROKEN_PIPE


def _denied(err: PermissionError) -> str:
    """What a file the user may not open, and that no check before named, is said as (exit
    2, as a study's unreadable files are): ``FILE: cannot read: Permission denied``."""
    name = os.fsdecode(err.filename)
    how = "read" if os.path.lexists(name) and not os.access(name, os.R_OK) else "write"
    return f"{name}: cannot {how}: {err.strerror}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``evtribo`` with *argv*.

    Parameters
    ----------
    argv : sequence of str, optional
        The command line without the program's name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 done, 1 failed, 2 bad input, 141 standard output closed early.
    """
    try:
        try:
            return _main(argv)
        finally:  # here, not at exit, where a closed pipe could only be warned about
            if sys.stdout is not None:
                sys.stdout.flush()
    except BrokenPipeError:
        if not _stdout_closed():
            raise
        return _quiet_exit()


def _main(argv: Sequence[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    chosen = _chosen(argv)
    parser = build_parser(only=chosen or "")
    unknown = None if chosen else _unknown_command(argv)
    if unknown is not None:
        parser.error(unknown)  # usage and the error on stderr, exit 2
    args = parser.parse_args(argv)
    _any_name_printable()
    debug = bool(getattr(args, "debug", False))
    _configure_logging(int(getattr(args, "verbose", 0) or 0), debug)
    try:
        code = args.func(args)
    except EvtriboError as err:
        if debug:
            raise
        print(f"evtribo {args.command}: error: {err.cli_text()}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print(f"evtribo {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as err:
        if isinstance(err, BrokenPipeError) and _stdout_closed():
            return _quiet_exit()
        if debug:
            raise
        if isinstance(err, PermissionError) and err.filename is not None:
            print(f"evtribo {args.command}: error: {_denied(err)}", file=sys.stderr)
            return 2
        print(f"evtribo {args.command}: failed: {type(err).__name__}: {err}\n"
              "(run again with --debug for the traceback)", file=sys.stderr)
        return 1
    return int(code or 0)


def entry() -> None:  # pragma: no cover - console script
    """The ``evtribo`` console script: one BLAS thread, then :func:`main`, its exit code the
    process's."""
    one_blas_thread()  # before numpy is imported
    sys.exit(main())
