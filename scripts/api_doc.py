"""Write docs/api.md from the docstrings of evtribo's Python API (``evtribo.api``).

    .venv/bin/python scripts/api_doc.py          # rewrite docs/api.md
    .venv/bin/python scripts/api_doc.py --check  # exit 1 when docs/api.md is out of date

``tests/test_api.py`` runs the check, so the page never disagrees with the code.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import inspect
import sys
from pathlib import Path

from evtribo import api

PAGE = Path(__file__).parents[1] / "docs" / "api.md"

INTRO = '''\
# The Python API

Everything the command line does to a study, from Python (study format §8): open a study,
look at a trial's forces, analyse in memory, save the result folder, read one back, fit the
seed paper's model. The command line runs the same functions: `evtribo analyze` computes
and saves as `evtribo.analyze(study).save(out)` does, `evtribo compare` fits as
`evtribo.compare(results)` does.

```python
import evtribo

study = evtribo.open_study("my-study")      # .trials, .subjects, .rig; the errors of §4
forces = study.trials[0].forces()           # t_s, normal_force_N, tangential_force_N, ...
results = evtribo.analyze(study)            # in memory: .trials .windows .electrostatic ...
results.save("results")                     # the files of §2, as `evtribo analyze` writes
results = evtribo.load_results("results")   # the same tables (+ .fit after compare)
fit = evtribo.compare(results)              # .table (fit.csv as a DataFrame), .figures
fit.population                              # population.csv (study format §10) as a DataFrame
```

`examples/quickstart.ipynb` runs these steps on the recorded study in `data/`.

What to know:

- **Nothing is written until you save.** `evtribo.analyze` writes nothing but the cache of
  decoded trials (`$EVTRIBO_CACHE_DIR`, else `~/.cache/evtribo`); `Results.save(out)` writes
  exactly what `evtribo analyze STUDY --out OUT` writes, with its rules: the folder is
  written as one unit, existing results are refused without `force=True`, a folder inside
  the study or one another process is writing is refused.
- **The same tables either way.** `analyze(...)` and `load_results(...)` give the same
  columns with the same types: names as `str`, counts (`frames`, `n_on`, ...) as nullable
  `Int64`, everything else `float64` (NaN where the CSV cell is empty).
- **The fit in memory, its files from `save`.** `evtribo.compare(results)` runs
  `evtribo compare`'s sequence (the fits, the population, the models asked for with
  `models=`, ranked in `fit.models`) and keeps the same figures as matplotlib figures
  (`fit.figures`, by file stem, the trials' checks among them). `fit.save()` runs
  `evtribo compare` on the results' folder, so the results must be saved first. A folder
  read after `evtribo compare` has `results.fit` (its table, and its figure files under
  `fit.files`); a fit of another analysis is left out with a warning.
- **One object for the result folder.** `Results` is a
  `evtribo.documents.result_folder.ResultFolder`, the one class that reads a result folder
  for the report, the console and the figures too: compare's documents are read when first
  asked for (`results.fit_table`, `results.models`, `results.population`, whose rows are
  found by key: `results.population.row("exponent", Drive("square", 10000.0))`), and a
  subject's cell by key (`results.cell("P01", Drive("square", 10000.0), 140.0)`; `Drive`
  from `evtribo.documents.population_table`). The tables' columns, units and keys are
  declared once, in `evtribo.documents.tables`.
- **`evtribo.compare` is also a package** (`evtribo.fit.fit.fit_study`,
  `evtribo.figures.plots`...): once the API is imported, the package itself can be called
  as the function below.
- **Errors** are evtribo's own exceptions (`evtribo.errors`), those the command line turns
  into exit code 2 with the file and line or key at fault: `StudyError`, `SidecarError`,
  `RigConfigError`, `ConfigError` (a bad setting or parameter name), `LogFormatError`,
  `OutputExistsError`, `OutputBusyError`, `ResultFolderError`, all subclasses of
  `UserInputError`; `AnalysisError` when a trial cannot be analysed.

Regenerated from the docstrings by `python scripts/api_doc.py` (the test suite checks it is
up to date).

'''

ORDER = ("open_study", "Study", "Trial", "analyze", "Results", "load_results", "compare",
         "Fit")
#: Public functions of the API's modules that ``evtribo`` does not re-export.
MORE = ("evtribo.api.study.trial_forces", "evtribo.api.results.typed_table")


def _docstring(obj: object) -> str:
    return f"```text\n{inspect.getdoc(obj)}\n```\n"


def _signature(func: object, prefix: str) -> str:
    sig = str(inspect.signature(func)).replace("'", "")  # type: ignore[arg-type]
    for first in ("self, ", "self", "cls, ", "cls"):
        if sig.startswith(f"({first}"):
            sig = "(" + sig[len(first) + 1:]
            break
    return f"```python\n{prefix}{sig}\n```\n"


def _members(cls: type) -> dict[str, object]:
    """The class's public members, then those it takes from evtribo's classes it is built
    on (:class:`~evtribo.documents.result_folder.ResultFolder` for ``Results``)."""
    out: dict[str, object] = {}
    for klass in cls.__mro__:
        if klass is cls or klass.__module__.startswith("evtribo."):
            for member_name, member in vars(klass).items():
                if not member_name.startswith("_"):
                    out.setdefault(member_name, member)
    return out


def _class(name: str, cls: type) -> list[str]:
    out = [f"## `evtribo.{name}`\n", _docstring(cls)]
    for member_name, member in _members(cls).items():
        if isinstance(member, property | functools.cached_property):
            read = " (read on first use)" if isinstance(member, functools.cached_property) \
                else ""
            out += [f"### `{name}.{member_name}`\n", f"A property{read}.\n",
                    _docstring(member)]
            continue
        func = member.__func__ if isinstance(member, classmethod) else member
        if inspect.isfunction(func):
            out += [f"### `{name}.{member_name}`\n",
                    _signature(func, f"{name}.{member_name}"), _docstring(func)]
    return out


def page() -> str:
    """The page's text."""
    parts = [INTRO, "## Contents\n",
             "\n".join(f"- [`evtribo.{n}`](#evtribo{n.lower()})" for n in ORDER) + "\n"]
    for name in ORDER:
        obj = getattr(api, name)
        if inspect.isclass(obj):
            parts += _class(name, obj)
        else:
            parts += [f"## `evtribo.{name}`\n", _signature(obj, f"evtribo.{name}"),
                      _docstring(obj)]
    parts.append("## In the API's modules\n")
    for dotted in MORE:
        module, name = dotted.rsplit(".", 1)
        obj = getattr(importlib.import_module(module), name)
        parts += [f"### `{dotted}`\n", _signature(obj, dotted), _docstring(obj)]
    return "\n".join(parts)


def main() -> int:
    """Write or check the page; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 when docs/api.md differs from the docstrings")
    args = parser.parse_args()
    text = page()
    if args.check:
        if PAGE.read_text(encoding="utf-8") != text:
            print(f"{PAGE} is out of date: run python scripts/api_doc.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
