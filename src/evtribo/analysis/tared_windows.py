"""A trial's taring step: the calibration, the finger-lifted stretches and the friction loop
(:mod:`.zero_offsets`), with the steady-sliding windows they give, and what they are worth
saying.

It joins the analysis's two floors, so it sits above both: the load cells' zero offsets
(:mod:`evtribo.analysis.forces`) and the steady-sliding windows
(:mod:`evtribo.analysis.friction.windows`), which the friction loop fits and whose means are
taken again from the forces it corrects.
"""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.align import AlignedForces
from evtribo.analysis.forces.excitation import Excitation, window_amplitudes
from evtribo.analysis.forces.zero_offsets import (
    Tared,
    calibrate,
    friction_loop_offset,
    tare_lifted,
    tare_loop,
)
from evtribo.analysis.friction.windows import find_windows, with_means
from evtribo.analysis.piece_observer import lift_exclusion
from evtribo.analysis.settings import AnalysisSettings
from evtribo.canlog.rig import Calibration
from evtribo.warning.collect import emitter

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["offset_warnings", "tare_and_find_windows"]


def _windows(tared: Tared, cond: npt.NDArray[np.int8], smooth: float, quantum: float,
             settings: AnalysisSettings) -> pd.DataFrame:
    f = tared.forces
    return find_windows(f.t, f.normal, f.tangential, cond, smooth_s=smooth,
                        min_window_s=settings.min_window_s, max_window_s=settings.max_window_s,
                        exclude=lift_exclusion(f.t, tared.lifted), quantum_s=quantum)


def tare_and_find_windows(aligned: AlignedForces, exc: Excitation, *, smooth: float,
                          quantum: float, tare_s: float | None, settings: AnalysisSettings,
                          calibration: Calibration | None
                          ) -> tuple[Tared, pd.DataFrame, npt.NDArray[np.float64]]:
    """Calibration and taring (:mod:`.zero_offsets`), the steady-sliding windows they give and
    the windows' amplitudes (the friction loop groups the ON windows by them).

    Parameters
    ----------
    aligned : AlignedForces
        The forces on their grid, as decoded (hum removed where it was).
    exc : Excitation
        The excitation: each grid point's condition.
    smooth, quantum : float, s
        The windows' smoothing span and quantum (:func:`~evtribo.analysis.friction.windows.
        find_windows`).
    tare_s : float or None, s
        How long the sidecar says the finger was lifted at the start.
    settings : AnalysisSettings
    calibration : Calibration or None
        The rig's ``[rig.calibration]``.

    Returns
    -------
    tared : Tared
    windows : pandas.DataFrame
        :func:`~evtribo.analysis.friction.windows.find_windows`' table, means from the tared forces.
    amplitudes : ndarray, V
        Each window's amplitude.
    """
    mode = settings.tare
    cal = calibration or Calibration()
    tared = calibrate(aligned, cal if mode != "none" else
                      Calibration(matrix=cal.matrix))
    if mode in ("auto", "lifted"):
        tared = tare_lifted(tared, min_s=settings.min_lift_s)
        if not tared.lifted and tare_s:
            emit("no-lift", tare_s=tare_s)
    w = _windows(tared, exc.condition, smooth, quantum, settings)
    amps = window_amplitudes(w, exc)
    if mode in ("auto", "friction-loop") and not w.empty:
        groups = [None if c != "on" else ("on" if not np.isfinite(a) else a)
                  for c, a in zip(w.condition, amps, strict=True)]
        loop = friction_loop_offset(tared.forces.t, tared.forces.normal,
                                    tared.forces.tangential, w, groups,
                                    max_knots=2 if tared.lifted else None)
        if loop is not None and not tared.lifted:
            # the same windows (found with relative thresholds, which an offset does not
            # move), their means from the corrected forces
            tared = tare_loop(tared, loop)
            w = with_means(w, tared.forces.normal, tared.forces.tangential)
        elif loop is not None and loop.significant:
            # the lifted finger measured the zero: what is left between the directions is
            # the finger's own (posture, the ridges' direction), compared direction by
            # direction in the estimate, not taken out as an offset
            level = float(np.mean(w.friction_force_N))
            log.info("forward and backward friction differ by %.1f mN (%.0f %% of %.3f N), "
                     "with the zero measured with the finger lifted", 2e3 * np.mean(
                         loop.offset_N), 200 * abs(np.mean(loop.offset_N)) / level, level)
        elif not tared.lifted and cal.tangential_offset_N is None:
            emit("tangential-zero")
            w, amps = _like_with_like(w, amps)
    if mode != "none" and not tared.normal_known:
        fn = float(np.nanmean(w.normal_force_N)) if len(w) else float(
            np.nanmedian(tared.forces.normal))
        emit("normal-zero", change_pct=1.0 / fn, normal_N=fn)
    return tared, w, amps


