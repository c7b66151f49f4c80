"""``evtribo plot``: a trial's check, or any signal of any log, to a file or a window.

Two forms::

    evtribo plot trial STUDY SUBJECT TRIAL [-o FILE]
    evtribo plot LOG --dbc FILE SIGNAL... [-o FILE]

The first draws what the analysis did with one trial of a study (decoded through the cache,
analysed with the study's settings, as ``evtribo analyze`` does): the normal and tangential
force, the ON phases, the steady-sliding windows, the finger-lifted stretches and what was
excluded. The second draws signals of a CAN log decoded with a DBC (``Signal``,
``Message.Signal`` or a pattern such as ``'Fz*'``), one panel per unit. A log whose name is
``trial`` is written ``./trial``.

With ``-o FILE`` the figure is written there, its format from the suffix (``.png`` at 300
dpi, ``.svg``, ``.pdf``); an existing file is kept unless ``--force``. Without it, the figure
opens in a window.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from evtribo.errors import UserInputError
from evtribo.guard import refuse_cache_in_study, refuse_input
from evtribo.store.files import atomic_open
from evtribo.store.owned import check_output, claim

#: Figure formats, by the output's suffix.
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: Resolution of a PNG, dots per inch.
PNG_DPI = 300

_DESCRIPTION = (
    "The first form draws what the analysis did with one trial of a study (decoded through "
    "the cache, analysed with the study's settings, as evtribo analyze does): the normal and "
    "tangential force, the ON phases, the steady-sliding windows, the finger-lifted "
    "stretches and what was excluded. The second draws signals of a CAN log decoded with a "
    "DBC (Signal, Message.Signal, or a pattern such as 'Fz*'), one panel per unit. A log "
    "named 'trial' is written ./trial. With -o FILE the figure is written there, its format "
    "from the suffix (.png at 300 dpi, .svg, .pdf); an existing file is kept unless --force. "
    "Without -o the figure opens in a window. Exit 0 done, 1 the trial could not be "
    "analysed, 2 bad input.")

_USAGE = ("evtribo plot trial STUDY SUBJECT TRIAL [-o FILE] [--force]\n"
          "       evtribo plot LOG --dbc FILE SIGNAL... [-o FILE] [--force]")


def _options(p: argparse.ArgumentParser) -> None:
    """The options of ``evtribo plot`` (before or after its words)."""
    p.add_argument("--dbc", metavar="FILE", help="the DBC to decode LOG with")
    p.add_argument("-o", "--output", metavar="FILE",
                   help="write the figure here (.png, .svg or .pdf) instead of a window")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--channel", help="a log's frames of this channel (bus) only")
    p.add_argument("--cache-dir", metavar="DIR",
                   help="cache of decoded trials (default: $EVTRIBO_CACHE_DIR or "
                        "~/.cache/evtribo)")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo plot``.

    Its words (``trial STUDY SUBJECT TRIAL``, or ``LOG SIGNAL...``) and its options may be
    mixed in any order: the words and what follows them are parsed again by :func:`run`.
    """
    p = subparsers.add_parser(
        "plot", help="a trial's check (forces, ON/OFF, windows, exclusions) or any signal "
                     "of a log, to a file or a window",
        usage=_USAGE, description=_DESCRIPTION)
    _options(p)
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARG",
                   help="'trial STUDY SUBJECT TRIAL', or 'LOG SIGNAL...' with --dbc")
    p.set_defaults(func=run)
    return p


def _words(args: argparse.Namespace) -> argparse.Namespace:
    """*args* with the words and options that follow the first word parsed (options may
    come between the words: ``LOG --dbc FILE SIGNAL``)."""
    inner = argparse.ArgumentParser(prog="evtribo plot", usage=_USAGE,
                                    description=_DESCRIPTION)
    _options(inner)
    inner.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                       help=argparse.SUPPRESS)
    inner.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help=argparse.SUPPRESS)
    inner.add_argument("words", nargs="*", metavar="ARG")
    rest = list(args.args)
    parsed = inner.parse_intermixed_args(rest, namespace=argparse.Namespace(**{
        k: v for k, v in vars(args).items() if k != "args"}))
    parsed.args = parsed.words
    if not parsed.args:
        inner.error("expected 'trial STUDY SUBJECT TRIAL' or 'LOG SIGNAL...'")
    return parsed


