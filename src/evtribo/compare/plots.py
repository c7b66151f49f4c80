"""Figures comparing the model with the measurements (the seed paper's Figures 5-7).

Every ``plot_*`` function draws on the Axes it is given (``ax=None`` makes a new figure) and
returns the Axes, like lmfit's ``plot_fit``. Figures are built with
:class:`matplotlib.figure.Figure` directly (no pyplot state), so they render with the Agg
canvas on a machine without a display.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import cast

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from evtribo.compare.model_points import mean_electrostatic_force, mean_friction_force
from evtribo.files import atomic_open
from evtribo.model import (
    area_increase_pct,
    friction_force,
    friction_time_series,
    sine_voltage,
)
from evtribo.model.params import TABLE_1, ModelParameters

log = logging.getLogger(__name__)

__all__ = ["new_axes", "plot_area_increase", "plot_electrostatic_force",
           "plot_friction_normal_force", "plot_friction_time", "safe_name", "save_figure",
           "trace_voltage"]

_WAVE_MARKERS = {"square": "o", "sine": "s"}


def safe_name(name: str) -> str:
    """*name* reduced to letters, digits, ``-`` and ``_`` (for file names).

    Parameters
    ----------
    name : str
        A subject's name, say.

    Returns
    -------
    str
        Every other character replaced by ``_`` (``"_"`` for an empty name).
    """
    return re.sub(r"[^A-Za-z0-9_-]", "_", str(name)) or "_"


def new_axes(figsize: tuple[float, float] = (5.0, 3.6)) -> Axes:
    """A fresh Axes on its own Agg-backed figure (no pyplot state).

    Parameters
    ----------
    figsize : (float, float)
        The figure's size, inches.

    Returns
    -------
    Axes
        The figure's one Axes.
    """
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig.add_subplot()


def save_figure(fig: Figure, folder: str | Path, stem: str, *, dpi: float = 150,
                formats: Sequence[str] = ("png", "svg")) -> list[Path]:
    """Write *fig* as ``folder/stem.<format>`` for each format, without a creation date
    (the same data give byte-identical files).

    Parameters
    ----------
    fig : Figure
        The figure.
    folder : str or Path
        Where the files go (created if missing).
    stem : str
        The files' name without suffix.
    dpi : float
        Resolution of raster formats, dots per inch.
    formats : sequence of str
        Suffixes matplotlib knows (``png``, ``svg``, ``pdf``...).

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for fmt in formats:
        path = folder / f"{stem}.{fmt}"
        with atomic_open(path, "wb") as fh:  # a killed process leaves no half figure
            fig.savefig(fh, dpi=dpi, format=fmt, metadata=_metadata(fmt))
        paths.append(path)
    return paths


def _metadata(fmt: str) -> dict[str, str | None]:
    # no creation date: the same data give byte-identical files
    if fmt == "svg":
        return {"Date": None}
    if fmt == "pdf":
        return {"CreationDate": None}
    return {}


def plot_electrostatic_force(rows: pd.DataFrame, params: ModelParameters = TABLE_1, *,
                             subject: str | None = None, ax: Axes | None = None) -> Axes:
    """Electrostatic force versus voltage amplitude, log-log: measured, model, U^2 guide.

    Parameters
    ----------
    rows : DataFrame
        One subject's rows of ``electrostatic.csv``.
    params : ModelParameters
        The subject's fitted parameters.
    subject : str, optional
        For the title.
    ax : Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    Axes
    """
    ax = new_axes() if ax is None else ax
    amps_all = rows["amplitude_V"].to_numpy(float)
    u_lo, u_hi = np.nanmin(amps_all) / 1.25, np.nanmax(amps_all) * 1.25
    grid = np.geomspace(u_lo, u_hi, 80)
    for k, (wave, sel) in enumerate(rows.groupby(rows["waveform"].astype(str), sort=True)):
        amp = sel["amplitude_V"].to_numpy(float)
        f = sel["electrostatic_force_N"].to_numpy(float)
        lo = np.clip(f - sel["electrostatic_force_ci_low_N"].to_numpy(float), 0, None)
        hi = np.clip(sel["electrostatic_force_ci_high_N"].to_numpy(float) - f, 0, None)
        color = f"C{k}"
        ax.errorbar(amp, f, yerr=np.vstack([lo, hi]), fmt=_WAVE_MARKERS.get(wave, "D"),
                    color=color, capsize=3, label=f"measured ({wave}, 95 % CI)")
        fn = float(np.nanmean(sel["normal_force_on_N"].to_numpy(float)))
        ax.plot(grid, mean_electrostatic_force(fn, grid, wave, params), "-", color=color,
                label=f"model ({wave}, F_n = {fn:.2g} N)")
        pos = f > 0
        if pos.any():  # U^2 through the points' geometric centre
            centre_u = np.exp(np.mean(np.log(amp[pos])))
            centre_f = np.exp(np.mean(np.log(f[pos])))
            ax.plot(grid, centre_f * (grid / centre_u) ** 2, ":", color="0.4",
                    label="∝ U² guide" if k == 0 else None)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("voltage amplitude U (V)")
    ax.set_ylabel("electrostatic force F_el (N)")
    ax.set_title(f"Electrostatic force, {subject}" if subject else "Electrostatic force")
    ax.legend(fontsize="small")
    return ax


