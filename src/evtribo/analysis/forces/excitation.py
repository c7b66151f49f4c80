"""What a trial's excitation was, and when it was on: from the amplifier's status signals when
the rig broadcasts them (what was applied), else from the sidecar (what was intended)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.conditions import condition_from_excitation, constant_condition
from evtribo.canlog.signals import FALLBACK_WAVEFORMS, ExcitationSignals, TrialSignals
from evtribo.errors import AnalysisError
from evtribo.util.docstrings import fill_doc
from evtribo.util.median import median
from evtribo.warning.collect import emitter

emit = emitter(__name__)


def waveform_names(values: npt.ArrayLike) -> list[str]:
    """Waveform names of status values.

    Parameters
    ----------
    values : array-like
        Names (as the decoder gives them: the DBC's value table), or codes, read through
        :data:`evtribo.canlog.signals.FALLBACK_WAVEFORMS`; None and NaN (a frame without the signal)
        are left out.

    Returns
    -------
    list of str
    """
    out = []
    for v in np.asarray(values, dtype=object).ravel():
        if isinstance(v, bytes | str):
            out.append(v.decode() if isinstance(v, bytes) else str(v))
        elif v is not None and np.isfinite(float(v)):
            out.append(FALLBACK_WAVEFORMS.get(int(v), str(int(v))))
    return out


def excitation_summary(exc: ExcitationSignals, on_mask: npt.NDArray[np.bool_]
                       ) -> dict[str, Any]:
    """Waveform (most common), frequency and amplitude (medians) while the voltage is on.

    Parameters
    ----------
    exc : ExcitationSignals
        The amplifier's status.
    on_mask : ndarray of bool
        Which of its frames say the voltage is on.

    Returns
    -------
    dict
        ``amplitude_V``, ``frequency_Hz``, ``waveform``: those the signals tell.
    """
    out: dict[str, Any] = {}
    if not on_mask.any():
        return out
    for key, values in (("amplitude_V", exc.amplitude), ("frequency_Hz", exc.frequency)):
        if values is not None:
            arr = np.asarray(values, dtype=np.float64)[on_mask]
            arr = arr[np.isfinite(arr)]
            if arr.size:
                out[key] = float(np.median(arr))
    if exc.waveform is not None:
        names = waveform_names(np.asarray(exc.waveform, dtype=object)[on_mask])
        if names:
            out["waveform"] = Counter(names).most_common(1)[0][0]
    return out


def same_value(a: Any, b: Any) -> bool:
    """Whether a sidecar's value and the signals' agree (numbers to 0.1 %).

    Parameters
    ----------
    a, b : object
        The two values.

    Returns
    -------
    bool
    """
    if isinstance(a, float) or isinstance(b, float):
        return bool(np.isclose(float(a), float(b), rtol=1e-3, atol=1e-6))
    return bool(a == b)


@dataclass
class Excitation:
    """What the trial's excitation was, and when it was on."""

    info: dict[str, Any]
    condition: npt.NDArray[np.int8]
    t: npt.NDArray[np.float64] | None = None
    enabled: npt.NDArray[np.bool_] | None = None
    amplitude: npt.NDArray[np.float64] | None = None


@fill_doc
def excitation_of(signals: TrialSignals, given: dict[str, Any],
                  grid_t: npt.NDArray[np.float64], guard_s: float) -> Excitation:
    """The condition of every grid point and the trial's waveform, frequency, amplitude; a
    disagreement between the sidecar and the signals is said (``sidecar-signals``).

    Parameters
    ----------
    signals : TrialSignals
        The decoded trial; its excitation signals, when the rig has them, are what was
        applied.
    given : dict
        The sidecar's ``waveform``, ``frequency_Hz``, ``amplitude_V``, ``condition``: used
        without excitation signals.
    grid_t : ndarray of float64
        The times of the forces' grid, s.
    guard_s : float
        Time after each switch that belongs to neither condition, s.

    Returns
    -------
    Excitation

    Raises
    ------
    AnalysisError
        No excitation signals, and the sidecar says the trial alternates or gives no
        condition.
    """
    info = dict(given)
    exc = signals.excitation
    if exc is not None and len(exc.t) and exc.enabled is not None:
        exc_t = np.asarray(exc.t, dtype=np.float64)
        enabled = np.asarray(exc.enabled).astype(bool)
        cond = condition_from_excitation(grid_t, exc_t, enabled, guard_s=guard_s)
        observed = {"condition": "alternating" if enabled.any() and not enabled.all()
                    else "on" if enabled.all() else "off"}
        observed.update(excitation_summary(exc, enabled))
        for key, value in observed.items():
            said = info.get(key)
            if said is not None and not same_value(said, value):
                emit("sidecar-signals", key=key, sidecar=said, signals=value)
            info[key] = value
        return Excitation(info, cond, exc_t, enabled,
                          None if exc.amplitude is None
                          else np.asarray(exc.amplitude, dtype=np.float64))
    if info["condition"] in ("on", "off"):
        return Excitation(info, constant_condition(grid_t.size, info["condition"]))
    if info["condition"] == "alternating":
        raise AnalysisError("the sidecar says the trial alternates, but the rig has no "
                            "excitation signals to tell ON from OFF")
    raise AnalysisError("the trial's condition is unknown: the rig has no excitation "
                        "signals and the sidecar gives no 'condition'")


def window_amplitudes(w: pd.DataFrame, exc: Excitation) -> npt.NDArray[np.float64]:
    """Amplitude of each window.

    Parameters
    ----------
    w : pandas.DataFrame
        The windows (``condition``, ``t_start``, ``t_end``).
    exc : Excitation
        The trial's excitation.

    Returns
    -------
    ndarray of float64
        0 for OFF; for ON, the amplitude reported during the window (which follows an
        amplitude sweep inside a trial), else the sidecar's (NaN when unknown), V.
    """
    amplitude = np.zeros(len(w))
    is_on = (w.condition == "on").to_numpy()
    if not is_on.any():
        return amplitude
    given = exc.info["amplitude_V"]
    amplitude[is_on] = np.nan if given is None else float(given)
    if exc.amplitude is not None and exc.t is not None and exc.enabled is not None:
        order = np.argsort(exc.t[exc.enabled], kind="stable")
        enabled_t = exc.t[exc.enabled][order]
        enabled_a = exc.amplitude[exc.enabled][order]
        on = np.flatnonzero(is_on)
        lo = np.searchsorted(enabled_t, w.t_start.to_numpy()[on], side="left")
        hi = np.searchsorted(enabled_t, w.t_end.to_numpy()[on], side="right")
        for k, a, b in zip(on, lo, hi, strict=True):
            if b > a:
                amplitude[k] = median(enabled_a[a:b])
    return amplitude


__all__ = ["Excitation", "excitation_of", "excitation_summary", "same_value",
           "waveform_names", "window_amplitudes"]