def _check_output(out: str | None, force: bool) -> str | None:
    """The output's format (None: a window); refuses an unknown suffix or an existing file
    without ``--force``, before anything is read."""
    if out is None:
        return None
    suffix = os.path.splitext(out)[1].lower()
    if suffix not in FORMATS:
        raise UserInputError("the figure's format comes from its suffix: .png, .svg or .pdf, "
                             f"not {suffix or '(none)'!r}", path=out)
    refuse_input(out, command="evtribo plot", key="-o")  # --force or not
    check_output(out, "plot", force=force, key="-o")  # only its own: --force or not
    return FORMATS[suffix]


def _window_figure() -> Figure:
    """A pyplot figure to show, or why no window can open here."""
    import matplotlib.pyplot as plt

    backend = str(plt.get_backend()).lower()
    if backend in {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}:
        raise UserInputError(f"no window can open here (matplotlib backend {backend!r}, no "
                             "display): give -o FILE", key="-o")
    return plt.figure(figsize=(6.89, 3.4), layout="constrained")


def _save(fig: Figure, out: str, fmt: str) -> None:
    """Write *fig* to *out* as one unit."""
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(out, "wb") as fh:
        fig.savefig(fh, format=fmt, dpi=PNG_DPI if fmt == "png" else "figure")
    claim(out, "plot")


def _trial(args: argparse.Namespace, window: Figure | None) -> Figure:
    """``evtribo plot trial STUDY SUBJECT TRIAL``."""
    from evtribo.figures.trial_plots import draw_trial_check, trial_caption
    from evtribo.results.trial_view import view_trial

    if len(args.args) != 4:
        raise UserInputError("expected 'evtribo plot trial STUDY SUBJECT TRIAL' (got "
                             f"{len(args.args) - 1} of its 3 names)", key="trial")
    if args.dbc is not None:
        raise UserInputError("a trial is decoded with its study's DBC; --dbc is for a log's "
                             "signals", key="--dbc")
    _, study, subject, trial = args.args
    refuse_cache_in_study(args.cache_dir, study)
    check = view_trial(study, subject, trial, cache_dir=args.cache_dir)
    ax = draw_trial_check(check, None if window is None else window.add_subplot())
    print(trial_caption(check))
    fig = ax.get_figure()
    assert isinstance(fig, Figure)
    return fig


def _signals(args: argparse.Namespace, window: Figure | None) -> Figure:
    """``evtribo plot LOG --dbc FILE SIGNAL...``."""
    from evtribo.canlog.decode_table import load_dbc_file
    from evtribo.canlog.io import read_frames
    from evtribo.figures.log_plots import decode_signals, on_channel, plot_signals, resolve_signals

    log_path, asked = args.args[0], args.args[1:]
    if args.dbc is None:
        raise UserInputError("give the DBC to decode it with: evtribo plot LOG --dbc FILE "
                             "SIGNAL...", path=log_path, key="--dbc")
    if not asked:
        raise UserInputError("name the signals to plot: evtribo plot LOG --dbc FILE "
                             "SIGNAL...", path=log_path)
    db = load_dbc_file(args.dbc)
    pairs = resolve_signals(db, asked, dbc_path=args.dbc)
    frames, _ = read_frames(log_path)
    frames = on_channel(frames, args.channel, log_path)
    signals = decode_signals(frames, db, pairs)
    missing = [f"{m}.{s}" for m, s in pairs
               if not any(x.message == m and x.name == s for x in signals)]
    if not signals:
        raise UserInputError(f"no frame of {', '.join(sorted({m for m, _ in pairs}))} in the "
                             "log: nothing to plot", path=log_path)
    if missing:
        print(f"evtribo plot: {log_path}: no frames of {', '.join(missing)}", file=sys.stderr)
    return plot_signals(signals, window)


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo plot``; return the exit code."""
    args = _words(args)
    fmt = _check_output(args.output, args.force)
    window = None if fmt else _window_figure()
    fig = (_trial if args.args[0] == "trial" else _signals)(args, window)
    if fmt is None:
        import matplotlib.pyplot as plt

        plt.show()
        return 0
    _save(fig, args.output, fmt)
    print(f"wrote {args.output}")
    return 0
