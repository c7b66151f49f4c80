"""The result tables, each declared once (:class:`TableSchema`: its file, its columns with
their kind, unit and meaning, its key, the columns a reader needs, those older folders
lack; :mod:`evtribo.documents.schema`), with one typing, one reader and one writer; and the
result folder's file names.

analyze's tables are :data:`TRIALS`, :data:`WINDOWS`, :data:`ELECTROSTATIC`,
:data:`EXPONENTS`, :data:`BOOTSTRAP`, :data:`SINE_TRACE`; compare's :data:`FIT`,
:data:`MODELS`, :data:`POPULATION`, :data:`CONTRASTS`, :data:`POPULATION_SUBJECTS`. The code
that computes a table takes its columns from here (``TRIAL_COLUMNS = TRIALS.names()``).

The typing, reading and writing every table shares are :mod:`evtribo.documents.schema`'s.
"""

from __future__ import annotations

from evtribo.documents.fit import FIT_JSON
from evtribo.documents.schema import Column, Kind, TableSchema
from evtribo.documents.schema import column as _c
from evtribo.documents.summary import SUMMARY_FILE

__all__ = ["ANALYSIS_FILES", "ANALYSIS_TABLES", "BOOTSTRAP", "BOOTSTRAP_FILE",
           "COMPARE_TABLES", "CONTRASTS", "COUNT_COLUMNS", "ELECTROSTATIC",
           "EXPONENTS", "FIT", "FIT_CSV", "MODELS", "MODELS_CSV", "NEWER_COLUMNS",
           "OUTPUT_FILES", "POPULATION", "POPULATION_CONTRASTS_CSV", "POPULATION_CSV",
           "POPULATION_SUBJECTS", "POPULATION_SUBJECTS_CSV", "SCHEMAS", "SINE_TRACE",
           "SINE_TRACE_FILE", "TEXT_COLUMNS", "TRIALS", "WINDOWS", "Column", "Kind",
           "TableSchema"]

# --- the result folder's files ---------------------------------------------------------------

#: The bootstrap replicates of electrostatic.csv (an addition to the study format), and a
#: stretch of each sine trial's forces around a switch from OFF to ON (for compare).
BOOTSTRAP_FILE, SINE_TRACE_FILE = "electrostatic_bootstrap.csv", "sine_trace.csv"
#: The files ``evtribo analyze`` always writes into its output folder.
OUTPUT_FILES = ("trials.csv", "windows.csv", "electrostatic.csv", "exponents.csv",
                SUMMARY_FILE, BOOTSTRAP_FILE)
#: Every file of analyze's.
ANALYSIS_FILES = (*OUTPUT_FILES, SINE_TRACE_FILE)
#: compare's fit (a row per subject and fitted parameter), its comparison of the candidate
#: models (``compare --models``), the population's estimates (study format §10), and each
#: subject's relative friction increase and test of F_el > 0.
FIT_CSV, MODELS_CSV = "fit.csv", "models.csv"
POPULATION_CSV, POPULATION_CONTRASTS_CSV = "population.csv", "population_contrasts.csv"
POPULATION_SUBJECTS_CSV = "population_subjects.csv"
#: compare's tables (and fit.json).
COMPARE_TABLES = (FIT_CSV, FIT_JSON, MODELS_CSV, POPULATION_CSV, POPULATION_CONTRASTS_CSV,
                  POPULATION_SUBJECTS_CSV)


# --- analyze's tables (study format §2) ---------------------------------------------------

_SUBJECT = _c("subject", "text", "the subject's name")
_TRIAL = _c("trial", "text", "the trial's name")
_WAVEFORM = _c("waveform", "text", "the drive's waveform: square or sine")
_FREQUENCY = _c("frequency_Hz", "Hz", "the drive's frequency")
_AMPLITUDE = _c("amplitude_V", "V", "the drive's amplitude (0 for OFF)")
_LOW, _HIGH = "its 95 % interval: low end", "its 95 % interval: high end"
_OUT = "seconds of the trial left out"

