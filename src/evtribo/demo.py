"""The demo: a small study simulated, recorded, analysed, compared and reported.

Every step is the real one: the simulated rig streams its frames on a python-can ``virtual``
bus, :func:`evtribo.acquisition.trial.record_trial` records them into a study folder (the
code ``evtribo acquire`` runs), then ``analyze``, ``compare`` and ``report`` run on that
folder. The rig runs in time-lapse (``speed``), with the frames keeping the trial's own
timestamps, so the demo takes about a minute on two cores.

The rig is a real one (:mod:`evtribo.acquisition.simulator.realism`): load cells with zero
offsets, drift and 50 Hz hum, a tare stretch at the start of every trial, and subjects whose
strokes are a person's; the demo prints the offsets the analysis removed beside the ones
simulated.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
import threading
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can

from evtribo.acquisition.simulator import Simulator, SubjectParams, TrialConfig, default_subjects
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.acquisition.trial import TrialInfo, record_trial
from evtribo.errors import AcquisitionError, OutputExistsError
from evtribo.store.files import atomic_write
from evtribo.store.names import check_new_path

__all__ = ["AMPLITUDES_V", "MARKER", "DemoResult", "DemoTrial", "run_demo"]

log = logging.getLogger(__name__)

#: Square-wave amplitudes of the demo study, V (as in the seed paper's Section 3.3).
AMPLITUDES_V = (60.0, 80.0, 100.0, 120.0, 140.0)
STUDY, RESULTS, REPORT, TRUTH = "study", "results", "report.html", "truth.json"

Progress = Callable[[str], None]


@dataclass(frozen=True)
class DemoTrial:
    """One trial of the demo study."""

    subject: SubjectParams
    name: str
    config: TrialConfig

    def info(self) -> TrialInfo:
        c = self.config
        return TrialInfo(waveform=c.waveform, frequency_Hz=c.frequency_Hz,
                         amplitude_V=c.amplitude_V, condition=c.condition,
                         notes="simulated rig (evtribo demo)", tare_s=c.tare_s)


@dataclass
class DemoResult:
    """Where the demo wrote what, and the truth it can be checked against."""

    out: Path
    study: Path
    results: Path
    report: Path
    truth: dict[str, Any] = field(default_factory=dict)
    fitted_air_gaps: dict[str, tuple[float, float, float]] = field(default_factory=dict)


def plan(subjects: Sequence[SubjectParams], amplitudes: Sequence[float] = AMPLITUDES_V, *,
         trial_s: float = 10.0, seed: int = 0) -> list[DemoTrial]:
    """The demo's trials: per subject, alternating square-wave trials at 10 kHz for each
    amplitude, then one alternating 10 Hz sine trial at the highest amplitude; every one on
    a real rig's load cells (offsets, drift, hum, a tare stretch)."""
    trials = []
    for i, subject in enumerate(subjects):
        specs = [("square", 10_000.0, float(a)) for a in amplitudes]
        specs.append(("sine", 10.0, float(max(amplitudes))))
        for k, (waveform, freq, amp) in enumerate(specs):
            cfg = TrialConfig(duration_s=trial_s, waveform=waveform, frequency_Hz=freq,
                              amplitude_V=amp, condition="alternating",
                              seed=seed * 1000 + i * 100 + k)
            trials.append(DemoTrial(subject, f"run-{k + 1:02d}", realistic_rig(cfg)))
    return trials


def record(trial: DemoTrial, study: Path, *, speed: float) -> dict[str, Any]:
    """Stream one simulated trial on a virtual bus and record it into *study*.

    Returns the simulator's truth for the trial.
    """
    channel = f"evtribo-demo-{uuid.uuid4().hex}"
    tx = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    rx = can.Bus(interface="virtual", channel=channel)
    sim = Simulator(trial.subject, trial.config, speed=speed)
    done = threading.Event()
    failure: list[BaseException] = []

    def stream() -> None:
        try:
            sim.run(tx, duration=trial.config.duration_s)
        except BaseException as err:  # reported below, after the recording is closed
            failure.append(err)
        finally:
            done.set()

    thread = threading.Thread(target=stream, name="simulated-rig", daemon=True)
    try:
        result = record_trial(rx, study, trial.subject.name, trial.name, duration=None,
                              info=trial.info(), log_channel="vcan0",
                              started=lambda _paths: thread.start(), until=done.is_set)
    finally:
        done.set()
        if thread.is_alive() or thread.ident is not None:
            thread.join()
        tx.shutdown()
        rx.shutdown()
    if failure:
        raise AcquisitionError(f"the simulated rig failed: {failure[0]}",
                               path=result.paths.log) from failure[0]
    if result.ended != "completed":
        raise AcquisitionError(f"recording ended {result.ended}: {result.error}",
                               path=result.paths.log)
    assert sim.generator is not None
    truth = sim.generator.truth().to_dict()
    truth.update(subject=trial.subject.to_dict(), frames=result.sidecar["frames"],
                 dropped_frames=result.sidecar["dropped_frames"])
    return truth


def taring_line(trials: Any, truth: dict[str, Any]) -> str:
    """One line on the zero offsets the analysis removed against the simulated ones."""
    diffs: list[float] = []
    largest = 0.0
    for row in trials.itertuples():
        cells = truth.get(f"{row.subject}/{row.trial}", {}).get("cells", {})
        for cell in ("normal", "tangential"):
            removed = getattr(row, f"{cell}_offset_N")
            if cell in cells and removed is not None and not math.isnan(removed):
                diffs.append(abs(float(removed) - cells[cell]["mean_offset_N"]))
                largest = max(largest, abs(cells[cell]["mean_offset_N"]))
    if not diffs:
        return "taring: no offsets removed"
    return (f"taring: load-cell offsets up to {1e3 * largest:.0f} mN removed in "
            f"{len(trials)} trials, each within {1e3 * max(diffs):.1f} mN of the simulated "
            "one (trials.csv: normal_offset_N, tangential_offset_N)")


