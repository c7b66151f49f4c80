"""Simulated trials written as a study folder (spec §1): logs, sidecars, ``study.toml``."""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evtribo import __version__
from evtribo.acquisition.rigfile import write_new_study
from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig
from evtribo.acquisition.simulator.core import TrialTruth, simulate_trial
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.canlog.io import write_candump
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import Rig, default_rig
from evtribo.documents.sidecar import read_sidecar, rig_entry, write_sidecar
from evtribo.errors import ConfigError, EvtriboError, OutputExistsError, RigConfigError
from evtribo.store.files import atomic_open, partial_path
from evtribo.store.lock import WriteLock
from evtribo.study import STUDY_FILE, read_study_toml, validate_name

__all__ = ["SubjectPopulation", "default_subjects", "population_subjects", "simulate_study",
           "write_trial"]

log = logging.getLogger(__name__)

#: The study's copy of the default rig's DBC, relative to ``study.toml``.
RIG_DBC = "rig/default.dbc"


def default_subjects(n: int = 3, seed: int = 0) -> list[SubjectParams]:
    """*n* plausible, different subjects ``P01``, ``P02``...: mu 0.3-0.7, air gap 3-8 um,
    target force 0.4-1.0 N (drawn with *seed*).

    Parameters
    ----------
    n : int
        How many subjects.
    seed : int

    Returns
    -------
    list of SubjectParams
    """
    rng = np.random.default_rng([seed, 1001])
    return [
        SubjectParams(name=f"P{i + 1:02d}", mu=round(float(rng.uniform(0.3, 0.7)), 3),
                      h_L=round(float(rng.uniform(3e-6, 8e-6)), 8),
                      normal_force_N=round(float(rng.uniform(0.4, 1.0)), 2),
                      force_drift=round(float(rng.uniform(0.03, 0.08)), 3),
                      sliding_speed_m_s=round(float(rng.uniform(0.015, 0.03)), 4))
        for i in range(n)
    ]


#: The smallest friction coefficient a simulated subject is drawn with.
MIN_MU = 0.05


@dataclass(frozen=True)
class SubjectPopulation:
    """Where simulated subjects come from: the population's typical values and spreads.

    Attributes
    ----------
    mu : float
        Mean friction coefficient.
    mu_sd : float
        Its standard deviation between subjects (normal; a draw below
        :data:`MIN_MU` is drawn again).
    h_L : float, m
        Median equivalent air gap (the paper's Table 1: 5 µm).
    h_L_log_sd : float
        Standard deviation of ln h_L between subjects (log-normal: 0.3 is a factor of 1.35).
    normal_force_N : float, N
        Median target normal force.
    force_log_sd : float
        Standard deviation of ln F_n between subjects.
    """

    mu: float = 0.5
    mu_sd: float = 0.1
    h_L: float = 5e-6
    h_L_log_sd: float = 0.3
    normal_force_N: float = 0.5
    force_log_sd: float = 0.3

    def __post_init__(self) -> None:
        for name, key in (("mu", "mu"), ("h_L", "h_L"), ("normal_force_N", "normal_force_N")):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"{value!r} is not allowed: must be a finite number > 0",
                                  key=f"SubjectPopulation.{key}")
        for name in ("mu_sd", "h_L_log_sd", "force_log_sd"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= 3):
                raise ConfigError(f"{value!r} is not allowed: a spread from 0 to 3",
                                  key=f"SubjectPopulation.{name}")
        if self.mu < MIN_MU:
            raise ConfigError(f"{self.mu!r} is not allowed: the mean friction coefficient "
                              f"must be at least {MIN_MU}", key="SubjectPopulation.mu")