#: trials.csv: one row per trial.
TRIALS = TableSchema("trials.csv", (
    _SUBJECT, _TRIAL, _WAVEFORM, _FREQUENCY, _AMPLITUDE,
    _c("condition", "text", "on, off, or alternating"),
    _c("duration_s", "s", "the trial's length"),
    _c("frames", "count", "frames of the rig's messages decoded"),
    _c("dropped_frames", "count", "frames missing by the counters, else by timing"),
    _c("skipped_lines", "count", "damaged lines of the log skipped"),
    _c("friction_modulation_Hz", "Hz", "the friction's dominant frequency while ON (sine)"),
    _c("normal_offset_N", "N", "the normal cell's zero offset removed"),
    _c("tangential_offset_N", "N", "the tangential cell's zero offset removed"),
    _c("tare", "text", "how they were found: lifted, friction-loop, calibration, none"),
    _c("mu_change_per_10s", "1/(10 s)", "the friction coefficient's change per 10 s"),
    _c("crosstalk_normal", "", "the share of the tangential force the normal cell reads"),
    _c("crosstalk_normal_se", "", "its standard error"),
    _c("tangential_direction_share", "", "the tangential reading that follows the normal "
       "force in both directions, per unit of normal force"),
    _c("analysed_s", "s", "seconds inside the steady-sliding windows"),
    _c("excluded_switch_s", "s", f"{_OUT} around the ON/OFF switches"),
    _c("excluded_lift_s", "s", f"{_OUT} with the finger lifted"),
    _c("excluded_unsteady_s", "s", f"{_OUT} as not steady sliding"),
    _c("excluded_other_s", "s", f"{_OUT} for other reasons (no status, no data)"),
    _c("duplicate_frames", "count", "frames received twice, counted once"),
), key=("subject", "trial"), required=("subject", "trial"),
    newer=frozenset({"duplicate_frames", "analysed_s", "excluded_switch_s", "excluded_lift_s",
                     "excluded_unsteady_s", "excluded_other_s"}))

#: windows.csv: one row per steady-sliding window used.
WINDOWS = TableSchema("windows.csv", (
    _SUBJECT, _TRIAL, _c("condition", "text", "on or off"), _AMPLITUDE, _WAVEFORM,
    _c("t_start_s", "s", "the window's start, from the trial's"),
    _c("t_end_s", "s", "the window's end, from the trial's"),
    _c("normal_force_N", "N", "the mean normal force"),
    _c("friction_force_N", "N", "the mean friction force (a magnitude)"),
    _c("direction", "", "the sliding direction, +1 or -1"),
    _c("stroke", "", "the window's stroke, numbered in its trial"),
    _c("stroke_s", "s", "that stroke's duration"),
    _c("mu_reference", "", "the friction coefficient an ON window was compared with"),
), key=("subject", "trial", "t_start_s"),
    required=("subject", "trial", "condition", "amplitude_V", "waveform", "normal_force_N",
              "friction_force_N"))

#: electrostatic.csv: one row per subject, drive and amplitude with ON windows.
ELECTROSTATIC = TableSchema("electrostatic.csv", (
    _SUBJECT, _WAVEFORM, _FREQUENCY, _AMPLITUDE,
    _c("mu", "", "the friction coefficient the ON windows were compared with"),
    _c("normal_force_on_N", "N", "the mean normal force ON"),
    _c("normal_force_off_N", "N", "the mean normal force OFF"),
    _c("friction_on_N", "N", "the mean friction force ON"),
    _c("friction_off_N", "N", "the mean friction force OFF"),
    _c("electrostatic_force_N", "N", "the inferred F_el = F_t,on/mu - F_n,on, averaged"),
    _c("electrostatic_force_ci_low_N", "N", _LOW),
    _c("electrostatic_force_ci_high_N", "N", _HIGH),
    _c("n_on", "count", "ON windows used"),
    _c("n_off", "count", "OFF windows used"),
    _c("friction_law", "text", "the subject's friction law: amontons or power"),
    _c("friction_exponent", "", "m of the friction law F_t = c W^m"),
    _c("friction_exponent_ci_low", "", _LOW),
    _c("friction_exponent_ci_high", "", _HIGH),
    _c("electrostatic_force_m075_N", "N", "F_el at m = 0.75 (the presses do not tell m)"),
    _c("electrostatic_force_m075_ci_low_N", "N", _LOW),
    _c("electrostatic_force_m075_ci_high_N", "N", _HIGH),
), key=("subject", "waveform", "frequency_Hz", "amplitude_V"),
    required=("subject", "waveform", "amplitude_V", "mu", "normal_force_on_N",
              "electrostatic_force_N", "electrostatic_force_ci_low_N",
              "electrostatic_force_ci_high_N"),
    newer=frozenset({"friction_law", "friction_exponent", "friction_exponent_ci_low",
                     "friction_exponent_ci_high", "electrostatic_force_m075_N",
                     "electrostatic_force_m075_ci_low_N",
                     "electrostatic_force_m075_ci_high_N"}))

