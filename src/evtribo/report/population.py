"""The report's "Population" section: what a paper reports of the whole study.

After the per-subject fit: the population's electrostatic force at each amplitude (mN, 95 %
intervals), its power law's exponent against the seed paper's limits (2 when the normal
force dominates the contact, eq. 13; 10/3 when the voltage does, eq. 12), its prefactor,
friction coefficient and air gap, the contrasts between conditions, the subjects left out as
outliers, what could not be estimated and why, a paragraph for a methods section, and the
population's figures. It reads ``population.csv``, ``population_contrasts.csv`` and
``fit.json``'s ``population`` (written by ``evtribo compare``).
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
from evtribo.errors import FORCE, ResultFolderError
from evtribo.population.data import CONTRAST_COLUMNS, POPULATION_COLUMNS, PopulationOutlier
from evtribo.population.stats import MIN_SUBJECTS
from evtribo.report.headline import Headline
from evtribo.report.page import Report
from evtribo.results.outputs import POPULATION_CONTRASTS_CSV, POPULATION_CSV
from evtribo.util.numbers import frequency, quantity, significant, to_float, voltage, with_interval

__all__ = ["SECTION", "add_population", "exponent_verdict", "population_headline",
           "read_population"]

#: The section's title.
SECTION = "Population"
#: "times or divided by", before a factor of spread.
_TIMES = "\u00d7/\u00f7"
#: The seed paper's limits of the exponent (eqs. 13 and 12).
LIMITS = ((Fraction(2), "the square law of a contact set by the normal force (eq. 13)"),
          (Fraction(10, 3), "the limit of a contact set by the voltage (eq. 12)"))


def read_population(folder: Path) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """population.csv and population_contrasts.csv of a result folder (None when absent).

    Parameters
    ----------
    folder : Path
        The result folder.

    Returns
    -------
    (DataFrame or None, DataFrame or None)

    Raises
    ------
    ResultFolderError
        A file that cannot be read or lacks a column.
    """
    out: list[pd.DataFrame | None] = []
    for name, columns in ((POPULATION_CSV, POPULATION_COLUMNS),
                          (POPULATION_CONTRASTS_CSV, CONTRAST_COLUMNS)):
        path = folder / name
        if not path.is_file():
            out.append(None)
            continue
        try:
            frame = pd.read_csv(path, dtype={"waveform": str, "method": str,
                                             "condition_a": str, "condition_b": str},
                                keep_default_na=False, na_values=[""])
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
            raise ResultFolderError(f"cannot read this table: {err}; run `evtribo compare "
                                    f"{folder} {FORCE}`", path=path) from err
        missing = [c for c in columns if c not in frame.columns]
        if missing:
            raise ResultFolderError(f"missing column(s) {', '.join(missing)}; run `evtribo "
                                    f"compare {folder} {FORCE}`", path=path, key=missing[0])
        if "waveform" in frame.columns:  # "" for mu and h_L, as in memory
            frame["waveform"] = frame["waveform"].fillna("").astype(str)
        out.append(frame)
    return out[0], out[1]


def _conditions(table: pd.DataFrame) -> list[tuple[str, float]]:
    rows = table[table["waveform"].fillna("").astype(str) != ""]
    pairs = dict.fromkeys(zip(rows["waveform"].astype(str),
                              rows["frequency_Hz"].astype(float), strict=True))
    return list(pairs)


def _of(table: pd.DataFrame, quantity_name: str, condition: tuple[str, float] | None
        ) -> pd.DataFrame:
    rows = table[table["quantity"].astype(str) == quantity_name]
    if condition is None:
        return rows
    f = rows["frequency_Hz"].astype(float)
    same_f = f.isna() if math.isnan(condition[1]) else (f - condition[1]).abs() < 1e-9
    return rows[(rows["waveform"].astype(str) == condition[0]) & same_f]


def population_headline(table: pd.DataFrame) -> Headline:
    """The population's F_el in mN with its 95 % interval: a row per condition.

    Parameters
    ----------
    table : DataFrame
        ``population.csv``.

    Returns
    -------
    Headline
        Columns ``Waveform``, ``Frequency``, then one per amplitude (``80 V``), then the
        spread between subjects and the subjects counted.
    """
    forces = table[table["quantity"].astype(str) == "electrostatic_force_N"]
    amps = sorted({float(a) for a in forces["amplitude_V"]})
    rows = []
    for cond in _conditions(forces):
        mine = _of(forces, "electrostatic_force_N", cond)
        row = {"Waveform": cond[0], "Frequency": frequency(cond[1])}
        for a in amps:
            hit = mine[(mine["amplitude_V"].astype(float) - a).abs() < 1e-9]
            row[voltage(a)] = "—" if hit.empty else with_interval(
                1e3 * float(hit["estimate"].iloc[0]), 1e3 * float(hit["ci_low"].iloc[0]),
                1e3 * float(hit["ci_high"].iloc[0]))
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
        "amplitude [95 % interval], in mN: a random-effects meta-analysis of log F_el, each "
        "subject's force weighted by its own interval; the spread between subjects as the "
        "factor of one standard deviation of log F_el (median over the amplitudes).",
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


def _quantities(table: pd.DataFrame) -> pd.DataFrame:
    """Exponent, prefactor, μ and h_L: one row each (per condition where it applies)."""
    shown = {"exponent": ("exponent n", "", False), "prefactor_N": ("prefactor k at 1 V", "N",
                                                                   True),
             "mu": ("friction coefficient μ", "", False), "h_L_m": ("air gap h_L", "m", True)}
    rows = []
    for _, r in table.iterrows():
        name = str(r["quantity"])
        if name not in shown:
            continue
        label, unit, log_normal = shown[name]
        wave = str(r["waveform"]) if isinstance(r["waveform"], str) else ""
        est, lo, hi = float(r["estimate"]), float(r["ci_low"]), float(r["ci_high"])
        if unit:
            value = f"{quantity(est, unit)} [{quantity(lo, unit)}, {quantity(hi, unit)}]"
        else:
            value = with_interval(est, lo, hi)
        sd = float(r["between_subject_sd"])
        rows.append({"quantity": label,
                     "condition": f"{wave} {frequency(r['frequency_Hz'])}" if wave else "all",
                     "population [95 %]": value,
                     "spread between subjects": (f"{_TIMES} {significant(math.exp(sd))}"
                                                 if log_normal else f"SD {significant(sd)}"),
                     "subjects": str(int(r["n_subjects"])), "method": str(r["method"])})
    return pd.DataFrame(rows, columns=["quantity", "condition", "population [95 %]",
                                       "spread between subjects", "subjects", "method"])


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
    """One line per outlier subject: its values outside the others' prediction intervals."""
    by_subject: dict[str, list[str]] = {}
    for o in doc.get("outliers") or []:
        if isinstance(o, Mapping):
            found = PopulationOutlier(str(o.get("subject")), str(o.get("quantity")),
                                      to_float(o.get("value")), to_float(o.get("low")),
                                      to_float(o.get("high")), str(o.get("unit") or ""))
            by_subject.setdefault(found.subject, []).append(
                found.describe().removeprefix(f"{found.subject}: "))
    return [f"{subject} lies far from the other subjects: {'; '.join(items)}. It was left "
            "out of those estimates (for a power law's, of all that condition's "
            "estimates and contrasts); its own results are in the tables above. Check its "
            "trials (a load cell, the finger's posture, a note) before reading it as a real "
            "difference." for subject, items in by_subject.items()]


