"""What a trial's excitation was, and when it was on: from the amplifier's status signals when
the rig broadcasts them (what was applied), else from the sidecar (what was intended)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.conditions import condition_from_excitation, constant_condition
from evtribo.errors import AnalysisError

_WAVE_CODES = {0: "sine", 1: "square", 2: "triangle", 3: "dc"}


def get_field(obj: Any, name: str, default: Any = None) -> Any:
    """``obj.name``, or *default* when *obj* is None or has no such attribute."""
    return getattr(obj, name, default) if obj is not None else default


def waveform_names(values: npt.ArrayLike) -> list[str]:
    """Waveform names of status values: strings as they are, codes through the value table
    of the default rig's DBC (0 sine, 1 square, 2 triangle, 3 dc)."""
    out = []
    for v in np.asarray(values, dtype=object).ravel():
        if isinstance(v, bytes | str):
            out.append(v.decode() if isinstance(v, bytes) else str(v))
        elif v is not None and np.isfinite(float(v)):
            out.append(_WAVE_CODES.get(int(v), str(int(v))))
    return out


def excitation_summary(exc: Any, on_mask: npt.NDArray[np.bool_]) -> dict[str, Any]:
    """Waveform (most common), frequency and amplitude (medians) while the voltage is on."""
    out: dict[str, Any] = {}
    if not on_mask.any():
        return out
    for key, name in (("amplitude_V", "amplitude"), ("frequency_Hz", "frequency")):
        values = get_field(exc, name)
        if values is not None:
            arr = np.asarray(values, dtype=np.float64)[on_mask]
            arr = arr[np.isfinite(arr)]
            if arr.size:
                out[key] = float(np.median(arr))
    waves = get_field(exc, "waveform")
    if waves is not None:
        names = waveform_names(np.asarray(waves, dtype=object)[on_mask])
        if names:
            out["waveform"] = Counter(names).most_common(1)[0][0]
    return out


def same_value(a: Any, b: Any) -> bool:
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


def excitation_of(signals: Any, given: dict[str, Any], grid_t: npt.NDArray[np.float64],
                guard_s: float, warn: Callable[[str], None]) -> Excitation:
    """The condition of every grid point and the trial's waveform, frequency, amplitude:
    from the excitation signals when the rig has them, else as *given* (the sidecar's
    ``waveform``, ``frequency_Hz``, ``amplitude_V``, ``condition``); a disagreement between
    the two is passed to *warn*."""
    info = dict(given)
    exc = get_field(signals, "excitation")
    exc_t = get_field(exc, "t")
    if exc is not None and exc_t is not None and len(exc_t) and exc.enabled is not None:
        exc_t = np.asarray(exc_t, dtype=np.float64)
        enabled = np.asarray(exc.enabled).astype(bool)
        cond = condition_from_excitation(grid_t, exc_t, enabled, guard_s=guard_s)
        observed = {"condition": "alternating" if enabled.any() and not enabled.all()
                    else "on" if enabled.all() else "off"}
        observed.update(excitation_summary(exc, enabled))
        for key, value in observed.items():
            given = info.get(key)
            if given is not None and not same_value(given, value):
                warn(f"the sidecar says {key} = {given!r} but the excitation signals say "
                     f"{value!r}; using the signals")
            info[key] = value
        amp = get_field(exc, "amplitude")
        return Excitation(info, cond, exc_t, enabled,
                           None if amp is None else np.asarray(amp, dtype=np.float64))
    if info["condition"] in ("on", "off"):
        return Excitation(info, constant_condition(grid_t.size, info["condition"]))
    if info["condition"] == "alternating":
        raise AnalysisError("the sidecar says the trial alternates, but the rig has no "
                            "excitation signals to tell ON from OFF")
    raise AnalysisError("the trial's condition is unknown: the rig has no excitation "
                        "signals and the sidecar gives no 'condition'")


def window_amplitudes(w: pd.DataFrame, exc: Excitation) -> npt.NDArray[np.float64]:
    """Amplitude of each window (0 for OFF; the amplitude reported during an ON window,
    which follows an amplitude sweep inside a trial), V."""
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
                amplitude[k] = float(np.median(enabled_a[a:b]))
    return amplitude


__all__ = ["Excitation", "excitation_of", "excitation_summary", "get_field", "same_value",
           "waveform_names", "window_amplitudes"]
