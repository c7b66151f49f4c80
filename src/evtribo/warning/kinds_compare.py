"""The kinds of warning of the comparison (``evtribo compare``): the model fitted to each
subject's points, its parameters and intervals, the candidate models compared, the
population's estimates (:data:`POPULATION_KINDS`), the figures and the trials' checks.

fit.json keeps them (its ``warnings``) and the report says them with the analysis's, in one
list; :data:`COMPARE_IDS` tells them apart (they concern the fit and the population's
estimates, not the cells of electrostatic.csv)."""

from __future__ import annotations

from evtribo.warning.kind import Kind

__all__ = ["COMPARE_IDS", "COMPARE_KINDS", "POPULATION_KINDS"]

_FIT = (
    Kind("parameter-undetermined", "interval", "a model parameter the data do not determine",
         "subject {subject}: {parameter} is not determined by these data (the forces hardly "
         "depend on it, or its effect cannot be told apart from the other fitted "
         "parameters'); interval is infinite",
         "Leave it out of compare --fit (its value then from --params), or record amplitudes "
         "or frequencies where it changes the forces.", "subject", prefixed=False),
    Kind("forces-zero", "interval", "model parameters of forces that do not differ from zero",
         "subject {subject}: {parameters} is not determined by these data: its forces do not "
         "differ from zero (every point within its error of it); no value, the interval holds "
         "the values whose forces the points would have seen excluded (profile)",
         "Nothing to fit there: record higher voltages, or longer, for forces that differ "
         "from zero.", "subject", prefixed=False),
    Kind("parameters-correlated", "interval", "model parameters the data hardly tell apart",
         "subject {subject}: {first} and {second} are strongly correlated (r = {r:.3f}): the "
         "data hardly tell them apart",
         "Fit one of the two only (compare --fit, the other from --params), or record where "
         "their effects differ.",
         "subject", prefixed=False),
    Kind("replicates-missing", "interval", "intervals from the Jacobian: replicates missing",
         "subject {subject}: electrostatic_bootstrap.csv lacks replicates of some of its "
         "points; intervals from the Jacobian",
         "Analyse the study again (evtribo analyze) to have every point's replicates.",
         "subject", prefixed=False),
    Kind("refits-failed", "interval", "intervals from the Jacobian: refits failed",
         "subject {subject}: intervals from the Jacobian (points taken as independent): only "
         "{converged} of {refits} refits converged",
         "Look at the subject's fit: the parameters may be near their bounds, or not "
         "determined.", "subject", prefixed=False),
    Kind("points-unweighted", "interval", "points without a usable interval",
         "subject {subject}: {points} point(s) without a usable interval; weighted like the "
         "median point ({sigma_N:.3g} N)",
         "Look at the points' windows (too few, or none ON or OFF).", "subject",
         prefixed=False),
    Kind("intervals-none", "interval", "no usable interval: fitted unweighted",
         "subject {subject}: no usable intervals in electrostatic.csv; fitting unweighted, "
         "uncertainty from the scatter",
         "Look at the subject's windows (too few, or none ON or OFF).", "subject",
         prefixed=False),
    Kind("points-missing", "number", "points with missing values left out of the fit",
         "subject {subject}: {points} point(s) with missing values left out",
         "Look at the subject's rows of electrostatic.csv: a value the fit needs is "
         "missing.", "subject", prefixed=False),
    Kind("model-failed", "information", "a model that could not be fitted",
         "model {model}, subject {subject}: {error}",
         "Nothing to do for the other models; the message says why this one failed.",
         "subject", prefixed=False),
)

_INTERVALS = (
    Kind("intervals-bootstrap", "information", "the fit's intervals from the bootstrap",
         "Intervals of {subjects}: 2.5-97.5 % percentiles of the parameters refitted to the "
         "bootstrap replicates of the electrostatic forces ({replicates} replicates, "
         "electrostatic_bootstrap.csv), which carry the errors the points share through a "
         "common OFF reference.",
         "Nothing to do: these intervals hold the errors the points share.", "study",
         prefixed=False),
    Kind("bootstrap-missing", "number", "the fit's intervals from the Jacobian: no replicates",
         "No electrostatic_bootstrap.csv in the result folder (results of an older evtribo "
         "analyze?): intervals from the Jacobian, with each point's error taken as "
         "independent; they are too narrow when several amplitudes share an OFF reference. "
         "Re-run evtribo analyze to get the replicates.",
         "Analyse the study again (evtribo analyze), then compare again: the intervals then "
         "come from the replicates.", "study", prefixed=False),
    Kind("intervals-jacobian", "number", "a subject's intervals from the Jacobian",
         "Intervals of {subject} from the Jacobian (each point's error taken as "
         "independent): {why}.",
         "Read the subject's intervals as too narrow where its amplitudes share an OFF "
         "reference; the reason says what to look at.", "subject", prefixed=False),
    Kind("intervals-profile", "information", "a parameter's interval from its profile",
         "{why}.", "Nothing to do: the interval is the profile's, where the forces do not "
         "determine the value.", "subject"),
    Kind("fit-none", "information", "no model fit: no electrostatic force",
         "No electrostatic force in these results (no subject has ON windows to compare with "
         "its OFF ones): no model fit; each subject's friction coefficient μ is in the "
         "report.",
         "Record ON phases (the voltage on) beside the OFF ones for a fit of the model.",
         "study", prefixed=False),
)