def _methods_text(table: pd.DataFrame, doc: Mapping[str, Any]) -> str:
    """A paragraph for a paper's methods section, with this study's numbers."""
    mu_text = ("each subject's friction coefficient μ (the ratio of its mean friction force "
               "to its mean normal force over its OFF windows, with the delta method's "
               "standard error)")
    if not (table["quantity"].astype(str) == "electrostatic_force_N").any():
        n = int(table["n_subjects"].max())
        return (f"Population estimates were computed with evtribo {__version__} from the "
                f"per-subject results of {n} subjects: the population's friction "
                f"coefficient is the random-effects mean of {mu_text}, each weighted by its "
                "own standard error (Paule-Mandel between-subject variance, "
                "Hartung-Knapp-Sidik-Jonkman interval; statsmodels). Subjects outside the "
                "prediction interval of the others (Higgins et al. 2009, "
                "Bonferroni-corrected) were reported and left out.")
    n = int(doc.get("n_subjects") or table["n_subjects"].max() if len(table) else 0)
    slopes = table["method"].astype(str).str.contains("intercept and exponent").any()
    random = "random intercepts and exponents" if slopes else "random intercepts"
    return (f"Population estimates were computed with evtribo {__version__} from the "
            f"per-subject results of {n} subjects. The population's electrostatic force at "
            "each voltage amplitude is the geometric mean over subjects, from a "
            "random-effects meta-analysis of log F_el in which each subject's estimate is "
            "weighted by its own 95 % bootstrap interval (Paule-Mandel between-subject "
            "variance, Hartung-Knapp-Sidik-Jonkman interval; statsmodels). The power law "
            "log F_el = log k + n log U was fitted across subjects by a linear mixed-effects "
            f"model with {random} by subject (REML, statsmodels MixedLM), each subject's "
            "forces whitened by their known covariance (their intervals, correlated as their "
            "bootstrap replicates), intervals from Student's t with Satterthwaite's degrees "
            f"of freedom. The friction coefficient, from {mu_text}, and the fitted air gap "
            "h_L, on the log scale, were pooled as the forces were. Subjects outside the "
            "prediction interval of the others (Higgins et al. 2009, Bonferroni-corrected) "
            "were reported and left out.")


