"""The report's "Population" section: what a paper reports of the whole study.

After the per-subject fit: the population's electrostatic force at each amplitude (mN, 95 %
intervals; every subject in, from the nonlinear mixed model on the linear scale), its power
law's exponent against the seed paper's limits (2 when the normal force dominates the
contact, eq. 13; 10/3 when the voltage does, eq. 12), its prefactor, friction coefficient and
air gap with the prediction intervals for a new subject and the model's checks; the relative
friction increase; each subject's test of F_el > 0 (Holm); the spread between subjects (tau
and I^2 with their intervals); the estimates without each subject far from the others; the
meta-analysis of log F_el where it is valid, as a second method; the contrasts between
conditions; the subjects excluded beforehand; what could not be estimated and why; a
paragraph for a methods section; and the population's figures. It reads compare's
population.csv, population_contrasts.csv, population_subjects.csv and fit.json's population.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo import __version__
from evtribo.documents.fit import FitDocument
from evtribo.documents.result_folder import ResultFolder
from evtribo.errors import FORCE
from evtribo.population.data import PopulationOutlier
from evtribo.population.journal import subjects_view
from evtribo.population.stats import MIN_SUBJECTS
from evtribo.report.headline import Headline
from evtribo.report.page import Report
from evtribo.util.numbers import frequency, quantity, significant, to_float, voltage, with_interval

__all__ = ["SECTION", "add_population", "exponent_verdict", "population_headline",
           "read_population", "read_subjects"]

#: The section's title.
SECTION = "Population"
#: "times or divided by", before a factor of spread.
_TIMES = "\u00d7/\u00f7"
#: The seed paper's limits of the exponent (eqs. 13 and 12).
LIMITS = ((Fraction(2), "the square law of a contact set by the normal force (eq. 13)"),
          (Fraction(10, 3), "the limit of a contact set by the voltage (eq. 12)"))
_PRIMARY = "primary"


def _as_read(frame: pd.DataFrame | None) -> pd.DataFrame | None:
    """A population table as the section reads it: "" where a waveform, the checks or the
    analysis is missing (mu's and h_L's rows), as in memory."""
    if frame is None:
        return None
    frame = frame.copy()
    for col in ("waveform", "checks", "analysis"):
        if col in frame.columns:
            frame[col] = frame[col].fillna("").astype(str)
    return frame


def read_population(folder: Path | ResultFolder
                    ) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """population.csv and population_contrasts.csv of a result folder (None when absent).

    Parameters
    ----------
    folder : Path or ResultFolder
        The result folder (read through :class:`~evtribo.documents.result_folder.ResultFolder`).

    Returns
    -------
    (DataFrame or None, DataFrame or None)

    Raises
    ------
    ResultFolderError
        A file that cannot be read or lacks a column.
    """
    results = folder if isinstance(folder, ResultFolder) \
        else ResultFolder.compare_documents(folder)
    table = results.population
    return _as_read(None if table is None else table.frame), _as_read(results.contrasts)


def read_subjects(folder: Path | ResultFolder) -> pd.DataFrame | None:
    """population_subjects.csv of a result folder (None when absent).

    Parameters
    ----------
    folder : Path or ResultFolder
        The result folder.

    Returns
    -------
    DataFrame or None
        Raises ResultFolderError as :func:`read_population` does.
    """
    results = folder if isinstance(folder, ResultFolder) \
        else ResultFolder.compare_documents(folder)
    return _as_read(results.population_subjects)


def _conditions(table: pd.DataFrame) -> list[tuple[str, float]]:
    rows = table[table["waveform"].fillna("").astype(str) != ""]
    pairs = dict.fromkeys(zip(rows["waveform"].astype(str),
                              rows["frequency_Hz"].astype(float), strict=True))
    return list(pairs)


def _of(table: pd.DataFrame, quantity_name: str, condition: tuple[str, float] | None,
        analysis: str = _PRIMARY) -> pd.DataFrame:
    rows = table[(table["quantity"].astype(str) == quantity_name)
                 & (table["analysis"].astype(str) == analysis)]
    if condition is None:
        return rows
    f = rows["frequency_Hz"].astype(float)
    same_f = f.isna() if math.isnan(condition[1]) else (f - condition[1]).abs() < 1e-9
    return rows[(rows["waveform"].astype(str) == condition[0]) & same_f]


def _by_amplitude(rows: pd.DataFrame, amps: Sequence[float], cell: Any) -> dict[str, str]:
    out = {}
    for a in amps:
        hit = rows[(rows["amplitude_V"].astype(float) - a).abs() < 1e-9]
        out[voltage(a)] = "—" if hit.empty else cell(hit.iloc[0])
    return out


def _amps(rows: pd.DataFrame) -> list[float]:
    return sorted({float(a) for a in rows["amplitude_V"]})


def population_headline(table: pd.DataFrame) -> Headline:
    """The population's F_el in mN with its 95 % interval: a row per condition.

    Parameters
    ----------
    table : DataFrame
        ``population.csv`` (its primary rows are shown).

    Returns
    -------
    Headline
        Columns ``Waveform``, ``Frequency``, then one per amplitude (``80 V``), then the
        spread between subjects and the subjects counted.
    """
    forces = _of(table, "electrostatic_force_N", None)
    amps = _amps(forces)
    rows = []
    for cond in _conditions(forces):
        mine = _of(forces, "electrostatic_force_N", cond)
        row = {"Waveform": cond[0], "Frequency": frequency(cond[1]),
               **_by_amplitude(mine, amps, lambda r: with_interval(
                   1e3 * float(r["estimate"]), 1e3 * float(r["ci_low"]),
                   1e3 * float(r["ci_high"])))}
        sd = mine["between_subject_sd"].astype(float)
        row["spread between subjects"] = (f"{_TIMES} {significant(math.exp(sd.median()))}"
                                          if len(sd) else "—")
        n = mine["n_subjects"].astype(int)
        row["subjects"] = (str(n.min()) if n.min() == n.max() else f"{n.min()}-{n.max()}") \
            if len(n) else "—"
        rows.append(row)
    return Headline(
        "population", "The population's electrostatic force F_el (mN)",
        "Geometric mean over the subjects of the inferred electrostatic force at each "
        "amplitude [95 % interval], in mN: the power law across every subject of a nonlinear "
        "mixed model on the linear scale, each subject's force with its own error (forces "
        "near or below zero count); the spread between subjects as the factor of one "
        "standard deviation of log F_el (median over the amplitudes).",
        pd.DataFrame(rows, columns=["Waveform", "Frequency", *(voltage(a) for a in amps),
                                    "spread between subjects", "subjects"]))


def exponent_verdict(estimate: float, low: float, high: float) -> str:
    """What the population's exponent says of the seed paper's two limits.

    Parameters
    ----------
    estimate, low, high : float
        The exponent and its 95 % interval.

    Returns
    -------
    str
        E.g. ``n = 2.05 [1.98, 2.12]: the interval holds 2 (...); it lies below 10/3 (...)``.
    """
    parts = []
    for limit, what in LIMITS:
        shown = str(limit)
        if low <= float(limit) <= high:
            parts.append(f"the interval holds {shown}, {what}")
        elif high < float(limit):
            parts.append(f"it lies below {shown}, {what}")
        else:
            parts.append(f"it lies above {shown}, {what}")
    return f"n = {with_interval(estimate, low, high)}: " + "; ".join(parts)


def _value(r: Any, unit: str, low: str = "ci_low", high: str = "ci_high") -> str:
    est, lo, hi = float(r["estimate"]), float(r[low]), float(r[high])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "—"
    if unit:
        return f"{quantity(est, unit)} [{quantity(lo, unit)}, {quantity(hi, unit)}]"
    return with_interval(est, lo, hi)


_NAMES = {"electrostatic_force_N": "F_el", "friction_increase_pct": "dF_t/F_t,OFF (%)"}
_SHOWN = {"exponent": ("exponent n", "", False), "prefactor_N": ("prefactor k at 1 V", "N", True),
          "mu": ("friction coefficient μ", "", False), "h_L_m": ("air gap h_L", "m", True)}


def _quantities(table: pd.DataFrame) -> pd.DataFrame:
    """Exponent, prefactor, μ and h_L: one row each (per condition where it applies), with
    the prediction interval for a new subject and the model's checks."""
    rows = []
    for _, r in table[table["analysis"].astype(str) == _PRIMARY].iterrows():
        name = str(r["quantity"])
        if name not in _SHOWN:
            continue
        label, unit, log_normal = _SHOWN[name]
        wave = str(r["waveform"])
        sd = float(r["between_subject_sd"])
        rows.append({"quantity": label,
                     "condition": f"{wave} {frequency(r['frequency_Hz'])}" if wave else "all",
                     "population [95 %]": _value(r, unit),
                     "a new subject [95 %]": _value(r, unit, "pi_low", "pi_high"),
                     "spread between subjects": (f"{_TIMES} {significant(math.exp(sd))}"
                                                 if log_normal else f"SD {significant(sd)}"),
                     "subjects": str(int(r["n_subjects"])), "checks": str(r["checks"]) or "—",
                     "method": str(r["method"])})
    return pd.DataFrame(rows, columns=["quantity", "condition", "population [95 %]",
                                       "a new subject [95 %]", "spread between subjects",
                                       "subjects", "checks", "method"])


