"""The SHA-256 of every result file of the reference studies: does a change leave the
results as they were, bit for bit?

For each study (``data/reference-study``, ``data/vcan-traces/study``) it runs
``evtribo analyze STUDY --out OUT --jobs 1`` and ``evtribo compare OUT --models
paper,hertz,circuit --jobs 1``, each in a fresh process with a fresh cache folder, and
prints the SHA-256 of every CSV in OUT (trials, windows, electrostatic, exponents,
electrostatic_bootstrap, sine_trace, fit, models, population, population_contrasts,
population_subjects) and of every figure in OUT/figures. ``--against SRC`` runs another
evtribo's source folder (its ``src``, e.g. ``/work/main/src``) in the same run, with this
Python, and says of each file whether the two trees wrote the same bytes; the exit code is
1 when a file differs or is written by one tree only. Run from the repository's root::

    .venv/bin/python scripts/result_digests.py [--against ../main/src] [--keep DIR]

It takes a few minutes (two analyses and two comparisons per tree).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("data/reference-study", "data/vcan-traces/study")
MODELS = "paper,hertz,circuit"


def digests(out: Path) -> dict[str, str]:
    """The SHA-256 of every CSV of a result folder and every file in its figures/, by name.

    Parameters
    ----------
    out : Path
        The result folder.

    Returns
    -------
    dict of str to str
        ``{"trials.csv": hex, "figures/population_square_10000Hz.svg": hex, ...}``, sorted.
    """
    files = [*out.glob("*.csv"), *(p for p in (out / "figures").glob("*") if p.is_file())]
    return {p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(files)}


def results_of(src: Path, study: Path, work: Path) -> dict[str, str]:
    """Analyse and compare *study* with the evtribo of *src* in *work*; the digests.

    Parameters
    ----------
    src : Path
        The source folder (``.../src``) whose evtribo runs.
    study : Path
    work : Path
        An empty folder for the results and the cache.

    Returns
    -------
    dict of str to str
    """
    cache, out = work / "cache", work / "out"
    env = dict(os.environ, EVTRIBO_CACHE_DIR=str(cache), PYTHONPATH=str(src))
    evtribo = [sys.executable, "-m", "evtribo"]
    for args in (["analyze", str(study), "--out", str(out), "--jobs", "1", "--cache-dir",
                  str(cache)],
                 ["compare", str(out), "--models", MODELS, "--jobs", "1", "--cache-dir",
                  str(cache)]):
        done = subprocess.run([*evtribo, *args], env=env, capture_output=True, text=True,
                              check=False)
        if done.returncode:
            raise RuntimeError(f"{src}: evtribo {' '.join(args)} exited {done.returncode}:\n"
                               f"{done.stderr[-2000:]}")
    return digests(out)


def compared(mine: dict[str, str], theirs: dict[str, str] | None) -> tuple[list[str], int]:
    """The lines saying each file's digest (and whether the other tree's is the same), and
    how many differ.

    Parameters
    ----------
    mine, theirs : dict of str to str
        The digests of this tree and of the other (None: no other).

    Returns
    -------
    (list of str, int)
    """
    lines, differ = [], 0
    for name in sorted(set(mine) | set(theirs or {})):
        a = mine.get(name, "-")
        if theirs is None:
            lines.append(f"  {name:48s} {a}")
            continue
        b = theirs.get(name, "-")
        same = a == b
        differ += not same
        lines.append(f"  {name:48s} {a}  {'same' if same else 'DIFFERS: ' + b}")
    return lines, differ


def main(argv: list[str] | None = None) -> int:
    """Run, print, and say whether everything is the same."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", type=Path, help="another evtribo's src folder")
    parser.add_argument("--keep", type=Path, help="keep the result folders under DIR")
    args = parser.parse_args(argv)
    trees = {"this tree": ROOT / "src"}
    if args.against is not None:
        trees["against"] = args.against.resolve()
    print(f"this tree: {trees['this tree']}"
          + (f"; against: {trees['against']}" if args.against else ""))
    with tempfile.TemporaryDirectory(prefix="evtribo-digests-") as tmp:
        base = args.keep or Path(tmp)
        differ = 0
        for study in STUDIES:
            got = {}
            for name, src in trees.items():
                work = base / Path(study).name / name.replace(" ", "-")
                work.mkdir(parents=True)
                got[name] = results_of(src, ROOT / study, work)
            lines, n = compared(got["this tree"], got.get("against"))
            differ += n
            print(study, *lines, sep="\n")
    if args.against is not None:
        print("every file the same" if not differ else f"{differ} file(s) differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
