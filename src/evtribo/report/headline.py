"""The answer of a study, as tables for people: what the report leads with and exports.

- :func:`force_table`: the inferred electrostatic force F_el in mN with its 95 % interval, one
  row per subject x waveform x frequency and one column per amplitude;
- :func:`fit_summary`: per subject, the fitted parameters in readable units (air gap in µm),
  the measured friction coefficient, the measured and the model's power-law exponents and the
  quality of the fit, to three significant figures;
- :func:`parameter_roles`: every parameter of the model, and whether it was measured, fixed
  (and from where) or fitted;
- :func:`model_comparison`: one subject's rows of ``models.csv``;
- :func:`friction_table`: each subject's friction coefficient, for results without any
  electrostatic force (a study of OFF trials).

Each returns a :class:`Headline` whose cells are text (:mod:`evtribo.util.numbers`), so the
HTML page and the Markdown and LaTeX exports print the same numbers.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import pandas as pd

from evtribo.documents.fit import FitDocument
from evtribo.figures.friction_only import subject_mu
from evtribo.fit.models import INDISTINGUISHABLE, study_ranking, verdict
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.numbers import (
    PREFIXES,
    auto_prefix,
    frequency,
    quantity,
    r_squared,
    significant,
    to_float,
    voltage,
    with_interval,
)

__all__ = ["CITATION", "DOI_URL", "F_EL_DEFINITION", "MU_COLUMN", "PARAMETER_DISPLAY",
           "Headline", "fit_summary", "force_table", "friction_table", "model_comparison",
           "model_ranking", "parameter_roles"]

#: The seed paper, cited wherever its model is named.
CITATION = ('"Voltage-Induced Friction with Application to Electrovibration", Lubricants 2019, '
            "7(12), 102, doi:10.3390/lubricants7120102")
#: Where the paper is.
DOI_URL = "https://doi.org/10.3390/lubricants7120102"

#: The inferred electrostatic force, as the README, the docs, the notebook and the report
#: state it (word for word: ``tests/test_docs.py`` checks them).
F_EL_DEFINITION = ("F_el = F_t,on/μ \u2212 F_n,on, averaged over the ON windows, with μ each ON "
                   "window's reference: the friction coefficient of the OFF windows at the "
                   "window's own time, sliding direction and stroke pace")
#: The column of the fit's table that gives each subject's μ.
MU_COLUMN = "μ (mean of its rows)"

#: How each model parameter is shown: its name for people, base unit and prefix (None: the
#: prefix that suits the value).
PARAMETER_DISPLAY: dict[str, tuple[str, str, str | None]] = {
    "mu": ("friction coefficient μ", "", ""),
    "R": ("fingertip radius R", "m", "m"),
    "E_star": ("effective modulus E*", "Pa", "k"),
    "eps_sc": ("permittivity of the stratum corneum ε_sc", "", ""),
    "eps_i": ("permittivity of the insulator ε_i", "", ""),
    "eps_L": ("permittivity of the air gap ε_L", "", ""),
    "h_sc": ("stratum corneum thickness h_sc", "m", "µ"),
    "h_i": ("insulator thickness h_i", "m", "µ"),
    "h_L": ("air gap h_L", "m", "µ"),
    "eps_0": ("vacuum permittivity ε0", "F/m", "p"),
    "r_sc": ("stratum corneum resistance r_sc", "Ω·m²", None),
    "r_g": ("air-gap leakage r_g", "Ω·m²", None),
}


@dataclass(frozen=True)
class Headline:
    """A table for people: text cells, a title, a caption and a file stem.

    Attributes
    ----------
    stem : str
        File stem of its export (``electrostatic_force``, ``fit``).
    title : str
        Its heading.
    caption : str
        What its numbers are.
    table : DataFrame
        The rows; every cell is text.
    """

    stem: str
    title: str
    caption: str
    table: pd.DataFrame


def _label(name: str) -> tuple[str, str, str | None]:
    return PARAMETER_DISPLAY.get(name, (name, "", None))


def _unit_of(name: str, value: float) -> tuple[str, float]:
    """The unit a parameter is printed in (``µm``) and the factor from SI to it."""
    _, unit, prefix = _label(name)
    if not unit:
        return "", 1.0
    p = auto_prefix(value) if prefix is None else prefix
    return f"{p}{unit}", 10.0 ** -PREFIXES[p]


def force_table(electrostatic: pd.DataFrame) -> Headline:
    """F_el in mN with its 95 % interval: a row per subject x waveform x frequency.

    Parameters
    ----------
    electrostatic : DataFrame
        ``electrostatic.csv`` (study-format §2).

    Returns
    -------
    Headline
        Columns ``Subject``, ``Waveform``, ``Frequency``, then one per amplitude (``80 V``);
        a cell reads ``26.5 [25.7, 27.4]`` (mN), ``—`` where that amplitude was not driven.
    """
    es = electrostatic.copy()
    if "frequency_Hz" not in es.columns:
        es["frequency_Hz"] = math.nan
    es["_wf"] = es["waveform"].fillna("").astype(str)
    amps = sorted({float(a) for a in es["amplitude_V"].to_numpy(float) if math.isfinite(a)})
    subjects = list(dict.fromkeys(es["subject"].astype(str)))
    rows = []
    for s in subjects:
        mine = es[es["subject"].astype(str) == s]
        for (wf, f), grp in mine.groupby(["_wf", "frequency_Hz"], sort=True, dropna=False):
            row = {"Subject": s, "Waveform": wf or "—", "Frequency": frequency(f)}
            for a in amps:
                hit = grp[grp["amplitude_V"].astype(float) == a]
                row[voltage(a)] = "—" if hit.empty else with_interval(
                    1e3 * float(hit["electrostatic_force_N"].iloc[0]),
                    1e3 * to_float(hit["electrostatic_force_ci_low_N"].iloc[0]),
                    1e3 * to_float(hit["electrostatic_force_ci_high_N"].iloc[0]))
            rows.append(row)
    columns = ["Subject", "Waveform", "Frequency", *(voltage(a) for a in amps)]
    return Headline(
        "electrostatic_force", "Electrostatic force F_el (mN) by subject and voltage",
        f"Inferred electrostatic force {F_EL_DEFINITION}. In mN: mean [95 % interval], per "
        "drive amplitude (columns); the mean μ each cell's ON windows were compared with is "
        "in its subject's table (electrostatic.csv's mu).",
        pd.DataFrame(rows, columns=columns))


def friction_table(windows: pd.DataFrame) -> Headline:
    """Each subject's friction coefficient, for results without electrostatic forces.

    Parameters
    ----------
    windows : DataFrame
        ``windows.csv``.

    Returns
    -------
    Headline
        One row per subject with OFF windows: μ (ratio of means of its OFF windows), its
        range between trials, the trials and windows it rests on, the normal forces.
    """
    mu = subject_mu(windows)
    rows = [{"Subject": r.subject, "μ": significant(r.mu),
             "μ between trials": f"{significant(r.mu_trial_min)} to "
                                 f"{significant(r.mu_trial_max)}",
             "trials": str(r.trials), "OFF windows": str(r.windows),
             "F_n (mN)": f"{significant(1e3 * r.normal_force_min_N)} to "
                         f"{significant(1e3 * r.normal_force_max_N)}"}
            for r in _rows(mu)]
    return Headline(
        "friction", "Friction coefficient μ by subject",
        "No electrostatic force: no subject has ON windows to compare with its OFF ones. μ "
        "of each subject: the ratio of means ΣF_t/ΣF_n of its steady-sliding OFF windows; "
        "between trials: the same within each trial, lowest and highest; F_n: the windows' "
        "normal forces.",
        pd.DataFrame(rows, columns=["Subject", "μ", "μ between trials", "trials",
                                    "OFF windows", "F_n (mN)"]))


def _estimate_cell(rows: pd.DataFrame, name: str) -> str:
    hit = rows[rows["parameter"].astype(str) == name]
    if hit.empty:
        return "—"
    r = hit.iloc[0]
    _, factor = _unit_of(name, to_float(r["value"]))
    return with_interval(factor * to_float(r["value"]), factor * to_float(r["ci_low"]),
                         factor * to_float(r["ci_high"]))


def _fit_header(name: str, fit: pd.DataFrame) -> str:
    label = _label(name)[0]
    values = fit.loc[fit["parameter"].astype(str) == name, "value"]
    unit, _ = _unit_of(name, to_float(values.iloc[0]) if len(values) else math.nan)
    return f"{label} ({unit})" if unit else label


def fit_summary(fit: pd.DataFrame, fit_doc: FitDocument) -> Headline:
    """Per subject: the fitted parameters, μ measured, exponents and the fit's quality.

    Parameters
    ----------
    fit : DataFrame
        ``fit.csv`` (:data:`~evtribo.fit.fit_csv.FIT_COLUMNS`).
    fit_doc : FitDocument
        ``fit.json`` (which parameters were fitted, μ measured).

    Returns
    -------
    Headline
        One row per subject; fitted parameters as ``value [95 % interval]`` in readable
        units (air gap in µm), three significant figures.
    """
    names = list(dict.fromkeys([*fit_doc.fit, *fit["parameter"].astype(str)]))
    headers = {n: _fit_header(n, fit) for n in names}
    rows = []
    for s in dict.fromkeys(fit["subject"].astype(str)):
        mine = fit[fit["subject"].astype(str) == s]
        first = mine.iloc[0]
        row: dict[str, str] = {"Subject": s}
        for n in names:
            row[headers[n]] = _estimate_cell(mine, n)
        wf = str(first.get("waveform", "") or "")
        row[MU_COLUMN] = significant(first.get("mu_measured"))
        row["exponent n, measured"] = with_interval(
            first.get("exponent"), first.get("exponent_ci_low"),
            first.get("exponent_ci_high")) + (f" ({wf})" if wf and wf != "nan" else "")
        row["exponent n, model"] = significant(first.get("exponent_model"))
        row["R²"] = r_squared(first.get("r2"))
        row["RMSE (mN)"] = significant(1e3 * to_float(first.get("rmse_N")))
        row["points"] = str(int(to_float(first.get("n_points")))) \
            if math.isfinite(to_float(first.get("n_points"))) else "—"
        rows.append(row)
    fitted = ", ".join(_label(n)[0] for n in names) or "nothing"
    return Headline(
        "fit", "Model fit per subject",
        f"Fitted per subject: {fitted}, value [95 % interval]. μ: the mean of the μ the "
        "subject's rows of electrostatic.csv used (the model's friction takes it); exponent "
        "n of the power law F_el = k·U^n measured over the amplitudes "
        "(95 % interval) and the fitted model's slope over the same amplitudes; R² and RMSE "
        "of the electrostatic force.", pd.DataFrame(rows))


def _role(name: str, value: float, fit_doc: FitDocument) -> str:
    if name in fit_doc.fit:
        return "fitted per subject (value and 95 % interval in the fit table)"
    if name == "mu":
        return ("measured per subject: the mean of the μ its ON windows were compared with "
                "(electrostatic.csv's mu)")
    if name == "eps_0":
        return "physical constant"
    table_1 = getattr(TABLE_1, name, math.nan)
    pfile = fit_doc.parameters_file
    if value == table_1 or (math.isnan(value) and math.isnan(table_1)):
        if name in ("r_sc", "r_g"):
            return "fixed: no leakage, the paper's purely capacitive layers"
        return "fixed: Table 1 of the paper"
    where = f"the parameter file {pfile.get('path')}" if pfile else "--params"
    return f"fixed: from {where} (Table 1: {_shown(name, table_1)})"


def _shown(name: str, value: float) -> str:
    _, unit, prefix = _label(name)
    return quantity(value, unit, prefix=prefix)


def _parameter_value(name: str, raw: Any) -> float:
    """A parameter's value from fit.json, where null stands for a non-finite number: the
    infinite resistance of a layer without leakage."""
    if raw is None:
        fields = {f.name: f for f in dataclasses.fields(ModelParameters)}
        rule = fields[name].metadata.get("rule") if name in fields else None
        return math.inf if rule == "resistance" else math.nan
    return to_float(raw)


def parameter_roles(fit_doc: FitDocument, fit: pd.DataFrame) -> Headline:
    """Every parameter of the model: its value and whether measured, fixed or fitted.

    Parameters
    ----------
    fit_doc : FitDocument
        ``fit.json``: the fixed parameters, the names fitted, each subject's parameters.
    fit : DataFrame
        ``fit.csv`` (the subjects).

    Returns
    -------
    Headline
        Columns ``parameter``, ``value``, ``role``.
    """
    fixed = fit_doc.fixed_parameters or ModelParameters().as_dict()
    subjects: Mapping[str, Any] = fit_doc.subjects
    rows = []
    for f in dataclasses.fields(ModelParameters):
        name = f.name
        value = _parameter_value(name, fixed.get(name, getattr(TABLE_1, name)))
        if name in fit_doc.fit or name == "mu":
            per = [(s, _parameter_value(name, (v.get("parameters") or {}).get(name)))
                   for s, v in subjects.items() if isinstance(v, dict)]
            shown = "; ".join(f"{s} {_shown(name, x)}" for s, x in per) or "per subject"
        else:
            shown = _shown(name, value)
        rows.append({"parameter": _label(name)[0], "value": shown,
                     "role": _role(name, value, fit_doc)})
    return Headline("parameters", "Model parameters: measured, fixed or fitted",
                    "The values this comparison used, and where each one comes from.",
                    pd.DataFrame(rows, columns=["parameter", "value", "role"]))


def _fitted_text(text: Any, at_bound: Any = "") -> str:
    """``h_L=3.21e-06; r_g=0.012`` -> ``h_L = 3.21 µm; r_g = 12.0 mΩ·m²``; a parameter left
    at a bound of its range is said to be there (``r_g at its bound, 788 Ω·m²``), not shown
    as fitted."""
    bound = {b.strip() for b in str(at_bound if isinstance(at_bound, str) else "").split(";")}
    parts = []
    for item in str(text if isinstance(text, str) else "").split(";"):
        name, sep, raw = item.partition("=")
        name, value = name.strip(), to_float(raw.strip())
        if not sep or math.isnan(value):
            parts.append(item.strip())
            continue
        parts.append(f"{name} at its bound ({_shown(name, value)}), not fitted"
                     if name in bound else f"{name} = {_shown(name, value)}")
    return "; ".join(p for p in parts if p) or "—"


def _criterion(models: pd.DataFrame) -> str:
    """``AICc`` when models.csv's ``criterion`` says any subject's is (``AIC`` otherwise)."""
    if "criterion" in models.columns and (models["criterion"].astype(str) == "AICc").any():
        return "AICc"
    return "AIC"


def _weight(w: Any) -> str:
    weight = to_float(w)
    return "< 0.001" if 0 <= weight < 0.0005 else significant(weight, decimals=3)


def model_comparison(models: pd.DataFrame, subject: str) -> Headline:
    """One subject's models (``models.csv``), best first, for people.

    Parameters
    ----------
    models : DataFrame
        ``models.csv``: subject, model, fitted, n_params, n_points, rss_N2, aic, bic,
        delta_aic, akaike_weight (criterion and at_bound when compare wrote them).
    subject : str
        Whose rows.

    Returns
    -------
    Headline
        Columns model, fitted, parameters, AICc (or AIC), ΔAICc, Akaike weight, verdict.
    """
    crit = _criterion(models)
    mine = models[models["subject"].astype(str) == subject].copy()
    mine = mine.sort_values("aic", kind="stable")
    rows = []
    for _, r in mine.iterrows():
        delta = to_float(r["delta_aic"])
        rows.append({
            "model": str(r["model"]),
            "fitted": _fitted_text(r.get("fitted"), r.get("at_bound", "")),
            "parameters": str(int(to_float(r["n_params"]))) if math.isfinite(
                to_float(r["n_params"])) else "—",
            crit: significant(r["aic"], decimals=1),
            f"Δ{crit}": significant(r["delta_aic"], decimals=1),
            "Akaike weight": _weight(r["akaike_weight"]),
            "verdict": "—" if not math.isfinite(delta) else "lowest" if delta == 0 else
            f"indistinguishable (Δ < {INDISTINGUISHABLE:g})" if delta < INDISTINGUISHABLE
            else "less supported"})
    undefined = ("; — where the criterion is not defined: no more points than the model's "
                 "parameters + 2, the model cannot be ranked") if any(
        r[crit] == "—" for r in rows) else ""
    return Headline(f"models_{subject}", f"Models compared, {subject}",
                    f"Each model fitted to the subject's electrostatic forces; {crit} from the "
                    "weighted residual sum of squares"
                    + (" (the small-sample AICc: fewer than 40 points per parameter)"
                       if crit == "AICc" else "")
                    + f", Δ{crit} to the best model, Akaike weight the relative support of "
                    f"each model (they sum to 1); models within Δ{crit} "
                    f"{INDISTINGUISHABLE:g} of the lowest are indistinguishable from it"
                    f"{undefined}.",
                    pd.DataFrame(rows, columns=["model", "fitted", "parameters", crit,
                                                f"Δ{crit}", "Akaike weight", "verdict"]))


def model_ranking(models: pd.DataFrame) -> Headline:
    """The models ranked over the study (:func:`evtribo.fit.models.study_ranking`).

    Parameters
    ----------
    models : DataFrame
        ``models.csv``.

    Returns
    -------
    Headline
        Columns model, summed AICc (or AIC), ΔAICc, Akaike weight, lowest in,
        indistinguishable in, at a bound in, verdict; its caption says the study's verdict.
    """
    ranking = study_ranking(models)
    crit = str(ranking["criterion"].iloc[0]) if not ranking.empty else _criterion(models)
    rows = []
    for r in _rows(ranking):
        n = int(r.subjects)
        rows.append({"model": str(r.model), f"summed {crit}": significant(r.aic_sum,
                                                                         decimals=1),
                     f"Δ{crit}": significant(r.delta, decimals=1),
                     "Akaike weight": _weight(r.akaike_weight),
                     "lowest in": f"{int(r.best_in)} of {n}",
                     f"within Δ{crit} {INDISTINGUISHABLE:g} in": f"{int(r.indistinguishable_in)} "
                                                               f"of {n}",
                     "parameter at its bound in": f"{int(r.at_bound_in)} of {n}",
                     "verdict": "lowest" if r.delta == 0 else
                     "indistinguishable" if r.delta < INDISTINGUISHABLE else "less supported"})
    for name in dict.fromkeys(models["model"].astype(str)):
        if name not in set(ranking["model"].astype(str)):
            rows.append({"model": name, "verdict": "not ranked: no criterion where the "
                                                   "others have one"})
    said = verdict(ranking)
    return Headline("models", "Models ranked over the study",
                    f"Each model's {crit} summed over the subjects where every model has one "
                    "(each subject its own parameters), Δ to the lowest sum and Akaike "
                    f"weights of the sums; within Δ{crit} {INDISTINGUISHABLE:g} of the lowest "
                    "a model is indistinguishable from it. "
                    + (f"Verdict: {said}." if said else "No subject has every model's "
                       "criterion: no ranking."),
                    pd.DataFrame(rows, columns=["model", f"summed {crit}", f"Δ{crit}",
                                                "Akaike weight", "lowest in",
                                                f"within Δ{crit} {INDISTINGUISHABLE:g} in",
                                                "parameter at its bound in", "verdict"]
                                 ).astype(object).fillna("—"))


def _rows(table: pd.DataFrame) -> list[Any]:
    """The rows of *table* as named tuples whose fields are typed ``Any``."""
    return list(table.itertuples(index=False))