def _per_amplitude(table: pd.DataFrame, quantity_name: str, analysis: str,
                   cell: Any) -> pd.DataFrame:
    """A row per condition, a column per amplitude, of *quantity_name*'s rows."""
    rows = _of(table, quantity_name, None, analysis)
    amps = _amps(rows)
    out = [{"condition": f"{c[0]} {frequency(c[1])}",
            **_by_amplitude(_of(rows, quantity_name, c, analysis), amps, cell)}
           for c in _conditions(rows)]
    return pd.DataFrame(out, columns=["condition", *(voltage(a) for a in amps)])


def _where(r: Any) -> dict[str, str]:
    """A row's quantity (with its amplitude) and condition, for people."""
    amp, name = float(r["amplitude_V"]), str(r["quantity"])
    name = _NAMES.get(name, _SHOWN.get(name, (name,))[0])
    return {"quantity": name + (f" at {voltage(amp)}" if math.isfinite(amp) else ""),
            "condition": (f"{r['waveform']} {frequency(r['frequency_Hz'])}"
                          if str(r["waveform"]) else "all")}


def _spread(table: pd.DataFrame) -> pd.DataFrame:
    """tau and I^2 with their intervals, for every row that has them."""
    rows = [{**_where(r), "analysis": str(r["analysis"]),
             "τ [95 %]": with_interval(r["between_subject_sd"], r["between_sd_low"],
                                       r["between_sd_high"]),
             "I² (%) [95 %]": with_interval(100 * float(r["i2"]), 100 * float(r["i2_low"]),
                                            100 * float(r["i2_high"]))}
            for _, r in table[table["i2"].notna()].iterrows()
            if str(r["analysis"]) in (_PRIMARY, "meta-analysis")]
    return pd.DataFrame(rows, columns=["quantity", "condition", "analysis", "τ [95 %]",
                                       "I² (%) [95 %]"])


