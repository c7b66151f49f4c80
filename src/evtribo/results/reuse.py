"""What an analysis can take from the last one instead of doing again.

Two things are kept in the cache folder (:func:`evtribo.canlog.cache.default_cache_dir`, or the
``cache_dir`` given), beside the decoded trials:

- **the inputs' hashes** (``inputs/<study>.json``, :class:`evtribo.store.memo.HashMemo`): a
  file whose size, modification and change times, inode and device are those it had when
  it was hashed, its change time settled before that, is not read again;
- **each trial's outcome** (``results/<key>.<checksum>.json``): its row of trials.csv, its
  windows, its sine trace and its warnings, under a key of everything its analysis depends
  on: the log's SHA-256, the trial as the study names it (subject, names, paths, sidecar),
  the rig (DBC bytes, roles, calibration), the settings, ``strict``, and the software (the
  SHA-256 of evtribo's own source files and the versions of Python and the libraries).
  Change any of them and the trial is analysed again. A trial that failed is never kept.
  As for decoded trials, ``<checksum>`` is the start of the SHA-256 of the file's bytes,
  checked on every read;
- **each trial's sketch** (``checks/<key>.<checksum>.sketch``, under the same key): what
  its check's figure draws (:class:`~evtribo.results.trial_sketch.TrialSketch`), which ``evtribo
  compare`` finds there (:func:`evtribo.results.trial_view.kept_sketches`) instead of analysing
  the trial again. It is kept with ``--recompute`` too.

A reused outcome is the one an analysis of the same inputs gives (the analysis of a trial
is deterministic); ``analyze --recompute`` (``reuse=False``) analyses every trial again.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
from collections.abc import Iterable, Mapping
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from evtribo.results.trial_sketch import TrialSketch
from evtribo.store.files import read_entry, write_checksummed
from evtribo.store.memo import software_fingerprint
from evtribo.warning.record import WarningRecord

if TYPE_CHECKING:
    from evtribo.canlog.rig import Rig
    from evtribo.results.workers import TrialOutcome, TrialTask
    from evtribo.study import TrialRef

log = logging.getLogger(__name__)

__all__ = ["SKETCHES", "OutcomeStore", "analysis_context", "context_text", "keep_outcome",
           "kept_outcomes", "source_fingerprint"]

#: Bumped whenever what an outcome file holds changes (2: its warnings as records).
OUTCOME_VERSION = 2
#: The folder of the kept sketches in the cache folder.
SKETCHES = "checks"


@cache
def source_fingerprint() -> str:
    """What a reused outcome must have been computed with: the SHA-256 of evtribo's source
    files and the versions of Python and the libraries the analysis runs on
    (:func:`evtribo.store.memo.software_fingerprint`), and :data:`OUTCOME_VERSION`.

    Returns
    -------
    str
    """
    return hashlib.sha256(f"v{OUTCOME_VERSION}\0{software_fingerprint()}".encode()).hexdigest()


def _plain(value: Any) -> Any:
    """A value JSON writes exactly (numpy scalars as Python's)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return os.fspath(value)
    raise TypeError(f"cannot keep {type(value).__name__}")


def _frame_to_json(df: pd.DataFrame | None) -> dict[str, Any] | None:
    if df is None:
        return None
    return {"columns": [str(c) for c in df.columns],
            "dtypes": [str(t) for t in df.dtypes],
            "data": [df[c].tolist() for c in df.columns]}


def _frame_from_json(obj: Mapping[str, Any] | None) -> pd.DataFrame | None:
    if obj is None:
        return None
    return pd.DataFrame({c: pd.Series(v, dtype=t) for c, v, t in
                         zip(obj["columns"], obj["data"], obj["dtypes"], strict=True)},
                        columns=list(obj["columns"]))


class OutcomeStore:
    """Trials' outcomes kept under a key of everything their analysis depends on.

    Parameters
    ----------
    directory : path-like or None
        The cache folder (None: nothing is kept).
    context : str
        What every trial of this analysis shares (rig, settings, strict), as text
        (:func:`analysis_context`).
    sketches : path-like, optional
        The cache folder the trials' sketches are kept in (default: *directory*; None
        with it: none kept).
    """

    def __init__(self, directory: str | os.PathLike[str] | None, context: str, *,
                 sketches: str | os.PathLike[str] | None = None) -> None:
        self.directory = None if directory is None else \
            Path(directory).expanduser() / "results"
        folder = sketches if sketches is not None else directory
        self.sketches = None if folder is None else Path(folder).expanduser() / SKETCHES
        self._base = hashlib.sha256(f"{source_fingerprint()}\0{context}".encode())
        self._keys: dict[int, str] = {}

    def key(self, trial: str, log_sha256: str) -> str:
        """The key of a trial (its description as text) whose log has this hash."""
        h = self._base.copy()
        h.update(f"\0{log_sha256}\0{trial}".encode("utf-8", "surrogateescape"))
        return h.hexdigest()[:40]

    def trial_key(self, task: TrialTask) -> str:
        """The key of a trial of this analysis (worked out once: the outcome is looked for
        before the analysis and kept after it)."""
        if task.index not in self._keys:
            self._keys[task.index] = self.ref_key(task.ref, task.log[0])
        return self._keys[task.index]

    def ref_key(self, ref: TrialRef, log_sha256: str) -> str:
        """The key of a trial as the study names it, whose log has this hash: its files
        named within the study (``P01/run-01.log``), not by where the study is or how its
        path was spelt (compare finds what ``analyze study`` kept from ``/abs/study``)."""
        def within(path: Path) -> Path:
            return Path(path.parent.name, path.name)

        sidecar = None if ref.sidecar_path is None else within(ref.sidecar_path)
        return self.key(context_text(trial=dataclasses.replace(
            ref, log_path=within(ref.log_path), sidecar_path=sidecar)), log_sha256)

    def get_sketch(self, key: str) -> TrialSketch | None:
        """The sketch kept under *key*, or None (a damaged one is removed)."""
        if self.sketches is None:
            return None
        return read_entry(self.sketches, key, ".sketch", TrialSketch.from_bytes,
                          what="kept sketch", then="the trial is analysed again for its check")

    def put_sketch(self, key: str, data: bytes) -> None:
        """Keep a trial's sketch (its bytes) under *key*; a cache folder that cannot be
        written is not an error (compare then analyses the trial for its check)."""
        if self.sketches is None:
            return
        try:
            write_checksummed(self.sketches, key, data, ".sketch")
        except OSError as err:
            log.debug("sketch not kept under %s: %s", key, err)

    def get(self, key: str) -> dict[str, Any] | None:
        """The outcome kept under *key* (``row``, ``windows``, ``warnings``, ``trace``), or
        None; a damaged file is removed."""
        if self.directory is None:
            return None

        def parse(data: bytes) -> dict[str, Any]:
            obj = json.loads(data)
            return {"row": dict(obj["row"]),
                    "warnings": [WarningRecord.from_json(w) for w in obj["warnings"]],
                    "windows": _frame_from_json(obj["windows"]),
                    "trace": _frame_from_json(obj["trace"])}
        return read_entry(self.directory, key, ".json", parse, what="kept outcome",
                          then="the trial is analysed again")

    def put(self, key: str, row: Mapping[str, Any], windows: pd.DataFrame,
            warnings: Iterable[WarningRecord], trace: pd.DataFrame | None) -> None:
        """Keep a trial's outcome under *key* (a cache folder that cannot be written, or an
        value JSON cannot hold, is not an error: the trial is analysed next time)."""
        if self.directory is None:
            return
        obj = {"row": dict(row), "warnings": [w.as_json() for w in warnings],
               "windows": _frame_to_json(windows), "trace": _frame_to_json(trace)}
        try:
            write_checksummed(self.directory, key, json.dumps(obj, default=_plain).encode(),
                              ".json")
        except (OSError, TypeError, ValueError) as err:
            log.debug("outcome not kept under %s: %s", key, err)


def context_text(**parts: Any) -> str:
    """The text of what every trial of an analysis shares (dataclasses by their fields).

    Parameters
    ----------
    **parts
        Named values (dataclasses, strings, numbers).

    Returns
    -------
    str
    """
    try:  # JSON's encoder walks the lists and dicts of a sidecar in C
        return json.dumps(parts, sort_keys=True, default=_plain_part)
    except TypeError:  # a key JSON cannot hold (a tuple's, say): every key as text
        def plain(v: Any) -> Any:
            v = _plain_part(v) if not isinstance(v, _JSON_VALUES) else v
            if isinstance(v, dict):
                return {str(k): plain(x) for k, x in v.items()}
            if isinstance(v, list | tuple):
                return [plain(x) for x in v]
            return v
        return json.dumps({k: plain(v) for k, v in parts.items()}, sort_keys=True)


#: What JSON writes as it is.
_JSON_VALUES = (dict, list, tuple, str, int, float, bool, type(None))


def _plain_part(v: Any) -> Any:
    """A value of :func:`context_text` JSON does not write itself: a dataclass as its
    compared fields, a mapping as a dict, anything else as its ``repr``."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: getattr(v, f.name) for f in dataclasses.fields(v) if f.compare}
    if isinstance(v, Mapping):
        return dict(v)
    return repr(v)


def analysis_context(rig: Rig, settings: Any, strict: bool) -> str:
    """What every trial of an analysis shares, as text: the rig (its DBC's bytes, roles and
    calibration), the settings and ``strict``.

    Parameters
    ----------
    rig : Rig
        The study's rig.
    settings : AnalysisSettings
        The analysis settings.
    strict : bool
        Whether a damaged line is an error.

    Returns
    -------
    str
    """
    return context_text(rig=rig.fingerprint(), calibration=rig.calibration, settings=settings,
                        strict=strict)


def kept_outcomes(store: OutcomeStore, tasks: list[TrialTask]
                  ) -> tuple[list[TrialOutcome], list[TrialTask]]:
    """The outcomes a former analysis of the same inputs kept, and the tasks still to run
    (the analysis says the kept outcomes' warnings with the others').

    Parameters
    ----------
    store : OutcomeStore
        Where outcomes are kept.
    tasks : list of TrialTask
        The trials to analyse.

    Returns
    -------
    kept : list of TrialOutcome
    todo : list of TrialTask
    """
    from evtribo.analysis.trial import empty_windows
    from evtribo.results.workers import TrialOutcome

    kept, todo = [], []
    for task in tasks:
        found = store.get(store.trial_key(task))
        if found is None:
            todo.append(task)
            continue
        kept.append(TrialOutcome(task.index, found["row"],
                                 found["windows"] if found["windows"] is not None
                                 else empty_windows(), found["warnings"], None,
                                 found["trace"]))
    if kept:
        log.info("%d of %d trials as a former analysis of the same inputs left them",
                 len(kept), len(tasks))
    return kept, todo


def keep_outcome(store: OutcomeStore, task: TrialTask, outcome: TrialOutcome) -> None:
    """Keep the outcome of a trial analysed (one that failed is analysed again).

    Parameters
    ----------
    store : OutcomeStore
        Where outcomes are kept.
    task : TrialTask
        The trial analysed.
    outcome : TrialOutcome
        Its outcome.
    """
    if outcome.error is None:
        key = store.trial_key(task)
        store.put(key, outcome.row, outcome.windows, outcome.warnings, outcome.trace)
        if outcome.sketch is not None:
            store.put_sketch(key, outcome.sketch)