_MODELS = (
    Kind("models-ranked", "information", "the candidate models ranked over the study",
         "Models over the study ({criterion}; each model's criterion summed over the "
         "subjects): {verdict}.",
         "Nothing to do; models.csv has each subject's ranking.", "study", prefixed=False),
    Kind("model-not-fitted", "information", "a candidate model not fitted to a subject",
         "Model {model} of {subject} could not be fitted: {why}",
         "Nothing to do for the other models; the message says why this one failed.",
         "subject", prefixed=False),
    Kind("model-at-bound", "number", "a candidate model's parameter at its bound",
         "Model {model}: {parameter} at its bound for {subjects} (the data do not set it; "
         "models.csv's fitted holds the bound, not an estimate).",
         "Read that parameter as undetermined: record where it changes the forces (other "
         "frequencies or amplitudes) to estimate it.", "study", prefixed=False),
    Kind("models-one-frequency", "information", "drives at a single frequency",
         "{subjects} subject(s) with each drive at a single frequency: no figure of F_el "
         "against the frequency for them, and the models are told apart by the voltage "
         "alone (the circuit's leak needs a drive at two frequencies or more).",
         "Record a drive at two frequencies or more to tell the models apart by frequency.",
         "study", prefixed=False),
)

_NEEDS = "Measure at least three subjects for the population's estimates."
_META = "Nothing to do: the mixed model's row is there; record longer there for this one."

#: The population's kinds (its notes in fit.json's ``population``).
POPULATION_KINDS: tuple[Kind, ...] = (
    Kind("population-rule-unread", "number", "the [population] rule not read",
         "the study folder {study_dir} was not there: its study.toml's [population] rule was "
         "not read, and every subject is in the population's estimates",
         "Run compare where the study folder is (summary.json's study_dir), so that its "
         "rule counts.", "study", prefixed=False),
    Kind("population-excluded", "information", "subjects excluded by the study's rule",
         "excluded from the population's estimates by the study's rule written beforehand "
         "(study.toml [population]): {reason}",
         "Nothing to do: the rule was written before the analysis.", "subject"),
    Kind("population-too-few", "number", "too few subjects for the population",
         "{subjects} subject(s) with electrostatic forces: a population estimate needs at "
         "least {needed}, so none was made of F_el, its power law or h_L", _NEEDS, "study",
         prefixed=False),
    Kind("population-cell-no-interval", "number", "a cell without an interval left out",
         "{subject}, {drive}, {amplitude_V:g} V: F_el without an interval: left out of the "
         "population estimates",
         "Look at the cell's windows (too few, or none ON or OFF).", "cell", prefixed=False),
    Kind("population-cell-not-positive", "number", "a cell whose F_el is not positive",
         "{subject}, {drive}, {amplitude_V:g} V: F_el not positive (no logarithm): counted "
         "in the mixed model on the linear scale, left out of the meta-analysis of log F_el "
         "and of the contrasts",
         "Nothing to do if the force is small there; record longer at this amplitude to tell "
         "it from zero.", "cell", prefixed=False),
    Kind("population-pool-few", "number", "too few subjects to pool a quantity",
         "{what}: {subjects} subject(s) to pool; a population estimate needs at least "
         "{needed}", _NEEDS, "study", prefixed=False),
    Kind("population-drive-few", "number", "too few subjects with a drive",
         "{drive}: {subjects} subject(s) with electrostatic forces; a population estimate "
         "needs at least {needed}", _NEEDS, "study", prefixed=False),
    Kind("population-one-amplitude", "number", "a drive at one amplitude: no power law",
         "{drive}: one amplitude only, no power law; the force there from the meta-analysis "
         "of log F_el where it is valid",
         "Record the drive at two amplitudes or more for the population's power law.",
         "study", prefixed=False),
    Kind("population-amplitudes-few", "number", "fewer amplitudes than the model needs",
         "{drive}: {amplitudes} amplitudes, fewer than the {model} model needs ({needed}); "
         "the force there from the meta-analysis of log F_el where it is valid",
         "Record the drive at more amplitudes, or choose another [population] model.",
         "study", prefixed=False),
    Kind("population-model-failed", "number", "the mixed model could not be fitted",
         "{drive}: the mixed model with random {effects} could not be fitted ({error})",
         "Look at the drive's cells (the population's figure): a subject's cells far off, or "
         "too few amplitudes.", "study", prefixed=False),
    Kind("population-checks-failed", "number", "the mixed model's checks failed",
         "{drive}: the mixed model's checks failed: {checks}; read its rows with care",
         "Read the drive's population rows as unsure: population.csv's checks name what "
         "failed.", "study", prefixed=False),
    Kind("population-singular", "information", "no spread between subjects estimated",
         "{drive}: {singular}",
         "Nothing to do: the subjects differ no more than their errors say.", "study",
         prefixed=False),
    Kind("population-meta-few", "number", "no meta-analysis: too few subjects",
         "{drive}, {amplitude_V:g} V: no meta-analysis of log F_el ({subjects} subject(s) "
         "measured there; it needs {needed})", _META, "study", prefixed=False),
    Kind("population-meta-invalid", "number", "no meta-analysis: an interval reaches zero",
         "{drive}, {amplitude_V:g} V: no meta-analysis of log F_el (a subject's interval "
         "there reaches zero, or its log standard error is over {max_log_se:g})", _META,
         "study", prefixed=False),
    Kind("population-air-gap-undetermined", "number", "a subject's air gap left out",
         "its fitted air gap h_L is not determined by its data (no finite interval): left "
         "out of the population's",
         "Look at the subject's fit: fit h_L alone (compare --fit h_L), or record more "
         "amplitudes.", "subject"),
    Kind("population-outlier", "information", "a subject far from the others",
         "{quantity}, {value_text}, outside the other subjects' prediction interval "
         "[{low_text}, {high_text}]",
         "Check the subject's trials (a load cell, the finger's posture, a note) before "
         "reading it as a real difference; population.csv has the estimates without it.",
         "subject"),
    Kind("population-model-note", "number", "a population model's note",
         "{text}", "Read the population model's documentation (study.toml's [population] "
         "model).", "study", prefixed=False),
)

