"""``evtribo calibrate STUDY --press SUBJECT/TRIAL [--slide SUBJECT/TRIAL ...]``: the load
cells' cross-talk matrix from calibration recordings.

Record, with ``evtribo acquire`` into the study, a trial with the finger lifted for the tare
stretch and then pressing without sliding, harder and lighter (from a light touch to about
twice the usual force), for 10-20 s: the tangential cell's reading against the normal one
there gives the share of the normal force it reads. Trials with the finger sliding back and
forth (``--slide``, default every other trial of the study) give, at each reversal, the
share of the tangential force the normal cell reads. The command prints both and the
``[rig.calibration] matrix`` that undoes them, to paste into study.toml: of the shares found
(measured within +/-1.5 % and beyond two standard errors of zero; a less precise one is
left out, with the recording that would make it precise). A sliding trial given as
``--press`` is refused. ``evtribo simulate --study STUDY --press-only`` records a press of
the simulated rig, to rehearse.
"""

from __future__ import annotations

import argparse
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``calibrate``."""
    p = subparsers.add_parser("calibrate", help="the load cells' cross-talk matrix from "
                              "calibration recordings",
                              description=__doc__.split("\n\n")[0],
                              epilog=__doc__.split("\n\n", 1)[1],
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("study", help="the study folder")
    p.add_argument("--press", metavar="SUBJECT/TRIAL",
                   help="a recording of the finger pressing without sliding")
    p.add_argument("--slide", metavar="SUBJECT/TRIAL", action="append",
                   help="a recording of the finger sliding (repeat; default: every other "
                        "trial of the study)")
    p.set_defaults(func=run)
    return p


def _split(text: str, key: str) -> tuple[str, str]:
    from evtribo.errors import UserInputError

    subject, _, trial = text.partition("/")
    if not subject or not trial:
        raise UserInputError(f"{text!r} is not SUBJECT/TRIAL (e.g. P01/run-03)", key=key)
    return subject, trial


def _unique(given: list[str]) -> list[str]:
    """The --slide trials in their order, each once (one given twice counts once)."""
    return list(dict.fromkeys(given))


def _say(found: Any) -> list[str]:
    """One line per share: its value, and whether it goes into the matrix and why."""
    from evtribo.analysis.calibration import MAX_SE, SIGNIFICANT_SE

    lines = []
    for term, cell, other, basis in (
            ("b", "tangential", "normal", f"{found.press_s:.1f} s of pressing"),
            ("a", "normal", "tangential", f"{found.reversals} reversals")):
        value, se = (found.b, found.b_se) if term == "b" else (found.a, found.a_se)
        verdict = found.verdict(term)
        if verdict == "not measured":
            lines.append(f"the {cell} cell's share of the {other} force: not measured ("
                         + ("record the finger pressing without sliding, give it with "
                            "--press)" if term == "b" else
                            "fewer than 3 reversals of the strokes: give sliding trials "
                            "with --slide)"))
            continue
        head = (f"the {cell} cell reads {100 * value:+.2f} % (+/- {100 * se:.2f}) of the "
                f"{other} force ({basis})")
        if verdict == "imprecise":
            more = ("a longer recording of the finger pressing still (10-20 s), from a "
                    "light touch to about twice the usual force" if term == "b" else
                    "more sliding trials (more reversals; the interval narrows as one "
                    "over the square root of their number)")
            lines.append(f"{head}: too uncertain to correct for (over +/- "
                         f"{100 * MAX_SE:g}), left out of the matrix; {more} would make it "
                         "precise")
        elif verdict == "none":
            lines.append(f"{head}: no cross-talk found (within {SIGNIFICANT_SE:g} "
                         "standard errors of zero): nothing to correct")
        else:
            lines.append(head)
    return lines


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo calibrate``; return the exit code."""
    from evtribo.analysis.calibration import crosstalk_matrix
    from evtribo.errors import AnalysisError, UserInputError
    from evtribo.results.trial_view import find_trial, trial_signals
    from evtribo.results.workers import trial_meta
    from evtribo.study import load_study

    study = load_study(args.study)
    if args.press is None and not args.slide and len(study.trials) < 1:
        raise UserInputError("the study has no trials to calibrate from", path=args.study)
    press_ref = find_trial(study, *_split(args.press, "--press")) if args.press else None
    slides = ([find_trial(study, *_split(s, "--slide")) for s in _unique(args.slide)]
              if args.slide else [t for t in study.trials if press_ref is None
                                  or t.key != press_ref.key])
    print(f"evtribo calibrate: pressing from {press_ref.key if press_ref else 'no trial'}, "
          f"sliding from {len(slides)} trial(s)", flush=True)
    press = trial_signals(press_ref, study) if press_ref else None
    try:
        found = crosstalk_matrix(
            press, [(trial_signals(ref, study), trial_meta(ref)) for ref in slides])
    except AnalysisError as err:
        if press_ref is not None and str(err).startswith("not a recording of the finger"):
            raise UserInputError(str(err), path=press_ref.log_path, key="--press") from err
        raise
    for line in _say(found):
        print(line)
    if found.matrix is None:
        print("\nno [rig.calibration] matrix to give: no cross-talk was found that could be "
              "corrected for")
        return 0
    (a, b), (c, d) = found.matrix
    print("\nin study.toml:\n[rig.calibration]\n"
          f"matrix = [[{a!r}, {b!r}], [{c!r}, {d!r}]]")
    return 0
