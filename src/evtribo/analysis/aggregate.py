"""Per-subject results from every trial's windows: electrostatic.csv and exponents.csv.

Each ON window is compared with a *reference* set of OFF windows:

- in a trial that alternates, its own OFF windows (same finger state, same session);
- otherwise the OFF windows of the subject's whole-OFF trials; if the subject has none,
  every OFF window of the subject (reported as a warning).

The estimates and their bootstrap are :func:`evtribo.analysis.estimate.estimate_electrostatic`,
run once per subject and waveform so that the replicates are shared by its amplitudes and
feed the power law's interval (:func:`evtribo.analysis.powerlaw.fit_power_law`). Each
subject and waveform gets its own seed (derived from the names and the settings' seed), so
the output does not depend on the order of the trials or on the number of processes.
"""

from __future__ import annotations

import logging
import zlib

import numpy as np
import pandas as pd

from evtribo.analysis.estimate import DEFAULT_N_BOOT, estimate_electrostatic
from evtribo.analysis.powerlaw import fit_power_law
from evtribo.errors import AnalysisError

log = logging.getLogger(__name__)

#: Columns of electrostatic.csv (study format, section 2).
ELECTROSTATIC_COLUMNS = ("subject", "waveform", "amplitude_V", "mu", "normal_force_on_N",
                         "normal_force_off_N", "friction_on_N", "friction_off_N",
                         "electrostatic_force_N", "electrostatic_force_ci_low_N",
                         "electrostatic_force_ci_high_N", "n_on", "n_off")
#: Columns of exponents.csv (study format, section 2).
EXPONENT_COLUMNS = ("subject", "waveform", "exponent", "exponent_ci_low", "exponent_ci_high",
                    "prefactor_N")
#: Below this many ON or OFF windows behind an amplitude, summary.json says so.
MIN_WINDOWS = 10


def _seed(base: int, *names: str) -> np.random.SeedSequence:
    return np.random.SeedSequence([base, *(zlib.crc32(n.encode()) for n in names)])


def summarize(windows: pd.DataFrame, trials: pd.DataFrame, *, n_boot: int = DEFAULT_N_BOOT,
              seed: int = 0, confidence: float = 0.95
              ) -> tuple[pd.DataFrame, pd.DataFrame, list[str]]:
    """Electrostatic force per subject, waveform and amplitude, and the power laws.

    Parameters
    ----------
    windows : pandas.DataFrame
        All trials' windows (windows.csv columns).
    trials : pandas.DataFrame
        All trials' rows (trials.csv columns); ``condition`` tells alternating trials.
    n_boot : int
        Bootstrap replicates.
    seed : int
        Base seed.
    confidence : float
        Coverage of the intervals.

    Returns
    -------
    electrostatic, exponents : pandas.DataFrame
        The tables of electrostatic.csv and exponents.csv.
    warnings : list of str
    """
    warnings: list[str] = []
    condition_of = {(r.subject, r.trial): r.condition for r in trials.itertuples()}
    el_rows: list[dict[str, object]] = []
    ex_rows: list[dict[str, object]] = []
    if windows.empty:
        return (pd.DataFrame(columns=list(ELECTROSTATIC_COLUMNS)),
                pd.DataFrame(columns=list(EXPONENT_COLUMNS)), warnings)
    wf = windows.assign(waveform=windows.waveform.fillna(""))
    for subject, sub in wf.groupby("subject", sort=True):
        off = sub[sub.condition == "off"]
        whole_off = off[[condition_of.get((subject, t)) == "off" for t in off.trial]]
        subject_ref = whole_off if len(whole_off) else off
        on_all = sub[sub.condition == "on"]
        if on_all.empty:
            continue
        for waveform, on_wave in on_all.groupby("waveform", sort=True):
            where = f"{subject} ({waveform or 'unknown waveform'})"
            on = on_wave[np.isfinite(on_wave.amplitude_V.to_numpy(float))]
            refs: list[pd.DataFrame] = []
            ref_index: dict[str, int] = {}
            on_ref = np.empty(len(on), dtype=np.int64)
            for k, trial in enumerate(on.trial):
                own = off[off.trial == trial]
                if condition_of.get((subject, trial)) == "alternating" and len(own):
                    key, frame = f"trial:{trial}", own
                else:
                    if condition_of.get((subject, trial)) == "alternating":
                        msg = (f"{where}: trial {trial} alternates but has no OFF window; "
                               "using the subject's OFF windows")
                    elif not len(whole_off):
                        msg = (f"{where}: no whole-OFF trial; trial {trial} is compared with "
                               "the OFF phases of alternating trials")
                    else:
                        msg = ""
                    if msg and msg not in warnings:
                        warnings.append(msg)
                    key, frame = "subject", subject_ref
                if key not in ref_index:
                    ref_index[key] = len(refs)
                    refs.append(frame)
                on_ref[k] = ref_index[key]
            if any(r.empty for r in refs):
                warnings.append(f"{where}: no OFF windows to estimate mu from; no "
                                "electrostatic force")
                continue
            est = estimate_electrostatic(
                [r.normal_force_N.to_numpy(float) for r in refs],
                [r.friction_force_N.to_numpy(float) for r in refs],
                on.normal_force_N.to_numpy(float), on.friction_force_N.to_numpy(float),
                on_ref, on.amplitude_V.to_numpy(float), n_boot=n_boot, confidence=confidence,
                seed=_seed(seed, str(subject), str(waveform)))
            for j, amp in enumerate(est.amplitudes_V):
                el_rows.append({
                    "subject": subject, "waveform": waveform or None, "amplitude_V": amp,
                    "mu": est.mu[j], "normal_force_on_N": est.normal_on_N[j],
                    "normal_force_off_N": est.normal_off_N[j],
                    "friction_on_N": est.friction_on_N[j],
                    "friction_off_N": est.friction_off_N[j],
                    "electrostatic_force_N": est.force_N[j],
                    "electrostatic_force_ci_low_N": est.ci_low_N[j],
                    "electrostatic_force_ci_high_N": est.ci_high_N[j],
                    "n_on": int(est.n_on[j]), "n_off": int(est.n_off[j])})
                if est.n_on[j] < MIN_WINDOWS or est.n_off[j] < MIN_WINDOWS:
                    warnings.append(f"{where} at {amp:g} V: only {est.n_on[j]} ON and "
                                    f"{est.n_off[j]} OFF windows (fewer than {MIN_WINDOWS}); "
                                    "the interval is calibrated for small counts but rests "
                                    "on few windows")
            pos = est.amplitudes_V > 0
            if np.count_nonzero(pos) < 2:
                continue
            try:
                fit = fit_power_law(est.amplitudes_V[pos], est.force_N[pos],
                                    replicates_N=est.replicates_N[:, pos],
                                    confidence=confidence)
            except AnalysisError as err:
                warnings.append(f"{where}: no power law: {err}")
                continue
            ex_rows.append({"subject": subject, "waveform": waveform or None,
                            "exponent": fit.exponent, "exponent_ci_low": fit.exponent_ci_low,
                            "exponent_ci_high": fit.exponent_ci_high,
                            "prefactor_N": fit.prefactor_N})
    for w in warnings:
        log.warning("%s", w)
    return (pd.DataFrame(el_rows, columns=list(ELECTROSTATIC_COLUMNS)),
            pd.DataFrame(ex_rows, columns=list(EXPONENT_COLUMNS)), warnings)


__all__ = ["ELECTROSTATIC_COLUMNS", "EXPONENT_COLUMNS", "summarize"]
