"""Parameter descriptions shared by many docstrings, filled in by :func:`fill_doc`.

As in MNE-Python: a docstring names a shared entry as ``%(name)s`` on a line of its own,
and :func:`fill_doc` puts the entry there, indented as that line is. One description per
parameter, however many functions take it.

>>> @fill_doc
... def f(study_dir):
...     '''Do something.
...
...     Parameters
...     ----------
...     %(study_dir)s
...     '''
>>> "The study folder" in f.__doc__
True
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

__all__ = ["docdict", "fill_doc"]

#: Shared parameter descriptions, numpydoc style (first line ``name : type``).
docdict: dict[str, str] = {
    "study_dir": """study_dir : path-like
    The study folder (``study.toml``, one folder per subject holding each trial's log and
    JSON sidecar).""",
    "out_dir": """out_dir : path-like
    The result folder. It is written as one unit: into a new folder beside it, swapped in
    when complete (see :mod:`evtribo.store.resultdir`).""",
    "force": """force : bool
    Replace what the command wrote there before; without it, existing outputs are refused
    (:class:`~evtribo.errors.OutputExistsError`).""",
    "strict": """strict : bool
    A damaged line in a log is an error instead of a warning.""",
    "jobs": """jobs : int, optional
    Worker processes (default: the number of CPUs; 1 works in this process).""",
    "cache_dir": """cache_dir : path-like, optional
    Where decoded trials are cached (default: :func:`evtribo.canlog.cache.default_cache_dir`).""",
    "reuse": """reuse : bool
    Take from the cache the outcome of each trial whose log, sidecar, rig, settings and
    software are those of a former analysis (:mod:`evtribo.results.reuse`); False
    analyses every trial again.""",
    "rig": """rig : Rig
    The rig: its DBC and which signal is which (:class:`evtribo.canlog.rig.Rig`).""",
    "settings": """settings : AnalysisSettings, optional
    The analysis settings (default: the study's ``[analysis]`` table over the package's
    defaults, :class:`evtribo.analysis.settings.AnalysisSettings`).""",
    "progress": """progress : callable, optional
    Called as ``progress(done, total)`` as work completes.""",
    "frames": """frames : FrameTable
    CAN frames, as :func:`evtribo.canlog.io.read_frames` returns them.""",
    "params": """params : ModelParameters, optional
    The model's parameters (default: the seed paper's Table 1,
    :class:`evtribo.model.ModelParameters`).""",
    # --- decoding and analysis (evtribo.canlog.decode, evtribo.canlog.cache, evtribo.analysis) ---
    "signals": """signals : TrialSignals
    The decoded trial (:class:`evtribo.canlog.signals.TrialSignals`, from
    :func:`evtribo.canlog.decode.decode_trial` or :func:`evtribo.canlog.cache.load_trial`): its load
    cells' forces with the frames missing from each, its excitation, its counts and the
    decoder's warnings.""",
    "warn": """warn : callable
    Called with each warning (a sentence) about the trial.""",

    # --- acquisition, frames, rig, study ---

    # --- model, compare, command line ---
    "normal_force": """normal_force : float or ndarray
    External normal force F_ext, N.""",
    "voltage": """voltage : float or ndarray
    Applied voltage U (instantaneous or amplitude), V.""",

}

F = TypeVar("F", bound=Callable[..., object])


def _indented(entry: str, indent: str) -> str:
    first, *rest = entry.splitlines()
    return "\n".join([first, *((indent + line) if line else "" for line in rest)])


def fill_doc(f: F) -> F:
    """Fill a function's or class's docstring with :data:`docdict`'s entries.

    Each ``%(name)s`` is replaced by the entry, its continuation lines indented as the
    placeholder's line is.

    Parameters
    ----------
    f : function or class
        What to document (used as a decorator).

    Returns
    -------
    function or class
        *f*, its docstring filled.

    Raises
    ------
    KeyError
        A placeholder names no entry (at import: a typo cannot ship).
    """
    doc = f.__doc__
    if not doc:
        return f
    lines = []
    for line in doc.splitlines():
        stripped = line.lstrip()
        if stripped.startswith("%(") and stripped.endswith(")s"):
            indent = line[: len(line) - len(stripped)]
            key = stripped[2:-2]
            if key not in docdict:
                raise KeyError(f"{f.__qualname__}: no shared description {key!r} in docdict")
            lines.append(indent + _indented(docdict[key], indent))
        else:
            lines.append(line)
    f.__doc__ = "\n".join(lines)
    return f
