"""``evtribo compare`` against ``evtribo analyze``: compare cold, and again with nothing
changed, each as a ratio to analyze cold on the same study in the same run.

The studies: 8 and 20 subjects (``--subjects``) drawn from a population, each with four
square-wave amplitudes and one sine trial of 20 s (40 and 100 trials), on a real rig
(load-cell offsets, drift, 50 Hz hum, a tare stretch, a person's strokes and lift-offs).
Every command runs in a fresh process (start-up included), with a cache folder of its own
per round (``$EVTRIBO_CACHE_DIR``):

- *analyze cold*: an empty cache: every log read, decoded and analysed (the baseline);
- *compare cold*: the first comparison of that analysis (its default options: figures at
  300 dpi, each trial's check as ``--trial-checks auto`` chooses them);
- *nothing changed*: ``compare --force`` again; the figure files are then checked to be
  the same bytes as before;
- *all checks*: ``compare --force --trial-checks all``: every trial's check drawn too
  (the other figures unchanged).

Baseline: analyze cold, measured in turn with the others (``--repeat`` rounds, 3 by
default, so that each sees the same stretches of a shared machine); medians are compared,
with the range of the rounds. ``--against SRC`` times another evtribo's source folder (its
``src``, e.g. of a checkout of the main branch) in the same rounds, with this Python: its
analyze and compare as ratios to this one's analyze cold. Run:
``python benchmarks/compare.py [--subjects 8,20] [--repeat N] [--jobs N] [--against SRC]``.

Measured on 2 idle cores, one round each, this tree against the one before (``--against``,
same rounds): compare cold 1.56x analyze cold at 8 subjects (5.8 s against 3.7 s; the tree
before: 1.79x) and 1.63x at 20 (11.0 s against 6.8 s; before: 1.93x); nothing changed
0.02-0.03x; the figures the same bytes; every trial's check drawn too: 2.19x and 2.50x.
Where compare cold's 5.8 s go (8 subjects): 1.2 s of start-up, one core idle; the fits,
0.4 s on the workers; then 19 figures on the workers (about 0.27 s each for an SVG and a
PNG at 300 dpi) while the population is estimated (1.1 s) and its figure drawn here.
"""

from __future__ import annotations

import argparse
import hashlib
import logging
import os
import statistics
import sys
import tempfile
from pathlib import Path

from _measure import run

from evtribo.acquisition.simulator import TrialConfig, simulate_study
from evtribo.acquisition.simulator.study import population_subjects

AMPLITUDES = (60.0, 90.0, 120.0, 150.0)
DURATION_S = 20.0
STEPS = ("analyze cold", "compare cold", "nothing changed", "all checks")


def study_of(root: Path, subjects: int) -> tuple[Path, int]:
    """Simulate a study of *subjects* subjects; its folder and trial count."""
    study = root / "study"
    simulate_study(study, population_subjects(subjects, seed=7), amplitudes=AMPLITUDES,
                   config=TrialConfig(duration_s=DURATION_S), force=True, realistic=True)
    return study, len(list(study.glob("*/*.log")))


def figure_hashes(out: Path) -> dict[str, str]:
    """The SHA-256 of every file in ``out/figures``."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted((out / "figures").glob("*")) if p.is_file()}


def one_round(study: Path, root: Path, name: str, src: str | None, jobs: int
              ) -> tuple[dict[str, float], str]:
    """Each step's seconds with the evtribo of *src* (None: this one); what the figures
    did when nothing changed."""
    env = dict(os.environ, EVTRIBO_CACHE_DIR=str(root / f"cache-{name}"))
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    out = root / f"out-{name}"
    evtribo = [sys.executable, "-m", "evtribo"]
    secs = {"analyze cold": run([*evtribo, "analyze", str(study), "--out", str(out),
                                 "--jobs", str(jobs)], env)[0]}
    secs["compare cold"] = run([*evtribo, "compare", str(out)], env)[0]
    before = figure_hashes(out)
    secs["nothing changed"] = run([*evtribo, "compare", str(out), "--force"], env)[0]
    after = figure_hashes(out)
    same = sum(after.get(k) == v for k, v in before.items())
    said = (f"{same} of {len(before)} figure files the same bytes"
            + ("" if set(after) == set(before) else "; the files listed differ"))
    if src is None:  # another evtribo may not know the option
        secs["all checks"] = run([*evtribo, "compare", str(out), "--force", "--trial-checks",
                                  "all"], env)[0]
        said += f"; {len(figure_hashes(out))} figure files with every trial's check"
    return secs, said


def _spread(values: list[float]) -> str:
    return "one run" if len(values) == 1 else \
        f"{len(values)} runs {min(values):.1f}-{max(values):.1f} s"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", default="8,20", help="study sizes in subjects")
    parser.add_argument("--repeat", type=int, default=3, help="rounds (medians compared)")
    parser.add_argument("--jobs", type=int, default=None, help="analyze's worker processes")
    parser.add_argument("--against", metavar="SRC", default=None,
                        help="another evtribo's source folder (its src), timed alike")
    args = parser.parse_args()
    logging.basicConfig(level=logging.ERROR)
    jobs = args.jobs or os.cpu_count() or 1
    trees: dict[str, str | None] = {"this": None}
    if args.against:
        trees["other"] = str(Path(args.against).resolve())
    print(f"evtribo analyze then compare in a fresh process each (start-up included), "
          f"{jobs} worker process(es); baseline: this evtribo's analyze cold, same rounds")
    for n in (int(s) for s in args.subjects.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            study, trials = study_of(root, n)
            times: dict[str, dict[str, list[float]]] = {t: {s: [] for s in STEPS}
                                                        for t in trees}
            said: dict[str, str] = {}
            for r in range(max(1, args.repeat)):
                for tree, src in trees.items():
                    got, said[tree] = one_round(study, root, f"{tree}-{r}", src, jobs)
                    for step, s in got.items():
                        times[tree][step].append(s)
            base = statistics.median(times["this"]["analyze cold"])
            print(f"{n} subjects, {trials} trials of {DURATION_S:.0f} s: analyze cold "
                  f"{base:.1f} s ({_spread(times['this']['analyze cold'])})")
            for tree in trees:
                label = "" if tree == "this" else f" [{args.against}]"
                for step in STEPS:
                    runs = times[tree][step]
                    if not runs or (tree == "this" and step == "analyze cold"):
                        continue
                    secs = statistics.median(runs)
                    print(f"  {step + label:24s} {secs:6.1f} s ({_spread(runs)}): "
                          f"{secs / base:5.2f}x analyze cold", flush=True)
                print(f"  figures{label}: {said[tree]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