_FIGURES = (
    Kind("sine-trace-none", "information", "no measured sine trace",
         "No measured sine trace (sine_trace.csv: the study has no sine trial with ON and "
         "OFF phases): no friction-versus-time figure; `evtribo model --figures DIR` draws "
         "the model's.",
         "Record a sine trial with ON and OFF phases for the measured trace.", "study",
         prefixed=False),
    Kind("figure-absent", "information", "a figure not drawn", "{text}",
         "The figure's plug-in says why.", "study", prefixed=False),
    Kind("checks-chosen", "information", "trials' checks drawn for some trials",
         "Each trial's check: drawn for the {chosen} of {trials} trials with a warning that "
         "may change a number or widens an interval, or that could not be analysed (a study "
         "of more than {auto_all} trials); `evtribo compare OUT --force --trial-checks all` "
         "draws every trial's (from what the analysis kept of each, no trial analysed again; "
         "the figures drawn before are reused), `evtribo plot trial STUDY SUBJECT TRIAL` "
         "one.",
         "Nothing to do; --trial-checks all draws every trial's check.", "study",
         prefixed=False),
    Kind("checks-study-gone", "information", "no trials' checks: the study folder is gone",
         "The study folder {study_dir} is not there: no check figures of the trials (run "
         "compare where the study is).",
         "Run compare where the study folder is (summary.json's study_dir).", "study",
         prefixed=False),
    Kind("checks-study-unreadable", "information", "no trials' checks: the study unreadable",
         "No check figures of the trials: {error}",
         "Put right what the message names (the study changed since the analysis?).",
         "study", prefixed=False),
    Kind("check-not-analysed", "information", "a trial's check not drawn",
         "Trial {subject}/{trial}: not analysed, so nothing to check: {error}",
         "Nothing to do: the analysis said why it could not analyse the trial.", "trial",
         prefixed=False),
)

#: The comparison's kinds, in the order the documentation lists them.
COMPARE_KINDS: tuple[Kind, ...] = (*_FIT, *_INTERVALS, *_MODELS, *POPULATION_KINDS, *_FIGURES)
#: Their ids.
COMPARE_IDS: frozenset[str] = frozenset(k.id for k in COMPARE_KINDS)

