"""evtribo's own figures, one :class:`~evtribo.figures.registry.spec.FigureSpec` per kind, in
the order compare draws them (:data:`BUILTIN`): each trial's check, every subject's
electrostatic force, each subject's force and friction against the normal force, friction
against time, the predicted contact-area increase, the population per condition, and F_el
against the drive's frequency per subject. The plot functions are those of the figure
modules (:mod:`evtribo.figures.plots`, :mod:`~evtribo.figures.population_plots`,
:mod:`~evtribo.figures.frequency_plots`, :mod:`~evtribo.figures.trial_plots`); each spec
says what it draws them from.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from evtribo.figures.frequency_plots import plot_frequency_response
from evtribo.figures.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_electrostatic_force_all,
    plot_friction_normal_force,
    plot_friction_time,
)
from evtribo.figures.population_plots import plot_population, population_caption
from evtribo.figures.registry.spec import Drawing, FigureContext, FigureSpec
from evtribo.figures.trial_checks import CheckFigure
from evtribo.figures.trial_plots import draw_failed, draw_trial_check
from evtribo.fit.fit import SubjectFit
from evtribo.fit.model_comparison import MIN_FREQUENCIES, frequencies_of
from evtribo.fit.tables import ResultTables
from evtribo.model.params import TABLE_1
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

emit = emitter(__name__)

__all__ = ["BUILTIN", "PAPER"]

#: The citation of the model's paper, for captions.
PAPER = ("Voltage-Induced Friction with Application to Electrovibration, Lubricants 2019, "
         "7(12), 102, doi:10.3390/lubricants7120102")


def _check(ctx: FigureContext, c: CheckFigure) -> Drawing:
    """A trial's check, or the figure saying why it was not analysed."""
    if c.sketch is None:
        return Drawing(draw_failed, (c.subject, c.trial, c.error or ""))
    return Drawing(draw_trial_check, (c.sketch,))


def _all(ctx: FigureContext, _: Any) -> Drawing | None:
    if not ctx.fits:
        return None
    return Drawing(plot_electrostatic_force_all, (
        ctx.tables.electrostatic, {f.subject: f.params for f in ctx.fits}))


def _all_caption(ctx: FigureContext, _: Any) -> str:
    waves = set(ctx.tables.electrostatic["waveform"].astype(str))
    fill = " (filled markers: square drive; open: sine)" if len(waves) > 1 else ""
    return ("Inferred electrostatic force of every subject against the voltage amplitude: "
            f"points with 95 % intervals{fill}, spread by up to ±3 % in voltage so that they "
            "do not hide one another; lines: each subject's fitted model at its mean normal "
            f"force ON ({PAPER}).")


def _force(ctx: FigureContext, s: str) -> Drawing | None:
    f = ctx.fit_of(s)
    if f is None:
        return None
    rows = ctx.tables.electrostatic[ctx.tables.electrostatic["subject"] == s]
    return Drawing(plot_electrostatic_force, (rows, f.params), {"subject": s})


def _friction(ctx: FigureContext, s: str) -> Drawing | None:
    """A subject's friction against the normal force: with its fitted model, or, in a
    study of OFF trials, the line of its μ."""
    windows = ctx.tables.windows
    if ctx.only_mu:
        win = windows[windows["subject"].astype(str) == s]
        return Drawing(plot_friction_normal_force, (win, TABLE_1.with_values(mu=ctx.mu[s])),
                       {"subject": s})
    f = ctx.fit_of(s)
    if f is None:
        return None
    return Drawing(plot_friction_normal_force, (windows[windows["subject"] == s], f.params),
                   {"subject": s})


def _friction_caption(ctx: FigureContext, s: str) -> str:
    if ctx.only_mu:
        return (f"{s}: steady-sliding windows OFF (points) and F_t = μ·F_n with the "
                "subject's μ, the ratio of means of those windows (line).")
    mu_how = "fitted." if "mu" in ctx.names else "from the measured OFF windows."
    return (f"{s}: steady-sliding windows OFF and ON (points) and the model (lines, eq. 5, "
            "cf. the paper's Figure 6) over the normal forces each drive's windows span; "
            f"axes zoomed to the windows; μ {mu_how}")


def _first_trace(tables: ResultTables) -> tuple[pd.DataFrame | None, str | None]:
    """The first trial of ``sine_trace.csv`` (when it holds several) and its subject."""
    trace = tables.sine_trace
    if trace is None or trace.empty:
        return None, None
    for col in ("subject", "trial"):
        if col in trace.columns:
            trace = trace[trace[col].astype(str) == str(trace[col].iloc[0])]
    subject = str(trace["subject"].iloc[0]) if "subject" in trace.columns else None
    return trace, subject


def _traced(ctx: FigureContext) -> SubjectFit | None:
    """The fit of the subject whose sine trial is drawn (the first fit if none is)."""
    _, subject = _first_trace(ctx.tables)
    return ctx.fit_of(subject or "") or next(iter(ctx.fits), None)


def _time(ctx: FigureContext, _: Any) -> Drawing | None:
    """Friction against time: the measured sine trial and the model along it."""
    trace, _subject = _first_trace(ctx.tables)
    elec = ctx.tables.electrostatic
    sine_rows = elec[elec["waveform"].astype(str) == "sine"]
    amp = float(sine_rows["amplitude_V"].max()) if not sine_rows.empty else 140.0
    pick = _traced(ctx)
    if pick is None:
        return None
    return Drawing(plot_friction_time, (trace, pick.params), {
        "amplitude": amp, "normal_force": float(np.nanmean(
            elec["normal_force_on_N"].to_numpy(float))), "subject": pick.subject})


