"""``evtribo simulate --study DIR --subjects N``: a whole study of subjects drawn from a
population with known parameters (the check of the population's estimates on data whose
truth is known).

Each subject's friction coefficient, air gap and target normal force are drawn
(:func:`evtribo.acquisition.simulator.population_subjects`: μ normal around ``--mu`` with SD
``--mu-spread``; h_L and F_n log-normal around ``--air-gap`` and ``--target-force`` with SDs
of their logs ``--air-gap-spread`` and ``--force-spread``); each gets one trial per
amplitude of ``--amplitudes`` (and a 10 Hz sine trial at the highest with
``--sine-trial``), with the trial options given. A real rig and real people unless
``--ideal``: each subject a person's strokes, each trial its load cells' offsets, drift and
hum, drawn with ``--seed``.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from evtribo.documents.sidecar import SIDECAR_BOUNDS
from evtribo.errors import ConfigError

__all__ = ["add_population_options", "simulate_population"]

#: Options that set one trial's or one person's imperfections: drawn per subject and trial
#: with --subjects, so refused there.
_PER_TRIAL = (("offsets", "--offsets"), ("drift", "--drift"), ("hum", "--hum"),
              ("mains", "--mains"), ("crosstalk", "--crosstalk"), ("tare_s", "--tare-s"),
              ("force_drift", "--force-drift"), ("speed", "--speed"),
              ("stroke_jitter", "--stroke-jitter"), ("dwell", "--dwell"),
              ("lifts_per_min", "--lifts-per-min"), ("lift_time", "--lift-time"),
              ("subject", "--subject"), ("trial", "--trial"), ("rig", "--rig"))
_POPULATION_OPTIONS = {"mu": "--mu", "mu_sd": "--mu-spread", "h_L": "--air-gap",
                       "h_L_log_sd": "--air-gap-spread", "normal_force_N": "--target-force",
                       "force_log_sd": "--force-spread"}


#: Most subjects of a simulated population.
MAX_SUBJECTS = 1000


def add_population_options(p: argparse.ArgumentParser) -> None:
    """The options of a study of many subjects drawn from a population.

    Parameters
    ----------
    p : argparse.ArgumentParser
        ``evtribo simulate``'s parser.

    Returns
    -------
    None
    """
    pop = p.add_argument_group(
        "a study of subjects drawn from a population (with --study; medians from --mu, "
        "--air-gap and --target-force)")
    pop.add_argument("--subjects", type=int, metavar="N",
                     help="write a whole study of N subjects P01, P02... into --study "
                          f"(1 to {MAX_SUBJECTS:,})")
    pop.add_argument("--amplitudes", default="60,80,100,120,140", metavar="V,V,...",
                     help="one trial per amplitude for each subject, V (60,80,100,120,140)")
    pop.add_argument("--mu-spread", type=float, default=0.1, metavar="SD",
                     help="standard deviation of μ between subjects (0.1)")
    pop.add_argument("--air-gap-spread", type=float, default=0.3, metavar="SD",
                     help="standard deviation of ln h_L between subjects (0.3)")
    pop.add_argument("--force-spread", type=float, default=0.3, metavar="SD",
                     help="standard deviation of ln F_n between subjects (0.3)")
    pop.add_argument("--sine-trial", action="store_true",
                     help="one more trial per subject: a 10 Hz sine at the highest amplitude")


def _amplitudes(text: str) -> list[float]:
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError as err:
        raise ConfigError(f"{text!r} is not allowed: amplitudes in V separated by commas, "
                          "e.g. 60,80,100", key="--amplitudes") from err
    if not values or any(not (math.isfinite(v) and v > 0) for v in values):
        raise ConfigError(f"{text!r} is not allowed: one amplitude or more, each a finite "
                          "number > 0", key="--amplitudes")
    high, _, why = SIDECAR_BOUNDS["amplitude_V"]
    if max(values) > high:
        raise ConfigError(f"{text!r} is not allowed: each amplitude at most {high:g} V "
                          f"({why})", key="--amplitudes")
    return sorted(set(values))


def _template(args: argparse.Namespace) -> tuple[Any, Any]:
    """The subjects' other parameters and the trials' settings the options ask for."""
    from evtribo.acquisition.simulator import SubjectParams, SubjectPopulation, TrialConfig
    from evtribo.model import TABLE_1

    model: dict[str, float] = {}
    medians = {"mu": args.mu, "h_L": args.air_gap}
    if args.model_set:
        changed = TABLE_1.with_assignments(args.model_set)
        model = {k: v for k, v in changed.as_dict().items()
                 if v != getattr(TABLE_1, k) and k not in ("mu", "h_L")}
        medians.update({n: getattr(changed, n) for n in ("mu", "h_L")
                        if getattr(changed, n) != getattr(TABLE_1, n)})
    try:
        pop = SubjectPopulation(mu=medians["mu"], mu_sd=args.mu_spread, h_L=medians["h_L"],
                                h_L_log_sd=args.air_gap_spread,
                                normal_force_N=args.target_force,
                                force_log_sd=args.force_spread)
    except ConfigError as err:
        field = (err.key or "").rpartition(".")[2]
        raise ConfigError(err.message, key=_POPULATION_OPTIONS.get(field, err.key)) from err
    template = SubjectParams(drift_time_s=args.drift_time, stroke_length_m=args.stroke_length,
                             reversal_s=args.reversal_time, model=model)
    config = TrialConfig(
        duration_s=args.duration or 30.0, waveform=args.waveform,
        frequency_Hz=args.frequency, condition=args.condition, on_s=args.on_time,
        off_s=args.off_time, start_on=args.start_on, fz_rate_Hz=args.fz_rate,
        fx_rate_Hz=args.fx_rate, hv_rate_Hz=args.hv_rate, fz_ppm=args.fz_ppm,
        fx_ppm=args.fx_ppm, hv_ppm=args.hv_ppm, noise_N=args.noise, jitter_s=args.jitter,
        drop_probability=args.drop_probability, foreign_rate_Hz=args.foreign_rate,
        seed=args.seed, **({"channel": args.channel} if args.channel else {}))
    return (pop, template), config


def simulate_population(args: argparse.Namespace) -> int:
    """Write the study of ``--subjects`` subjects and print who was drawn.

    Parameters
    ----------
    args : argparse.Namespace
        ``evtribo simulate``'s options.

    Returns
    -------
    int
        The exit code (0).

    Raises
    ------
    ConfigError
        A bad option, or one that sets a single trial's imperfection (drawn here).
    """
    from evtribo.acquisition.simulator import population_subjects, simulate_study

    if args.study is None:
        raise ConfigError("writes a study: give --study DIR", key="--subjects")
    if args.subjects < 1:
        raise ConfigError(f"{args.subjects!r} is not allowed: at least 1 subject",
                          key="--subjects")
    if args.subjects > MAX_SUBJECTS:
        raise ConfigError(f"{args.subjects!r} is not allowed: at most {MAX_SUBJECTS:,} "
                          "subjects (no study records more)", key="--subjects")
    for name, option in _PER_TRIAL:
        if getattr(args, name, None) is not None:
            raise ConfigError("not with --subjects: each subject's and trial's are drawn "
                              "(none with --ideal), the subjects named P01, P02... and "
                              "their trials run-01, run-02...", key=option)
    amplitudes = _amplitudes(args.amplitudes)
    (pop, template), config = _template(args)
    subjects = population_subjects(args.subjects, pop, seed=args.seed, template=template)
    truth = simulate_study(args.study, subjects, amplitudes, config=config,
                           sine_trial=args.sine_trial, force=args.force,
                           realistic=not args.ideal)
    print(f"{args.study}: {len(subjects)} subjects x {len(amplitudes)} amplitudes "
          f"({sum(len(t) for t in truth.values())} trials), drawn with seed {args.seed}:")
    print("subject      mu   h_L (um)   F_n (N)")
    for s in subjects:
        print(f"{s.name:8s} {s.mu:6.3f} {s.h_L * 1e6:10.3f} {s.normal_force_N:9.3f}")
    return 0
