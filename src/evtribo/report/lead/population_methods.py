"""The Population section's paragraph for a paper's methods section: how the population's
estimates were made, with this study's numbers (:func:`methods_paragraph`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from evtribo import __version__
from evtribo.documents.population_table import FORCE, PopulationTable

__all__ = ["methods_paragraph"]


def methods_paragraph(table: PopulationTable, doc: Mapping[str, Any],
                      excluded: Sequence[Mapping[str, str]]) -> str:
    """A paragraph for a paper's methods section, with this study's numbers.

    Parameters
    ----------
    table : PopulationTable
        population.csv.
    doc : mapping
        fit.json's ``population`` (its ``n_subjects`` and ``exclusion_rule``).
    excluded : sequence of mapping
        The subjects excluded beforehand: ``{"subject", "reason"}`` each.

    Returns
    -------
    str
    """
    gone = "".join(f" {e['subject']} was excluded by a rule written in the study's study.toml "
                   f"before the analysis ({e['reason']})." for e in excluded)
    gone += "".join(f" No exclusion rule was read: {n}." for n in doc.get("exclusion_rule")
                    or [] if isinstance(n, str))
    mu_text = ("each subject's friction coefficient μ (the ratio of its mean friction force "
               "to its mean normal force over its OFF windows, with the delta method's "
               "standard error)")
    most = max((r.n_subjects or 0 for r in table), default=0)
    if not any(r.quantity == FORCE for r in table):
        n = most
        return (f"Population estimates were computed with evtribo {__version__} from the "
                f"per-subject results of {n} subjects: the population's friction "
                f"coefficient is the random-effects mean of {mu_text}, each weighted by its "
                "own standard error (Paule-Mandel between-subject variance, "
                "Hartung-Knapp-Sidik-Jonkman interval; statsmodels). Every subject was in "
                "the estimate; subjects outside the prediction interval of the others "
                "(Higgins et al. 2009, Bonferroni-corrected) were reported, with the "
                "estimate without each." + gone)
    n = int(doc.get("n_subjects") or most)
    slopes = any("intercept and exponent" in r.method for r in table)
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
            f"100 F_el/F_n,ON (in %, at the same press), {mu_text} and the fitted air gap h_L "
            "(on the log scale) were pooled by random-effects meta-analysis (Paule-Mandel "
            "between-subject variance, Hartung-Knapp-Sidik-Jonkman interval, Q-profile "
            "interval of tau; "
            "statsmodels). Each subject's F_el > 0 was tested one-sided, its forces weighted "
            "as U^2, with Holm's correction over subjects. Every subject was in the primary "
            "analysis; subjects outside the prediction interval of the others "
            "(Bonferroni-corrected) were reported, with the estimates without each as a "
            "sensitivity analysis." + gone)