#: exponents.csv: one row per subject and drive, the power law F_el = k U^n.
EXPONENTS = TableSchema("exponents.csv", (
    _SUBJECT, _WAVEFORM, _FREQUENCY, _c("exponent", "", "n"),
    _c("exponent_ci_low", "", _LOW), _c("exponent_ci_high", "", _HIGH),
    _c("prefactor_N", "N", "k, the force at U = 1 V"),
), key=("subject", "waveform", "frequency_Hz"),
    required=("subject", "waveform", "exponent", "exponent_ci_low", "exponent_ci_high"))

#: electrostatic_bootstrap.csv: one row per electrostatic.csv row and bootstrap replicate.
BOOTSTRAP = TableSchema(BOOTSTRAP_FILE, (
    _SUBJECT, _WAVEFORM, _FREQUENCY, _AMPLITUDE,
    _c("replicate", "count", "the replicate: one resampling of the subject's windows"),
    _c("electrostatic_force_N", "N", "F_el in that replicate"),
), key=("subject", "waveform", "frequency_Hz", "amplitude_V", "replicate"),
    required=("subject", "waveform", "amplitude_V", "replicate", "electrostatic_force_N"))

#: sine_trace.csv: a sine trial's forces around a switch from OFF to ON. A reader takes a
#: ``voltage_V`` column (V, 0 while OFF) in place of the drive's amplitude and frequency.
SINE_TRACE = TableSchema(SINE_TRACE_FILE, (
    _SUBJECT, _TRIAL, _c("time_s", "s", "from the start of the trace"),
    _c("normal_force_N", "N", "the normal force"),
    _c("friction_force_N", "N", "the friction force (a magnitude)"),
    _c("amplitude_V", "V", "the drive's amplitude (0 while OFF)"), _FREQUENCY,
), key=("subject", "trial", "time_s"), required=("time_s", "normal_force_N", "friction_force_N"),
    either=(("voltage_V",), ("amplitude_V", "frequency_Hz")))


# --- compare's tables ---------------------------------------------------------------------

_IN_UNIT = "in the parameter's unit"
#: fit.csv: one row per subject and fitted parameter.
FIT = TableSchema(FIT_CSV, (
    _SUBJECT, _c("parameter", "text", "the fitted parameter (h_L, E_star, ...)"),
    _c("value", "", f"its estimate, {_IN_UNIT}"),
    _c("ci_low", "", f"{_LOW}, {_IN_UNIT}"), _c("ci_high", "", f"{_HIGH}, {_IN_UNIT}"),
    _c("stderr", "", f"its standard error, {_IN_UNIT}"),
    _c("unit", "text", "the parameter's SI unit"),
    _c("rmse_N", "N", "the fit's root-mean-square residual"),
    _c("r2", "", "the fit's coefficient of determination"),
    _c("chi2_reduced", "", "the weighted residuals' chi-square per degree of freedom"),
    _c("n_points", "count", "points fitted"), _WAVEFORM,
    _c("exponent", "", "the measured power law's exponent (exponents.csv)"),
    _c("exponent_ci_low", "", _LOW), _c("exponent_ci_high", "", _HIGH),
    _c("exponent_model", "", "the fitted model's exponent over the same amplitudes"),
    _c("mu_measured", "", "the subject's measured friction coefficient"),
), key=("subject", "parameter", "waveform"), required=("subject", "parameter", "value"))

#: models.csv (``compare --models``): one row per subject and candidate model.
MODELS = TableSchema(MODELS_CSV, (
    _SUBJECT, _c("model", "text", "the candidate model: paper, hertz, maugis, circuit"),
    _c("fitted", "text", "its fitted parameters: name=value; ..."),
    _c("n_params", "count", "parameters fitted"), _c("n_points", "count", "points fitted"),
    _c("rss_N2", "N^2", "the residual sum of squares"),
    _c("aic", "", "Akaike's criterion (AICc with few points: see criterion)"),
    _c("bic", "", "the Bayesian information criterion"),
    _c("delta_aic", "", "aic less the subject's lowest"),
    _c("akaike_weight", "", "the model's Akaike weight among the subject's"),
    _c("criterion", "text", "AIC or AICc"),
    _c("at_bound", "text", "the fitted parameters the optimiser left at a bound"),
), key=("subject", "model"),
    required=("subject", "model", "fitted", "n_params", "aic", "delta_aic", "akaike_weight"))

