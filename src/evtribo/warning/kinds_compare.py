"""The kinds of warning of the comparison (``evtribo compare``): the model fitted to each
subject's points, its parameters and intervals, the models compared."""

from __future__ import annotations

from evtribo.warning.kind import Kind

__all__ = ["COMPARE_KINDS"]

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

#: The comparison's kinds, in the order the documentation lists them.
COMPARE_KINDS: tuple[Kind, ...] = _FIT