def _time_caption(ctx: FigureContext, _: Any) -> str:
    trace, _subject = _first_trace(ctx.tables)
    voltage = ("measured voltage" if trace is not None and "voltage_V" in trace.columns else
               "drive's amplitude and frequency (its phase, which the rig does not record, "
               "chosen to match the measured friction)")
    pick = _traced(ctx)
    return (f"Measured sine trial of {pick.subject if pick else '?'} and the model evaluated "
            f"at its measured normal force and the {voltage}, cf. the paper's Figure 5.")


def _no_trace(ctx: FigureContext) -> WarningRecord | None:
    return None if ctx.only_mu else emit.record("sine-trace-none")


def _area(ctx: FigureContext, _: Any) -> Drawing | None:
    """The contact-area increase the fitted model predicts, at each subject's mean
    normal force ON."""
    if not ctx.fits:
        return None
    elec = ctx.tables.electrostatic
    mean_fn = {f.subject: float(np.nanmean(elec.loc[elec["subject"] == f.subject,
                                                    "normal_force_on_N"].to_numpy(float)))
               for f in ctx.fits}
    amps = elec["amplitude_V"].to_numpy(float)
    return Drawing(plot_area_increase, (mean_fn, {f.subject: f.params for f in ctx.fits}), {
        "u_max": max(150.0, float(np.nanmax(amps))),
        "amplitudes": sorted(set(amps[np.isfinite(amps)].tolist()))})


def _population(ctx: FigureContext, condition: Any) -> Drawing | None:
    if ctx.population is None:
        return None
    return Drawing(plot_population, (ctx.tables.electrostatic, ctx.population, condition))


def _population_caption(ctx: FigureContext, condition: Any) -> str:
    return "" if ctx.population is None else population_caption(ctx.population, condition)


def _rows(ctx: FigureContext, s: str) -> pd.DataFrame:
    elec = ctx.tables.electrostatic
    return elec[elec["subject"].astype(str) == s]


def _swept(ctx: FigureContext) -> list[str]:
    """The subjects with a drive measured at several frequencies."""
    return [s for s in ctx.subjects if frequencies_of(_rows(ctx, s)) >= MIN_FREQUENCIES]


def _response(ctx: FigureContext, s: str) -> Drawing:
    mine = [f for f in ctx.model_fits if f.subject == s]
    return Drawing(plot_frequency_response, (_rows(ctx, s), mine), {"subject": s})


def _fitted(ctx: FigureContext) -> bool:
    return not ctx.only_mu


#: evtribo's figures, in the order compare draws them.
BUILTIN = (
    FigureSpec("trial", "trial_{subject}_{trial}", "{subject} / {trial}",
               lambda ctx, c: str(c.caption), "checks", "trial", _check, needs="fits",
               screen=True, told="check of {subject}/{trial}"),
    FigureSpec("electrostatic_force_all", "electrostatic_force_all",
               "Electrostatic force vs voltage, all subjects", _all_caption, "all", "study",
               _all, needs="fits", when=_fitted),
    FigureSpec("electrostatic_force", "electrostatic_force_{subject}",
               "Electrostatic force vs voltage, {subject}",
               "{subject}: inferred electrostatic force (points, 95 % intervals) and the "
               "fitted model (lines) at the subject's mean normal force ON, over the "
               "amplitudes measured.", "subject", "subject", _force, needs="fits",
               when=_fitted, grid=(
                   "Electrostatic force vs voltage, each subject",
                   "Each subject's inferred electrostatic force (points, 95 % intervals) and "
                   "its fitted model (lines) at its mean normal force ON, over the amplitudes "
                   "measured.")),
    FigureSpec("friction_normal_force", "friction_normal_force_{subject}",
               "Friction vs normal force, {subject}", _friction_caption, "subject", "subject",
               _friction, needs="fits", grid=(
                   "Friction vs normal force, each subject",
                   "Each subject's steady-sliding windows OFF and ON (points) and the model "
                   "(lines, eq. 5) over the normal forces each drive's windows span; axes "
                   "zoomed to the windows.")),
    FigureSpec("friction_time", "friction_time", "Friction vs time, sine drive", _time_caption,
               "all", "study", _time, needs="fits",
               when=lambda ctx: _fitted(ctx) and _first_trace(ctx.tables)[0] is not None,
               why_not=_no_trace),
    FigureSpec("area_increase", "area_increase", "Predicted contact-area increase",
               "A prediction of the model, nothing measured: JKR over Hertz contact area at "
               "each subject's mean normal force ON with the fitted parameters, cf. the "
               "paper's Figure 7.", "predictions", "study", _area, needs="fits", when=_fitted),
    FigureSpec("population", "population_{condition}", "The population, {condition}",
               _population_caption, "population", "condition", _population,
               needs="population", when=_fitted),
    FigureSpec("frequency_response", "frequency_response_{subject}",
               "Electrostatic force vs drive frequency, {subject}",
               "Inferred electrostatic force (points, 95 % intervals) against the drive's "
               "frequency, one colour and marker per drive, and each candidate model fitted "
               "to the subject's points (models.csv; one line style per model, in each "
               "drive's colour), at the points' mean normal force ON.", "models", "subject",
               _response, needs="models", when=lambda ctx: _fitted(ctx) and bool(ctx.models),
               items=_swept),
)
