"""Write a study folder and its truth from a :class:`StudyConfig` and a seed.

    python tests/heldout/generator.py DEST [--scenario NAME] [--seed N]

writes ``DEST/study/`` (study.toml, rig/heldout.dbc, one candump ``-L`` log and sidecar per
trial) and ``DEST/truth.json`` with ``DEST/truth/`` (a 10-ms trace of every trial's true
electrostatic force). README.md beside this file says what each number of the truth means.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: import the package from tests/
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from heldout import canframes, cells, logfile, truth
from heldout.config import StudyConfig
from heldout.trial import Subject, TrialSpec, simulate, weak_gap

EPOCH_S = 1_763_700_000.0


def draw_subjects(cfg: StudyConfig, rng: np.random.Generator) -> list[Subject]:
    """Every subject's friction and electrostatic parameters."""
    e, f = cfg.electrostatic, cfg.friction
    n_weak = round(e.weak_share * cfg.subjects)
    weak = set(rng.choice(cfg.subjects, size=n_weak, replace=False).tolist()) if n_weak else set()
    out = []
    for i in range(cfg.subjects):
        mu = rng.uniform(*f.mu)
        s = Subject(name=f"P{i + 1:02d}", mu=mu, c=mu * f.f_ref_N ** (1.0 - f.m),
                    asymmetry=f.direction_asymmetry * rng.choice([-1.0, 1.0]),
                    weak=i in weak)
        factor = rng.uniform(*e.weak_factor) if s.weak else 1.0
        if e.model == "paper":
            h = e.h_L_median_m * float(np.exp(e.h_L_log_sd * rng.standard_normal()))
            s.h_L_m = weak_gap(cfg, h, factor) if s.weak else h
        elif e.model == "power":
            s.n = e.n_mean + e.n_sd * rng.standard_normal()
            f140 = e.force_at_140V_N * float(np.exp(e.force_log_sd * rng.standard_normal()))
            s.k = factor * f140 / 140.0**s.n
        else:
            raise ValueError(f"unknown electrostatic model {e.model!r}")
        out.append(s)
    return out


def plan_trials(cfg: StudyConfig, subject: Subject, rng: np.random.Generator) -> list[TrialSpec]:
    """The subject's trials in recording order (amplitudes shuffled, as a protocol does)."""
    f = cfg.friction
    kinds: list[tuple[float, str]] = []
    for amp in cfg.drive.amplitudes_V:
        for _ in range(cfg.repetitions):
            if cfg.drive.signal == "sidecar":
                kinds += [(0.0, "off"), (amp, "on")]
            else:
                kinds.append((amp, "alternating"))
    order = rng.permutation(len(kinds) // (2 if cfg.drive.signal == "sidecar" else 1))
    if cfg.drive.signal == "sidecar":
        kinds = [k for i in order for k in kinds[2 * i : 2 * i + 2]]
    else:
        kinds = [kinds[i] for i in order]
    specs = []
    for j, (amp, cond) in enumerate(kinds):
        specs.append(TrialSpec(
            subject=subject, name=f"run-{j + 1:02d}", amplitude_V=amp, condition=cond,
            mu_factor=float(np.exp(f.trial_spread * rng.standard_normal())),
            moisture_rise=rng.uniform(*f.moisture_rise),
            moisture_tau_s=rng.uniform(*f.moisture_tau_s)))
    return specs


def study_toml(cfg: StudyConfig, xtalk: np.ndarray) -> str:
    """study.toml: the rig's roles (and the cross-talk matrix when the lab measured it)."""
    roles = dict(canframes.ROLES)
    if cfg.drive.signal == "can":
        roles.update(canframes.EXCITATION_ROLES)
    lines = [f'name = "held-out study: {cfg.name}"', "", "[rig]", 'dbc = "rig/heldout.dbc"']
    lines += [f'{k} = "{v}"' for k, v in roles.items()]
    if cfg.cells.calibration_in_toml and cfg.cells.crosstalk > 0:
        inv = np.linalg.inv(xtalk)
        rows = ", ".join("[" + ", ".join(f"{v:.6f}" for v in r) + "]" for r in inv)
        lines += ["", "[rig.calibration]", f"matrix = [{rows}]"]
    return "\n".join(lines) + "\n"


def sidecar(cfg: StudyConfig, spec: TrialSpec) -> dict:
    """The trial's sidecar, as a lab's acquisition would write it."""
    return {"subject": spec.subject.name, "waveform": cfg.drive.waveform,
            "frequency_Hz": cfg.drive.frequency_Hz, "amplitude_V": spec.amplitude_V,
            "condition": spec.condition, "tare_s": cfg.cells.tare_s,
            "notes": f"held-out generator, scenario {cfg.name}"}


def write_trial(study: Path, dest: Path, cfg: StudyConfig, spec: TrialSpec, *,
                xtalk: np.ndarray, epoch: float, rng: np.random.Generator) -> dict:
    """Simulate one trial, write its log, sidecar and truth trace; its truth record."""
    phys = simulate(cfg, spec, rng)
    streams = cells.sample(phys.t, (phys.normal, phys.tangential), xtalk, cells=cfg.cells,
                           logger=cfg.logger, rng=rng)
    frames = logfile.cell_streams(streams)
    if cfg.drive.signal == "can":
        frames.append(logfile.status_stream(phys.t, phys.on, cfg, spec.amplitude_V, rng))
    if cfg.logger.foreign_rate_Hz > 0:
        frames.append(logfile.heartbeat_stream(cfg.trial_s, cfg.logger.foreign_rate_Hz, rng))
    folder = study / spec.subject.name
    folder.mkdir(parents=True, exist_ok=True)
    info = logfile.write(folder / f"{spec.name}.log", frames, cfg, epoch, rng)
    (folder / f"{spec.name}.json").write_text(json.dumps(sidecar(cfg, spec), indent=2) + "\n")
    trace = truth.write_trace(dest / "truth" / f"{spec.subject.name}_{spec.name}.npz",
                              phys, info)
    return truth.trial_record(spec, phys, streams, info, trace.relative_to(dest))


def generate(dest: Path, cfg: StudyConfig, seed: int) -> dict:
    """Write ``dest/study`` and ``dest/truth.json``; return the truth."""
    rng = np.random.default_rng(seed)
    study = dest / "study"
    study.mkdir(parents=True, exist_ok=False)
    canframes.write_dbc(study / "rig" / "heldout.dbc")
    xtalk = cells.crosstalk_matrix(cfg.cells, rng)
    (study / "study.toml").write_text(study_toml(cfg, xtalk))
    subjects = draw_subjects(cfg, rng)
    records = []
    epoch = EPOCH_S + float(rng.integers(0, 10_000_000))
    for subject in subjects:
        for spec in plan_trials(cfg, subject, rng):
            records.append(write_trial(study, dest, cfg, spec, xtalk=xtalk, epoch=epoch,
                                       rng=rng))
            epoch += cfg.trial_s + 30.0 + rng.uniform(0, 60)
    doc = truth.study_truth(cfg, seed, subjects, records, xtalk)
    (dest / "truth.json").write_text(json.dumps(doc, indent=1, default=float) + "\n")
    return doc


def main(argv: list[str] | None = None) -> int:
    """The command line: one study of a named scenario."""
    from heldout.scenarios import SCENARIOS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dest", type=Path)
    parser.add_argument("--scenario", default="clean", choices=sorted(SCENARIOS))
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    doc = generate(args.dest, SCENARIOS[args.scenario], args.seed)
    print(f"{args.dest}/study: {len(doc['trials'])} trials, {len(doc['cells'])} cells; "
          f"truth in {args.dest}/truth.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