def _why_not(notes: Sequence[str], what: str = "") -> str:
    """The text said when *what* (default: anything) was not estimated: the first note, or
    a re-run hint."""
    if notes:
        return f"No population estimate{f' of {what}' if what else 's'}: {notes[0]}."
    return ("No population estimates: this comparison was made by an older evtribo compare; "
            f"run `evtribo compare OUT {FORCE}` for them (they need at least {MIN_SUBJECTS} "
            "subjects with electrostatic forces).")


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
        ``fit.json`` (its ``population``: subjects, notes, outliers).
    figures : sequence of mapping
        fit.json's figure records, each with its ``file``.
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
        notes = [] if friction_only else notes[1:]
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
    only_mu = set(table["quantity"].astype(str)) == {"mu"}
    report.add_table(_quantities(table), "The population's friction coefficient μ" if only_mu
                     else "The population's power law, μ and air gap",
                     caption="Population value [95 % interval]; the spread as the standard "
                             "deviation of the subjects' μ." if only_mu else
                     "Population value [95 % interval]; for k and h_L the geometric mean, the "
                     "spread as the factor of one standard deviation of their log.",
                     section=SECTION, wrap=True)
    if contrasts is not None and not contrasts.empty:
        report.add_table(_contrasts_view(contrasts), "Between conditions",
                         caption="Within subjects measured in both: the ratio of F_el (over "
                                 "the amplitudes each has in both) and the difference of the "
                                 "exponents, pooled over subjects.", section=SECTION)
    outliers = _outliers(doc)
    if outliers:
        report.add_list(outliers, "Outliers", section=SECTION)
    if notes:
        report.add_list(notes, "Not estimated", section=SECTION)
    for f in figures:
        if f.get("kind") == "population":
            report.add_figure(f["file"], str(f.get("title") or f.get("stem")),
                              caption=str(f.get("caption") or ""), section=SECTION)
    report.add_text(_methods_text(table, doc), "For a methods section", section=SECTION)
    return headlines