def plot_friction_normal_force(windows: pd.DataFrame, params: ModelParameters = TABLE_1, *,
                               subject: str | None = None, ax: Axes | None = None) -> Axes:
    """Friction versus normal force, OFF and ON: measured windows and the model (Figure 6).

    Parameters
    ----------
    windows : DataFrame
        Rows of ``windows.csv`` (one subject's, or several).
    params : ModelParameters
        Model parameters (``mu`` from the measured OFF windows unless fitted).
    subject : str, optional
        For the title.
    ax : Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    Axes
    """
    ax = new_axes((7.6, 3.8)) if ax is None else ax  # room for the legend on the right
    fn = windows["normal_force_N"].to_numpy(float)
    top = float(np.nanmax(fn)) * 1.15 if fn.size and np.isfinite(fn).any() else 1.0
    grid = np.linspace(0.02 * top, top, 60)
    cond = windows["condition"].astype(str).str.lower()
    off = windows[cond == "off"]
    ax.plot(off["normal_force_N"], off["friction_force_N"], "o", color="C2", alpha=0.7,
            label="measured OFF")
    ax.plot(grid, mean_friction_force(grid, 0.0, "square", params), "-", color="C2",
            label=f"model OFF (μ = {params.mu:.3g})")
    on = windows[cond == "on"]
    keys = on.groupby([on["waveform"].astype(str), on["amplitude_V"]], sort=True)
    for k, (key, sel) in enumerate(keys):
        wave, amp = cast(tuple[str, float], key)  # (waveform, amplitude), as grouped
        color = f"C{(k % 8) + 3}" if k else "C1"
        ax.plot(sel["normal_force_N"], sel["friction_force_N"], _WAVE_MARKERS.get(wave, "D"),
                color=color, alpha=0.7, label=f"measured ON {amp:g} V {wave}")
        ax.plot(grid, mean_friction_force(grid, amp, wave, params),
                ":" if wave == "sine" else "--", color=color, label=f"model ON {amp:g} V {wave}")
    ax.set_xlabel("normal force F_n (N)")
    ax.set_ylabel("friction force F_t (N)")
    ax.set_title(f"Friction vs normal force, {subject}" if subject
                 else "Friction vs normal force")
    ax.set_xlim(0, top)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.02, 1.0),
              borderaxespad=0.0)
    return ax


def trace_voltage(trace: pd.DataFrame, params: ModelParameters = TABLE_1,
                  n_phases: int = 90) -> NDArray[np.float64]:
    """Instantaneous voltage U(t) of a sine trace, V.

    ``voltage_V`` when the trace has it; otherwise A(t) sin(2 pi f t + phi) from
    ``amplitude_V`` and ``frequency_Hz``, with the phase phi in [0, pi) that best matches the
    measured friction (the model's friction depends on U^2, so phi + pi gives the same).

    Parameters
    ----------
    trace : DataFrame
        Rows of ``sine_trace.csv`` (one trial).
    params : ModelParameters
        Model parameters for matching the phase.
    n_phases : int
        Phases tried.

    Returns
    -------
    ndarray
        U(t) at the trace's rows, V.
    """
    if "voltage_V" in trace.columns:
        return trace["voltage_V"].to_numpy(float)
    t = trace["time_s"].to_numpy(float)
    amp = np.nan_to_num(trace["amplitude_V"].to_numpy(float))
    freq = np.nan_to_num(trace["frequency_Hz"].to_numpy(float))
    fn = trace["normal_force_N"].to_numpy(float)
    ft = trace["friction_force_N"].to_numpy(float)
    phases = np.linspace(0.0, np.pi, n_phases, endpoint=False)
    u = amp[None, :] * np.sin(2 * np.pi * freq[None, :] * t[None, :] + phases[:, None])
    model = np.asarray(friction_force(fn[None, :], u, params), dtype=float)
    err = np.nansum((model - ft[None, :]) ** 2, axis=1)
    return u[int(np.argmin(err))]


