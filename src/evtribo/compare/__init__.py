"""Model versus experiment: fitting the seed paper's model to results, figures, the report.

Layers, lowest first: :mod:`~evtribo.compare.tables` (reading a result folder),
:mod:`~evtribo.compare.params` (fit names, the user's parameter TOML),
:mod:`~evtribo.compare.fit` (weighted least squares with intervals),
:mod:`~evtribo.compare.plots` (figures, ``ax=None`` returns the Axes),
:mod:`~evtribo.compare.run` (``evtribo compare``) and :mod:`~evtribo.compare.report`
(``evtribo report``: a self-contained HTML file).
"""

from evtribo.compare.fit import (
    ParameterEstimate,
    SubjectFit,
    fit_study,
    fit_subject,
    mean_electrostatic_force,
    mean_friction_force,
    model_exponent,
)
from evtribo.compare.fit_csv import FIT_COLUMNS, fit_table
from evtribo.compare.params import (
    DEFAULT_FIT,
    load_parameters,
    parameter_names,
    resolve_fit_names,
)
from evtribo.compare.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_friction_normal_force,
    plot_friction_time,
    save_figure,
)
from evtribo.compare.report import Report
from evtribo.compare.run import CompareResult, FigureRecord, compare
from evtribo.compare.study_report import build_report
from evtribo.compare.tables import ResultTables, read_results

__all__ = [
    "DEFAULT_FIT",
    "FIT_COLUMNS",
    "CompareResult",
    "FigureRecord",
    "ParameterEstimate",
    "Report",
    "ResultTables",
    "SubjectFit",
    "build_report",
    "compare",
    "fit_study",
    "fit_subject",
    "fit_table",
    "load_parameters",
    "mean_electrostatic_force",
    "mean_friction_force",
    "model_exponent",
    "parameter_names",
    "plot_area_increase",
    "plot_electrostatic_force",
    "plot_friction_normal_force",
    "plot_friction_time",
    "read_results",
    "resolve_fit_names",
    "save_figure",
]