def _like_with_like(w: pd.DataFrame, amps: npt.NDArray[np.float64]
                    ) -> tuple[pd.DataFrame, npt.NDArray[np.float64]]:
    """The windows without the ON windows that slid in a direction none of the OFF windows
    did, when the tangential cell's zero is unknown.

    An unknown offset ``o`` of the tangential cell adds to the friction in one direction and
    subtracts in the other. Where both directions are under one condition the reference
    model's direction term takes it (:mod:`evtribo.analysis.friction.reference`); where the
    OFF windows all slid one way, an ON window that slid the other way differs from them by
    ``2 o`` besides the voltage's effect, and nothing in the trial tells the two apart (with
    ``o`` of 20 mN and ``mu`` of 0.5, F_el is 80 mN off). Such windows are left out, and
    said. A trial without OFF windows is compared with other trials' (whose zeros are their
    own): its windows stay.
    """
    on = (w.condition == "on").to_numpy()
    d = w.direction.to_numpy()
    if on.all():  # compared with other trials' OFF windows, whose zeros are their own
        return w, amps
    alien = on & ~np.isin(d, d[~on])
    if not alien.any():
        return w, amps
    way = "forwards" if int(d[~on][0]) > 0 else "backwards"
    emit("directions-confounded", left=int(alien.sum()), on=int(on.sum()), way=way)
    keep = ~alien
    return w.loc[keep].reset_index(drop=True), amps[keep]


def offset_warnings(tared: Tared, w: pd.DataFrame, offsets: tuple[float | None, float | None]
                    ) -> None:
    """Say offsets large against the forces measured (``offset``), and zeros that drifted
    beyond the noise (``zero-drift``).

    Parameters
    ----------
    tared : Tared
    w : pandas.DataFrame
        The windows.
    offsets : (float or None, float or None), N
        The offsets removed from the normal and the tangential cell.
    """
    if w.empty:
        return
    scale = {"normal": float(np.mean(w.normal_force_N)),
             "tangential": float(np.mean(w.friction_force_N))}
    for name, value in zip(("normal", "tangential"), offsets, strict=True):
        if value is not None and scale[name] > 0 and abs(value) > 0.1 * scale[name]:
            emit("offset", cell=name, offset_mN=1e3 * value,
                 share_pct=100 * abs(value) / scale[name], force_N=scale[name])
    if len(tared.lifted) < 2:
        return
    first, last = tared.lifted[0], tared.lifted[-1]
    for name, se_name in (("normal", "normal_se_N"), ("tangential", "tangential_se_N")):
        moved = getattr(last, f"{name}_N") - getattr(first, f"{name}_N")
        noise = 3 * float(np.hypot(getattr(first, se_name), getattr(last, se_name)))
        if abs(moved) > max(noise, 0.01 * scale["normal"]):
            emit("zero-drift", cell=name, drift_mN=1e3 * moved,
                 first_s=first.t_mid - tared.forces.t[0], last_s=last.t_mid - tared.forces.t[0],
                 noise_mN=1e3 * noise / 3)