#: Left in a demo's output folder: --force replaces only folders that carry it.
MARKER = ".evtribo-demo"


def _check_out(out: Path, force: bool) -> None:
    check_new_path(out, key="--out", folder=True)  # a name evtribo writes
    taken = [out / name for name in (STUDY, RESULTS, REPORT, TRUTH) if (out / name).exists()]
    if not taken:
        return
    if not (out / MARKER).is_file():
        # not written by the demo: it may hold a lab's recordings; never replaced, even forced
        raise OutputExistsError("holds " + ", ".join(p.name for p in taken) + " not written "
                                "by evtribo demo; choose another --out", path=out)
    if not force:
        raise OutputExistsError("holds a previous demo (" + ", ".join(p.name for p in taken)
                                + "); use {force} to replace it", path=out)
    if (out / STUDY).exists():
        # The demo's own simulated study is the only thing it ever deletes: files of the
        # user's in it (or links) stop it before anything is deleted.
        foreign = sorted(set(_files(out / STUDY)) - _demo_study_files(out))
        if foreign:
            raise OutputExistsError(
                f"holds {len(foreign)} file(s) evtribo demo did not write ("
                + ", ".join(foreign[:3]) + "): the demo deletes only its own study, {force} "
                "included; move them away or choose another --out", path=out / STUDY)
        shutil.rmtree(out / STUDY)


def _files(folder: Path) -> list[str]:
    """Every file and link under *folder*, relative (links are not followed)."""
    return [p.relative_to(folder).as_posix() for p in folder.rglob("*")
            if p.is_symlink() or not p.is_dir()]


def _demo_study_files(out: Path) -> set[str]:
    """What the demo recorded into its study, as its truth.json lists the trials: each
    trial's log and sidecar, study.toml and the rig's DBC."""
    try:
        truth = json.loads((out / TRUTH).read_text(encoding="utf-8"))
        trials = list(truth.get("trials", {}))
    except (OSError, ValueError, AttributeError):
        trials = []
    own = {"study.toml", "rig/default.dbc"}
    for key in trials:
        if isinstance(key, str) and key.count("/") == 1:
            own |= {f"{key}.log", f"{key}.json"}
    return own


def run_demo(out: str | Path, *, subjects: int = 3, amplitudes: Sequence[float] = AMPLITUDES_V,
             trial_s: float = 16.0, speed: float = 8.0, seed: int = 0, jobs: int | None = None,
             force: bool = False, progress: Progress | None = None) -> DemoResult:
    """Simulate, record, analyse, compare and report a small study under *out*.

    Parameters
    ----------
    out : path-like
        Output folder: ``study/``, ``results/``, ``report.html``, ``truth.json``.
    subjects : int
        Number of simulated subjects (their μ, air gap and force drawn with *seed*).
    amplitudes : sequence of float, V
        Square-wave amplitudes.
    trial_s : float, s
        Length of each trial.
    speed : float
        Time-lapse factor of the simulated rig.
    seed : int
    jobs : int, optional
        Worker processes for the analysis.
    force : bool
        Replace a previous demo in *out*.
    progress : callable, optional
        Called with a line of text after each step.

    Returns
    -------
    DemoResult
    """
    from evtribo.report.compare import compare
    from evtribo.report.study_report import build_report
    from evtribo.results.pipeline import analyze_study

    say = progress or (lambda _line: None)
    out = Path(out)
    _check_out(out, force)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write(out / MARKER, "written by evtribo demo: --force may replace this folder's "
                               "study/, results/ and report\n")
    res = DemoResult(out=out, study=out / STUDY, results=out / RESULTS, report=out / REPORT)
    people = [human(p, seed=seed * 100 + i)
              for i, p in enumerate(default_subjects(subjects, seed=seed))]
    trials = plan(people, amplitudes, trial_s=trial_s, seed=seed)
    truths: dict[str, Any] = {"subjects": {p.name: p.to_dict() for p in people}, "trials": {}}
    for n, trial in enumerate(trials, 1):
        truth = record(trial, res.study, speed=speed)
        truths["trials"][f"{trial.subject.name}/{trial.name}"] = truth
        c = trial.config
        say(f"[{n}/{len(trials)}] recorded {trial.subject.name}/{trial.name}: {c.waveform} "
            f"{c.amplitude_V:g} V {c.frequency_Hz:g} Hz, {truth['frames']} frames, "
            f"{truth['dropped_frames']} dropped")
    atomic_write(out / TRUTH, json.dumps(truths, indent=2) + "\n")
    res.truth = truths

    def analysis_progress(done: int, total: int) -> None:
        if done == total:
            say(f"analysed {total} trials")

    analysis = analyze_study(res.study, res.results, jobs=jobs, force=force,
                             progress=analysis_progress)
    say(f"results in {res.results}")
    say(taring_line(analysis.trials, truths["trials"]))
    cmp = compare(res.results, force=force, progress=say)
    for fit in cmp.fits:
        est = next((e for e in fit.estimates if e.name == "h_L"), None)
        if est is not None:
            res.fitted_air_gaps[fit.subject] = (est.value, est.ci_low, est.ci_high)
            true_gap = truths["subjects"].get(fit.subject, {}).get("h_L")
            say(f"{fit.subject}: air gap fitted {est.value * 1e6:.2f} µm "
                f"[{est.ci_low * 1e6:.2f}, {est.ci_high * 1e6:.2f}], simulated with "
                f"{true_gap * 1e6:.2f} µm")
    build_report(res.results, res.report, force=force, run_compare=False)
    return res