def _sensitivity(table: pd.DataFrame) -> pd.DataFrame:
    """Every primary estimate beside the same without each subject far from the others."""
    primary = {tuple(_where(r).values()): r for _, r in
               table[table["analysis"].astype(str) == _PRIMARY].iterrows()}
    rows = []
    for _, r in table[table["analysis"].astype(str).str.startswith("without ")].iterrows():
        name, where = str(r["quantity"]), _where(r)
        unit = "N" if name == "electrostatic_force_N" else _SHOWN.get(name, ("", ""))[1]
        same = primary.get(tuple(where.values()))
        rows.append({**where, "every subject [95 %]": "—" if same is None else
                     _value(same, unit), "analysis": str(r["analysis"]),
                     "sensitivity [95 %]": _value(r, unit)})
    return pd.DataFrame(rows, columns=["quantity", "condition", "every subject [95 %]",
                                       "analysis", "sensitivity [95 %]"])


def _contrasts_view(contrasts: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for _, r in contrasts.iterrows():
        ratio = str(r["quantity"]) == "electrostatic_force_N"
        value = float(r["ratio"] if ratio else r["difference"])
        rows.append({"compared": f"{r['condition_b']} against {r['condition_a']}",
                     "quantity": "F_el ratio" if ratio else "exponent difference",
                     "value [95 %]": with_interval(value, r["ci_low"], r["ci_high"]),
                     "subjects": str(int(r["n_subjects"]))})
    return pd.DataFrame(rows, columns=["compared", "quantity", "value [95 %]", "subjects"])


def _outliers(doc: Mapping[str, Any]) -> list[str]:
    """One line per subject far from the others: its values outside the others'
    prediction intervals."""
    by_subject: dict[str, list[str]] = {}
    for o in doc.get("outliers") or []:
        if isinstance(o, Mapping):
            found = PopulationOutlier(str(o.get("subject")), str(o.get("quantity")),
                                      to_float(o.get("value")), to_float(o.get("low")),
                                      to_float(o.get("high")), str(o.get("unit") or ""))
            by_subject.setdefault(found.subject, []).append(
                found.describe().removeprefix(f"{found.subject}: "))
    return [f"{subject} lies far from the other subjects: {'; '.join(items)}. It is in every "
            "estimate above; the table of sensitivity gives them without it. Check its "
            "trials (a load cell, the finger's posture, a note) before reading it as a real "
            "difference." for subject, items in by_subject.items()]


def _excluded(doc: Mapping[str, Any]) -> list[dict[str, str]]:
    return [{"subject": str(e.get("subject")), "reason": str(e.get("reason"))}
            for e in doc.get("excluded") or [] if isinstance(e, Mapping)]


def _why_not(notes: Sequence[str], what: str = "") -> str:
    """Why *what* (default: anything) was not estimated: the first note, or a re-run hint."""
    if notes:
        return f"No population estimate{f' of {what}' if what else 's'}: {notes[0]}."
    return ("No population estimates: this comparison was made by an older evtribo compare; "
            f"run `evtribo compare OUT {FORCE}` for them (they need at least {MIN_SUBJECTS} "
            "subjects with electrostatic forces).")


def _methods_text(table: pd.DataFrame, doc: Mapping[str, Any]) -> str:
    """A paragraph for a paper's methods section, with this study's numbers."""
    gone = "".join(f" {e['subject']} was excluded by a rule written in the study's study.toml "
                   f"before the analysis ({e['reason']})." for e in _excluded(doc))
    gone += "".join(f" No exclusion rule was read: {n}." for n in doc.get("exclusion_rule")
                    or [] if isinstance(n, str))
    mu_text = ("each subject's friction coefficient μ (the ratio of its mean friction force "
               "to its mean normal force over its OFF windows, with the delta method's "
               "standard error)")
    if not (table["quantity"].astype(str) == "electrostatic_force_N").any():
        n = int(table["n_subjects"].max())
        return (f"Population estimates were computed with evtribo {__version__} from the "
                f"per-subject results of {n} subjects: the population's friction "
                f"coefficient is the random-effects mean of {mu_text}, each weighted by its "
                "own standard error (Paule-Mandel between-subject variance, "
                "Hartung-Knapp-Sidik-Jonkman interval; statsmodels). Every subject was in "
                "the estimate; subjects outside the prediction interval of the others "
                "(Higgins et al. 2009, Bonferroni-corrected) were reported, with the "
                "estimate without each." + gone)
    n = int(doc.get("n_subjects") or table["n_subjects"].max() if len(table) else 0)
    slopes = table["method"].astype(str).str.contains("intercept and exponent").any()
    random = "level (log k) and exponent were" if slopes else "level (log k) was"
    return (f"Population estimates were computed with evtribo {__version__} from the "
            f"per-subject results of {n} subjects. The power law F_el = k U^n was fitted "
            "across subjects as a nonlinear mixed-effects model on the linear scale: each "
            f"subject's {random} normal random effects, each of its forces with its own "
            "measurement error (from its 95 % bootstrap interval, correlated as its bootstrap "
            "replicates), so that forces near or below zero count. The random effects were "
            "integrated by the Laplace approximation and the variances estimated by "
            "approximate REML; the fit was repeated with three optimisers (L-BFGS-B, "
            "Nelder-Mead, Powell; the lowest deviance kept, any disagreement reported) and "
            "checked for a finite log-likelihood and a positive-definite Hessian; intervals "
            "from Student's t with Satterthwaite's degrees of freedom. The population's F_el "
            "at each voltage is the model's geometric mean over subjects; prediction "
            "intervals for a new subject use Student's t with k - 2 degrees of freedom "
            "(Higgins, Thompson and Spiegelhalter 2009). The relative friction increase "
            f"dF_t/F_t,OFF = F_el/F_n,ON, {mu_text} and the fitted air gap h_L (on the log "
            "scale) were pooled by random-effects meta-analysis (Paule-Mandel between-subject "
            "variance, Hartung-Knapp-Sidik-Jonkman interval, Q-profile interval of tau; "
            "statsmodels). Each subject's F_el > 0 was tested one-sided, its forces weighted "
            "as U^2, with Holm's correction over subjects. Every subject was in the primary "
            "analysis; subjects outside the prediction interval of the others "
            "(Bonferroni-corrected) were reported, with the estimates without each as a "
            "sensitivity analysis." + gone)


def add_population(report: Report, table: pd.DataFrame | None,
                   contrasts: pd.DataFrame | None, fit_doc: FitDocument,
                   figures: Sequence[Mapping[str, Any]], *, friction_only: bool = False
                   ) -> list[Headline]:
    """The "Population" section (nothing, or why not, when there are no estimates).

    Parameters
    ----------
    report : Report
        The page.
    table, contrasts : DataFrame or None
        ``population.csv`` and ``population_contrasts.csv`` (None when absent).
    fit_doc : FitDocument
        ``fit.json`` (its ``population``: subjects, notes, outliers, exclusions);
        ``population_subjects.csv`` is read beside it.
    figures : sequence of mapping
        fit.json's records of this section's figures, each with its ``file``.
    friction_only : bool
        A study of OFF trials: the population's μ only, or why there is none.

    Returns
    -------
    list of Headline
        The population's table (for ``--tables``), or none.
    """
    doc = fit_doc.population
    notes = [n for n in doc.get("notes") or [] if isinstance(n, str)]
    headlines: list[Headline] = []
    if table is None or not (table["quantity"].astype(str) == "electrostatic_force_N").any():
        # fewer than three subjects with F_el: at most mu's row
        notes = notes[1:] if friction_only else notes
        if not friction_only or table is None or table.empty:
            report.add_text(_why_not(notes, "μ" if friction_only else ""), section=SECTION)
        if table is None or table.empty:
            return []
    else:
        headline = population_headline(table)
        report.add_table(headline.table, headline.title, caption=headline.caption,
                         section=SECTION, wrap=True)
        headlines.append(headline)
    for cond in _conditions(_of(table, "exponent", None)):
        r = _of(table, "exponent", cond).iloc[0]
        report.add_text(f"{cond[0]} {frequency(cond[1])}: the population's exponent "
                        + exponent_verdict(float(r["estimate"]), float(r["ci_low"]),
                                           float(r["ci_high"])) + ".", section=SECTION)
    _tables(report, table, contrasts, fit_doc, only_mu=set(table["quantity"]) == {"mu"})
    for title, items in (("Far from the other subjects", _outliers(doc)),
                         ("Excluded beforehand", [f"{e['subject']}: {e['reason']}"
                                                  for e in _excluded(doc)])):
        if items:
            report.add_list(items, title, section=SECTION)
    for f in figures:
        report.add_figure(f["file"], str(f.get("title") or f.get("stem")),
                          caption=str(f.get("caption") or ""), section=SECTION)
    report.add_text(_methods_text(table, doc), "For a methods section", section=SECTION)
    return headlines


def _subjects_of(fit_doc: FitDocument) -> pd.DataFrame:
    """population_subjects.csv beside fit.json (empty when there is none)."""
    if fit_doc.path is None:
        return pd.DataFrame()
    subjects = read_subjects(fit_doc.path.parent)
    return pd.DataFrame() if subjects is None or subjects.empty else subjects_view(subjects)


def _tables(report: Report, table: pd.DataFrame, contrasts: pd.DataFrame | None,
            fit_doc: FitDocument, *, only_mu: bool) -> None:
    """The section's tables after the headline."""
    report.add_table(_quantities(table), "The population's friction coefficient μ" if only_mu
                     else "The population's power law, μ and air gap",
                     caption="Population value [95 % interval], and where a new subject's "
                             "value would lie [95 % prediction interval]; the spread as the "
                             "standard deviation of the subjects' μ." if only_mu else
                     "Population value [95 % interval], and where a new subject's value "
                     "would lie [95 % prediction interval]; for k and h_L the geometric mean, "
                     "the spread as the factor of one standard deviation of their log; "
                     "checks: the mixed model's (finite log-likelihood, positive-definite "
                     "Hessian, the optimisers' agreement, a determined exponent).",
                     section=SECTION, wrap=True)
    views = [
        (_per_amplitude(table, "friction_increase_pct", _PRIMARY, lambda r: with_interval(
            r["estimate"], r["ci_low"], r["ci_high"])),
         "Relative friction increase dF_t/F_t,OFF (%)",
         "The population's mean over subjects of F_el / F_n,ON in % [95 % interval]: the "
         "friction ON over the friction OFF at the same normal force, less one."),
        (_subjects_of(fit_doc), "Each subject: relative friction increase (%) and F_el > 0",
         "Each subject's F_el / F_n,ON in % [95 % interval] at each amplitude, and the "
         "one-sided test of F_el > 0 (its forces weighted as U^2) with Holm's correction "
         "over the study's subjects and conditions (family-wise 5 %)."),
        (_spread(table), "Spread between subjects: τ and I²",
         "τ: the between-subject SD (of log F_el for forces) [95 % interval: Satterthwaite's "
         "for the mixed model, Q-profile for the meta-analyses]; I²: its share of the "
         "subjects' scatter beyond their measurements' errors."),
        (_sensitivity(table), "Sensitivity: without each subject far from the others",
         "Each estimate with every subject (as above) and without the subject named far "
         "from the others."),
        (_per_amplitude(table, "electrostatic_force_N", "meta-analysis",
                        lambda r: with_interval(1e3 * float(r["estimate"]),
                                                1e3 * float(r["ci_low"]),
                                                1e3 * float(r["ci_high"]))),
         "A second method: meta-analysis of log F_el (mN)",
         "At the amplitudes where every subject's force has an interval above zero and "
         "a standard error of its log of at most 0.2: a random-effects meta-analysis of log "
         "F_el (Paule-Mandel, Hartung-Knapp), for comparison with the mixed model's."),
    ]
    for frame, title, caption in views:
        if not frame.empty and len(frame.columns) > 1:
            report.add_table(frame, title, caption=caption, section=SECTION, wrap=True)
    if contrasts is not None and not contrasts.empty:
        report.add_table(_contrasts_view(contrasts), "Between conditions",
                         caption="Within subjects measured in both: the ratio of F_el (over "
                                 "the amplitudes each has in both) and the difference of the "
                                 "exponents, pooled over subjects.", section=SECTION)