def plot_friction_time(trace: pd.DataFrame | None, params: ModelParameters = TABLE_1, *,
                       amplitude: float = 140.0, frequency: float = 10.0,
                       normal_force: float = 0.5, subject: str | None = None,
                       ax: Axes | None = None) -> Axes:
    """Friction versus time during a sine drive, measured and model (Figure 5).

    With a measured trace (``sine_trace.csv``), the model is evaluated at its normal force
    and voltage sample by sample. Without one the model alone is drawn for the paper's
    conditions (*amplitude*, *frequency*, constant *normal_force*), ON and OFF, and the
    Axes says so.

    Parameters
    ----------
    trace : DataFrame or None
        Columns ``time_s``, ``normal_force_N``, ``friction_force_N``, ``voltage_V``.
    params : ModelParameters
        Model parameters.
    amplitude, frequency : float
        Drive for the model-only figure, V and Hz.
    normal_force : float
        Normal force for the model-only figure, N.
    subject : str, optional
        For the title.
    ax : Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    Axes
    """
    ax = new_axes((6.0, 3.6)) if ax is None else ax
    if trace is not None and len(trace):
        t = trace["time_s"].to_numpy(float)
        fn = trace["normal_force_N"].to_numpy(float)
        u = trace_voltage(trace, params)
        fitted_phase = "voltage_V" not in trace.columns
        ax.plot(t, fn, "-", color="C2", lw=1, label="normal force (measured)")
        # the model underneath, wide and pale, so that the measured trace stays visible
        ax.plot(t, friction_time_series(t, fn, u, params), "-", color="C3", lw=3.5, alpha=0.45,
                label="friction (model, drive phase fitted)" if fitted_phase
                else "friction (model)")
        ax.plot(t, friction_time_series(t, fn, np.zeros_like(t), params), "--", color="C0",
                lw=1, label="friction (model, OFF)")
        ax.plot(t, trace["friction_force_N"].to_numpy(float), "-", color="k", lw=0.8,
                label="friction (measured)")
        title = "Friction vs time, sine drive"
    else:
        t = np.linspace(0.0, 3.0 / frequency, 600)
        fn = np.full_like(t, normal_force)
        ax.plot(t, fn, "-", color="C2", lw=1, label="normal force")
        ax.plot(t, friction_time_series(t, fn, sine_voltage(t, amplitude, frequency), params),
                "-", color="C3", lw=1.2, label=f"model ON ({amplitude:g} V, {frequency:g} Hz)")
        ax.plot(t, friction_time_series(t, fn, np.zeros_like(t), params), "-", color="C0",
                lw=1.2, label="model OFF")
        ax.text(0.02, 0.5, "model only: no measured sine trace\n(sine_trace.csv absent)",
                transform=ax.transAxes, fontsize="small", color="C3", va="center")
        title = "Friction vs time, sine drive (model only)"
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("force (N)")
    ax.set_title(f"{title}, {subject}" if subject else title)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="x-small", loc="lower right")
    return ax


def plot_area_increase(normal_forces: Mapping[str, float],
                       params: Mapping[str, ModelParameters], *, u_max: float = 150.0,
                       ax: Axes | None = None) -> Axes:
    """Predicted increase of the contact area versus voltage amplitude (Figure 7).

    Parameters
    ----------
    normal_forces : mapping
        ``{label: normal force in N}``, e.g. each subject's mean normal force ON.
    params : mapping
        ``{label: ModelParameters}`` with the same keys.
    u_max : float
        Largest voltage amplitude drawn, V.
    ax : Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    Axes
    """
    ax = new_axes() if ax is None else ax
    u = np.linspace(0.0, u_max, 120)
    for k, (label, fn) in enumerate(normal_forces.items()):
        ax.plot(u, area_increase_pct(fn, u, params[label]), color=f"C{k % 10}",
                label=f"{label} (F_n = {fn:.2g} N)")
    ax.set_xlabel("voltage amplitude U (V)")
    ax.set_ylabel("contact area increase (%)")
    ax.set_title("Predicted contact-area increase (JKR vs Hertz)")
    ax.set_xlim(0, u_max)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="small")
    return ax
