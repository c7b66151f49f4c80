"""evtribo: tribometer experiments on electrovibration.

The data's way, package by package: ``canlog`` (CAN logs read and decoded through the rig's
DBC), ``analysis`` (one trial: its forces, windows, friction and electrostatic force),
``results`` (a study's trials analysed and gathered into the result tables), ``fit`` (the
seed paper's ``model`` fitted per subject), ``population`` (from subjects to the
population), ``figures`` and ``report``; beside them ``acquisition`` (recording from a bus,
the simulated rig), ``store`` (files written safely), ``util``, ``api`` (the Python
interface below) and ``cli`` (docs/architecture.md draws it).

The Python interface (study format §8; :mod:`evtribo.api`, imported on first use so that
``import evtribo`` stays light)::

    import evtribo
    study = evtribo.open_study("my-study")      # .trials, .subjects, .rig
    forces = study.trials[0].forces()           # t_s, normal_force_N, tangential_force_N, ...
    results = evtribo.analyze(study)            # in memory: .trials .windows .electrostatic ...
    results.save("results")                     # the files of `evtribo analyze`
    results = evtribo.load_results("results")   # the same tables (+ .fit after compare)
    fit = evtribo.compare(results)              # .table (fit.csv), .figures
"""

from __future__ import annotations

import importlib
from typing import Any

#: The names of :mod:`evtribo.api`, re-exported here.
_API = ("Fit", "Results", "Study", "Trial", "analyze", "compare", "load_results",
        "open_study")

__all__ = ["Fit", "Results", "Study", "Trial", "__version__", "analyze", "compare",
           "load_results", "open_study"]

#: evtribo's version: the one place it is written (pyproject.toml's build, the
#: documentation and ``evtribo --version`` read it from here).
__version__ = "0.2.0"


def __getattr__(name: str) -> Any:
    """The names of :mod:`evtribo.api`, imported on first use (PEP 562)."""
    if name in _API:
        api = importlib.import_module("evtribo.api")
        value = getattr(api, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'evtribo' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_API})