_SPREAD = "the spread between subjects"
#: population.csv (study format §10): the population's estimates.
POPULATION = TableSchema(POPULATION_CSV, (
    _c("quantity", "text", "electrostatic_force_N, exponent, prefactor_N, "
       "friction_increase_pct, mu or h_L_m"), _WAVEFORM, _FREQUENCY,
    _c("amplitude_V", "V", "the amplitude (empty where none applies)"),
    _c("estimate", "", "the population's typical value, in the quantity's unit"),
    _c("ci_low", "", _LOW), _c("ci_high", "", _HIGH),
    _c("between_subject_sd", "", f"{_SPREAD} (of the log for forces, k and h_L)"),
    _c("n_subjects", "count", "subjects that contributed"),
    _c("method", "text", "how it was estimated"),
    _c("analysis", "text", "primary, without S (a subject far from the others), or "
       "meta-analysis"),
    _c("pi_low", "", "the 95 % prediction interval for a new subject: low end"),
    _c("pi_high", "", "the 95 % prediction interval for a new subject: high end"),
    _c("between_sd_low", "", f"{_SPREAD}'s 95 % interval: low end"),
    _c("between_sd_high", "", f"{_SPREAD}'s 95 % interval: high end"),
    _c("i2", "", "I^2: the spread's share of the subjects' scatter"),
    _c("i2_low", "", _LOW), _c("i2_high", "", _HIGH),
    _c("checks", "text", "the mixed model's convergence checks, in words"),
), key=("quantity", "waveform", "frequency_Hz", "amplitude_V", "analysis"),
    required=())

#: population_contrasts.csv (study format §10): two conditions compared within subjects.
CONTRASTS = TableSchema(POPULATION_CONTRASTS_CSV, (
    _c("condition_a", "text", "the first condition (square 10000 Hz)"),
    _c("condition_b", "text", "the second condition"),
    _c("quantity", "text", "electrostatic_force_N (a ratio b/a) or exponent (b - a)"),
    _c("ratio", "", "b/a of the forces"), _c("difference", "", "b - a of the exponents"),
    _c("ci_low", "", _LOW), _c("ci_high", "", _HIGH),
    _c("n_subjects", "count", "subjects measured in both"),
), key=("condition_a", "condition_b", "quantity"), required=())

#: population_subjects.csv: each subject's relative friction increase and test of F_el > 0.
POPULATION_SUBJECTS = TableSchema(POPULATION_SUBJECTS_CSV, (
    _SUBJECT, _WAVEFORM, _FREQUENCY, _AMPLITUDE,
    _c("electrostatic_force_N", "N", "the subject's F_el (electrostatic.csv)"),
    _c("ci_low_N", "N", _LOW), _c("ci_high_N", "N", _HIGH),
    _c("normal_force_N", "N", "the mean normal force ON"),
    _c("friction_increase_pct", "%", "the relative friction increase F_el/F_n,ON"),
    _c("increase_ci_low_pct", "%", _LOW), _c("increase_ci_high_pct", "%", _HIGH),
    _c("z_positive", "", "the one-sided test's z of F_el > 0 (the drive's cells)"),
    _c("p_one_sided", "", "its p"), _c("p_holm", "", "its p adjusted by Holm's method"),
    _c("responds", "flag", "F_el > 0 shown at the family-wise 5 %"),
), key=("subject", "waveform", "frequency_Hz", "amplitude_V"), required=())

#: analyze's tables, in the order written.
ANALYSIS_TABLES = (TRIALS, WINDOWS, ELECTROSTATIC, EXPONENTS, BOOTSTRAP, SINE_TRACE)
#: Every table, analyze's then compare's, by file name.
SCHEMAS = {s.file: s for s in (*ANALYSIS_TABLES, FIT, MODELS, POPULATION, CONTRASTS,
                               POPULATION_SUBJECTS)}
#: The columns of names of analyze's tables, and of counts.
TEXT_COLUMNS = tuple(dict.fromkeys(c.name for s in ANALYSIS_TABLES for c in s.columns
                                   if c.kind == "text"))
COUNT_COLUMNS = tuple(dict.fromkeys(c.name for s in ANALYSIS_TABLES for c in s.columns
                                    if c.kind == "count"))
#: Columns of analyze's tables that a result folder of an earlier evtribo lacks.
NEWER_COLUMNS: frozenset[str] = frozenset().union(*(s.newer for s in ANALYSIS_TABLES))