def population_subjects(n: int, population: SubjectPopulation | None = None, *,
                        seed: int = 0, template: SubjectParams | None = None
                        ) -> list[SubjectParams]:
    """*n* subjects ``P01``, ``P02``... drawn from a population with known parameters.

    Each subject's friction coefficient is normal (mean ``mu``, SD ``mu_sd``, at least
    :data:`MIN_MU`), its air gap and target normal force log-normal (medians ``h_L`` and
    ``normal_force_N``, SDs of their logs ``h_L_log_sd`` and ``force_log_sd``), all
    independent; the other parameters are *template*'s.

    Parameters
    ----------
    n : int
        How many subjects (at least 1).
    population : SubjectPopulation, optional
        Default: :class:`SubjectPopulation` ().
    seed : int
        Seed of the draws.
    template : SubjectParams, optional
        The subjects' other parameters (strokes, drift, model); default SubjectParams().

    Returns
    -------
    list of SubjectParams

    Raises
    ------
    ConfigError
        *n* below 1.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError(f"{n!r} is not allowed: at least 1 subject", key="subjects")
    pop = population or SubjectPopulation()
    base = template or SubjectParams()
    rng = np.random.default_rng([seed, 3003])
    out = []
    for i in range(n):
        mu = float(rng.normal(pop.mu, pop.mu_sd))
        while mu < MIN_MU:
            mu = float(rng.normal(pop.mu, pop.mu_sd))
        h_l = pop.h_L * math.exp(pop.h_L_log_sd * float(rng.standard_normal()))
        fn = pop.normal_force_N * math.exp(pop.force_log_sd * float(rng.standard_normal()))
        out.append(dataclasses.replace(base, name=f"P{i + 1:02d}", mu=round(mu, 4),
                                       h_L=float(f"{h_l:.4g}"), normal_force_N=round(fn, 4)))
    return out


def _rig_table(rig: Rig, dbc_rel: str) -> dict[str, Any]:
    """The ``[rig]`` table of a new study for *rig*."""
    return {"dbc": dbc_rel, **{r: ref.qualified_name for r, ref in rig.roles.items()}}


#: The comment above a new simulated study's ``[rig.calibration]``.
EXACT_NOTE = ("The simulated tangential cell reads exactly zero at rest (no offset, drift or\n"
              "cross-talk): its zero is known, as a calibrated rig's is.")


def _exact_tangential(config: TrialConfig) -> bool:
    """Whether the simulated tangential cell reads exactly zero at rest."""
    return (config.fx_offset_N == 0 and config.fx_drift_N_per_s == 0
            and config.fx_thermal_N == 0 and config.crosstalk[1][0] == 0)


def _study_rig(root: Path, rig: Rig | None, name: str, *, exact: bool = False
               ) -> tuple[Rig, str]:
    """The rig a trial of the study at *root* speaks, and its DBC relative to the study.

    A study with a ``study.toml`` speaks its own rig (*rig*, if given, must be the same); a
    new one is created for *rig* (default: the default rig), with a copy of its DBC, and,
    when the trial's tangential cell is *exact* (it reads zero at rest), ``[rig.calibration]
    tangential_offset_N = 0.0``: a study of an exact rig without a tare stretch whose OFF
    and ON windows slid opposite ways is then analysed as a calibrated rig's, not left
    without its force (:mod:`evtribo.analysis.forces.taring`).
    """
    toml = root / STUDY_FILE
    if toml.exists():
        table = read_study_toml(toml).get("rig")
        if not isinstance(table, dict):
            raise RigConfigError("has no [rig] table", path=toml, key="rig")
        own = Rig.from_mapping(table, root, source=toml)
        if rig is not None and rig.fingerprint() != own.fingerprint():
            raise RigConfigError(f"the study's rig is {own.name!r} ({own.dbc}), not the rig "
                                 f"asked for ({rig.dbc}): simulate it without a rig, or into "
                                 "another study", path=toml, key="rig")
        return own, os.path.relpath(own.dbc, root.resolve())
    use = rig or default_rig()
    dbc_rel = RIG_DBC if rig is None else f"rig/{use.dbc.name}"
    try:
        write_new_study(root, use.dbc, dbc_rel=dbc_rel, name=name,
                        rig=_rig_table(use, dbc_rel),
                        calibration={"tangential_offset_N": 0.0} if exact else None,
                        calibration_note=EXACT_NOTE)
    except OutputExistsError:  # another process created it meanwhile
        return _study_rig(root, rig, name, exact=exact)
    log.info("new study folder %s for the rig %s (%s)", root, use.name, use.dbc)
    return use, dbc_rel


def write_trial(root: str | os.PathLike[str], trial: str, subject: SubjectParams,
                config: TrialConfig, *, force: bool = False, notes: str = "",
                study_name: str = "simulated study", rig: Rig | None = None) -> TrialTruth:
    """Simulate one trial into a study folder: ``<subject>/<trial>.log`` and ``.json``.

    The trial speaks the study's rig (its DBC and roles, whatever their IDs, byte order and
    scales). The study folder and its ``study.toml`` (with a copy of the rig's DBC: *rig*'s,
    default the default rig's) are created if missing. The sidecar holds the spec's keys,
    the frame counts, and the truth under ``"simulation"``.

    Parameters
    ----------
    root : path-like
        The study folder.
    trial : str
        Trial name (``run-01``).
    subject : SubjectParams
        The subject; its ``name`` is the subject folder.
    config : TrialConfig
    force : bool
        Overwrite an existing trial.
    notes : str
        Free text for the sidecar.
    study_name : str
        The study's ``name`` in a new ``study.toml``.
    rig : Rig, optional
        The rig of a new study (an existing study's must be the same).

    Returns
    -------
    TrialTruth

    Raises
    ------
    LockedError
        Another process is writing that trial (``--force`` included).
    OutputExistsError
        The trial exists and *force* is False.
    """
    root = Path(root)
    validate_name(subject.name, what="subject", key="subject")
    validate_name(trial, what="trial", key="trial")
    log_path = root / subject.name / f"{trial}.log"
    lock = WriteLock(log_path.with_suffix(".lock"), f"the trial {subject.name}/{trial}",
                     "recorded")
    lock.check()  # --force included: never into a trial another process writes
    _refuse_existing(log_path, force)
    used, dbc_rel = _study_rig(root, rig, study_name, exact=_exact_tangential(config))
    frames, truth = simulate_trial(subject, config, rig=used)
    log_path.parent.mkdir(parents=True, exist_ok=True)
    entry = rig_entry(dbc_rel, name=used.name, dbc_version=used.database.version)
    with lock:
        _refuse_existing(log_path, force)  # again, now that nobody else can write it
        _write_files(log_path, frames, truth, subject, config, force=force, notes=notes,
                     rig=entry)
    return truth


def _refuse_existing(log_path: Path, force: bool) -> None:
    existing = [p for p in (log_path, partial_path(log_path),
                            log_path.with_suffix(".json")) if p.exists()]
    if existing and not force:
        raise OutputExistsError("trial exists already (use {force} to overwrite): "
                                + ", ".join(str(p) for p in existing), path=existing[0])
    if existing:
        _refuse_recorded(log_path)


def _refuse_recorded(log_path: Path) -> None:
    """``--force`` replaces a trial evtribo simulated (its sidecar says so), never a
    recording: nothing recorded is ever lost."""
    sidecar = log_path.with_suffix(".json")
    part = partial_path(log_path)
    why = None
    if part.exists():
        why = f"{part.name} is a recording that was cut short"
    else:
        try:
            extra = read_sidecar(sidecar, default_subject=log_path.parent.name).extra
        except (OSError, EvtriboError):
            extra = {}
        bus = extra.get("bus")
        if "simulation" not in extra or not isinstance(bus, dict) or \
                bus.get("interface") != "simulated":
            why = ("its sidecar does not say it was simulated: a recording (made from a bus)"
                   if sidecar.exists() else "it has no sidecar saying it was simulated")
    if why is not None:
        raise OutputExistsError(f"{why}; evtribo simulate replaces only a trial it simulated, "
                                "{force} included (nothing recorded is ever lost): choose "
                                "another trial name", path=log_path)


def _write_files(log_path: Path, frames: FrameTable, truth: TrialTruth, subject: SubjectParams,
                 config: TrialConfig, *, force: bool, notes: str, rig: dict[str, Any]) -> None:
    sidecar_path = log_path.with_suffix(".json")
    # a name of its own (not TRIAL.log.part, which may be a killed recording of this trial)
    with atomic_open(log_path, "wb") as fh:
        write_candump(fh, frames, config.channel)
    if force:
        partial_path(log_path).unlink(missing_ok=True)
    dropped = sum(int(n["dropped"]) for n in truth.nodes.values())
    sidecar: dict[str, Any] = {
        "subject": subject.name, "waveform": config.waveform,
        "frequency_Hz": config.frequency_Hz, "amplitude_V": config.amplitude_V,
        "condition": config.condition, "notes": notes, "tare_s": config.tare_s,
        "rig": rig, "bus": {"interface": "simulated", "channel": config.channel},
        "software": f"evtribo {__version__}", "start_time": config.start_time,
        "frames": len(frames), "dropped_frames": dropped, "bus_errors": 0,
        "simulation": truth.to_dict(),
    }
    write_sidecar(sidecar_path, json.loads(json.dumps(sidecar)), force=force)
    log.info("wrote %s (%d frames)", log_path, len(frames))


def simulate_study(root: str | os.PathLike[str], subjects: Sequence[SubjectParams] | None = None,
                   amplitudes: Sequence[float] = (60.0, 80.0, 100.0, 120.0, 140.0), *,
                   config: TrialConfig | None = None, sine_trial: bool = True,
                   force: bool = False, name: str = "simulated study",
                   realistic: bool = False) -> dict[str, dict[str, TrialTruth]]:
    """Write a whole simulated study: every subject at every amplitude.

    Each subject gets one trial per amplitude (``run-01``...) with *config*'s waveform
    (default: 10 kHz square, alternating 2 s / 2 s, 30 s), and, if *sine_trial*, one more at
    the highest amplitude with a 10 Hz sine. Seeds differ per trial and follow
    ``config.seed``.

    Parameters
    ----------
    root : path-like
        The study folder (created).
    subjects : sequence of SubjectParams, optional
        Default: :func:`default_subjects` (3 subjects).
    amplitudes : sequence of float, V
    config : TrialConfig, optional
        Template for every trial.
    sine_trial : bool
    force : bool
        Overwrite existing trials.
    name : str
        The study's ``name`` in a new ``study.toml``.
    realistic : bool
        A real rig and real people (:mod:`~evtribo.acquisition.simulator.realism`): every
        trial's load cells get their own offsets, drift and hum and a tare stretch, every
        subject a person's strokes.

    Returns
    -------
    dict
        ``{subject: {trial: TrialTruth}}``.
    """
    base = config or TrialConfig()
    subjects = list(subjects) if subjects is not None else default_subjects(seed=base.seed)
    if realistic:
        subjects = [human(s, seed=base.seed * 100 + i) for i, s in enumerate(subjects)]
    out: dict[str, dict[str, TrialTruth]] = {}
    for si, subject in enumerate(subjects):
        trials = [dataclasses.replace(base, amplitude_V=float(a)) for a in amplitudes]
        if sine_trial:
            trials.append(dataclasses.replace(base, waveform="sine", frequency_Hz=10.0,
                                              amplitude_V=float(max(amplitudes))))
        out[subject.name] = {}
        for ti, template in enumerate(trials):
            cfg = dataclasses.replace(template, seed=base.seed * 100_003 + si * 1000 + ti,
                                      start_time=base.start_time + 3600 * si + 120 * ti)
            if realistic:
                cfg = realistic_rig(cfg)
            trial = f"run-{ti + 1:02d}"
            out[subject.name][trial] = write_trial(root, trial, subject, cfg, force=force,
                                                   study_name=name)
    return out
