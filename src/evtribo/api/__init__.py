"""evtribo from Python (study format §8): a study, its analysis in memory, the model fit.

>>> import evtribo
>>> study = evtribo.open_study("my-study")       # doctest: +SKIP
>>> forces = study.trials[0].forces()            # doctest: +SKIP
>>> results = evtribo.analyze(study)             # doctest: +SKIP
>>> results.save("results")                      # doctest: +SKIP
>>> results = evtribo.load_results("results")    # doctest: +SKIP
>>> fit = evtribo.compare(results)               # doctest: +SKIP

- :mod:`~evtribo.api.study`: :func:`open_study`, :class:`Study`, :class:`Trial` (its
  forces as a DataFrame);
- :mod:`~evtribo.api.results`: :func:`analyze`, :class:`Results` (``save``),
  :func:`load_results`;
- :mod:`~evtribo.api.fit`: :func:`compare`, :class:`Fit` (``save``).

The command line runs the same functions: ``evtribo analyze`` computes and saves as
``analyze(study).save(out)`` does, ``evtribo compare`` fits as :func:`compare` does.
"""

from evtribo.api.fit import Fit, compare
from evtribo.api.load import load_results
from evtribo.api.results import Results, analyze
from evtribo.api.study import Study, Trial, open_study

__all__ = ["Fit", "Results", "Study", "Trial", "analyze", "compare", "load_results",
           "open_study"]
