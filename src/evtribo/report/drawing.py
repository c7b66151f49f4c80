"""compare's figures: each keyed by what it shows, reused while that is unchanged, drawn in
worker processes.

A figure comes as a :class:`~evtribo.figures.registry.PlannedFigure` of the figure registry
(:mod:`evtribo.figures.registry`): its names and a :class:`Drawing` (a plotting function
and its arguments, called where the figure is drawn). A drawing's key is the SHA-256 of
what the figure shows and how (:func:`evtribo.report.compare_cache.figure_key`: the function, its
arguments, the width, the software); a file's key adds its format and resolution. Each
file of a drawing is then:

- left as it is in the result folder, not written again, when the last comparison wrote it
  under the same key and it still holds the bytes fit.json records (``output_sha256``);
- else copied from the cache folder (``figures/<key>.<checksum>.<format>``), which keeps
  every figure drawn: after ``analyze --force`` (which removes compare's files), or for a
  trial's check asked again;
- else drawn: in worker processes (started as analyze's are: :func:`evtribo.store.pool.
  init_worker`), or on the Dask cluster compare was given, while compare goes on.

The same figure gives the same bytes wherever it is drawn (no date, a fixed SVG salt:
:func:`evtribo.figures.plots.figure_bytes`). A figure to look at rather than print (a
trial's check: its spec's ``screen``) is written as PNG at most at
:data:`~evtribo.figures.trial_checks.CHECK_DPI` and listed after the others.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evtribo.figures.plots import figure_bytes
from evtribo.figures.registry import Drawing, PlannedFigure
from evtribo.figures.style import journal_style
from evtribo.figures.trial_checks import CHECK_DPI
from evtribo.report.compare_cache import FigureStore, figure_key, file_key
from evtribo.results.outputs import FIGURES
from evtribo.store.files import atomic_write, sha256_file
from evtribo.store.pool import init_worker, stop_workers
from evtribo.store.resultdir import Staging
from evtribo.warning.record import WarningRecord
from evtribo.warning.render import group

log = logging.getLogger(__name__)

__all__ = ["Drawing", "FigureRecord", "Figures", "Look", "Runner", "render", "trials_to_check"]


@dataclass(frozen=True)
class Look:
    """How the figures are written.

    Attributes
    ----------
    dpi : float
        Resolution of the PNGs, dots per inch.
    formats : tuple of str
        The formats asked.
    width : str
        ``single`` or ``double``.
    """

    dpi: float
    formats: tuple[str, ...]
    width: str


@dataclass(frozen=True)
class FigureRecord:
    """One figure written by :func:`~evtribo.report.compare.compare`: its kind, subject (or
    None) and files.

    Parameters
    ----------
    kind : str
        What the figure shows (``electrostatic_force_all``, ``electrostatic_force``...).
    title : str
        A short title (the figure itself has none).
    stem : str
        The files' name in ``figures/`` without suffix.
    subject : str or None
        The subject shown, None for a figure of the whole study.
    caption : str
        What a reader needs to read the figure.
    extra : mapping
        Further keys of the record in fit.json (``trial`` for a trial's figure; ``key`` and
        ``dpi``: what the files were drawn from).

    Returns
    -------
    FigureRecord
    """

    kind: str
    title: str
    stem: str
    subject: str | None
    caption: str
    extra: Mapping[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The record as fit.json lists it.

        Returns
        -------
        dict
            ``kind``, ``title``, ``stem``, ``subject``, ``caption``, then the extra keys.
        """
        return {"kind": self.kind, "title": self.title, "stem": self.stem,
                "subject": self.subject, "caption": self.caption, **self.extra}


def render(job: tuple[str, Drawing, tuple[str, ...], float]) -> dict[str, bytes]:
    """Draw a figure in the journal style and give its bytes in each format (what a worker
    does).

    Parameters
    ----------
    job : tuple
        ``(width, drawing, formats, dpi)``.

    Returns
    -------
    dict
        The bytes of each format.
    """
    width, what, formats, dpi = job
    with journal_style(width):
        return figure_bytes(what.draw().figure, formats, dpi=dpi)


class Runner:
    """Calls run in worker processes (*jobs* > 1, started on first use), on a Dask cluster
    (*scheduler*), or here.

    Parameters
    ----------
    jobs : int
        Worker processes.
    scheduler : distributed.Client, optional
        A Dask cluster to run the calls on instead.
    """

    def __init__(self, jobs: int, scheduler: Any = None) -> None:
        self.jobs = max(1, int(jobs))
        self.scheduler = scheduler
        self._pool: ProcessPoolExecutor | None = None

    def submit(self, func: Callable[[Any], Any], item: Any) -> Any:
        """``func(item)``, as a future (its ``result()``).

        Returns
        -------
        concurrent.futures.Future or distributed.Future
        """
        if self.scheduler is not None:
            return self.scheduler.submit(func, item, pure=False)
        if self.jobs > 1:
            if self._pool is None:
                self._pool = ProcessPoolExecutor(max_workers=self.jobs,
                                                 initializer=init_worker)
            return self._pool.submit(func, item)
        done: Future[Any] = Future()
        try:
            done.set_result(func(item))
        except Exception as err:
            done.set_exception(err)
        return done

    def map(self, func: Callable[[Any], Any], items: list[Any]) -> list[Any]:
        """``func`` of each item, in order.

        Returns
        -------
        list
        """
        return [f.result() for f in [self.submit(func, item) for item in items]]

    def close(self, *, failed: bool = False) -> None:
        """Let the workers go (stopped at once when *failed*)."""
        if self._pool is not None:
            if failed:
                stop_workers(self._pool)
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


@dataclass
class _Pending:
    """A figure being drawn: what to do with its bytes when they come."""

    stem: str
    key: str
    dpi: float
    formats: tuple[str, ...]
    future: Any
    tell: str


class Figures:
    """Writes compare's figures into a staging folder, each file left as it is, copied from
    the cache folder or drawn (see the module's text), and records them.

    Parameters
    ----------
    stage : Staging
        Where the files written go (``figures/<stem>.<fmt>``).
    look : Look
        Formats, resolution and width asked.
    runner : Runner
        Where figures are drawn.
    store : FigureStore
        The figures kept in the cache folder.
    previous : mapping, optional
        The result folder's fit.json, as the last comparison wrote it.
    progress : callable, optional
        Told ``[k/n] <what>`` as each figure whose spec tells of it is done.

    Attributes
    ----------
    records : list of FigureRecord
        Each figure's record in fit.json, those to look at (``screen``) last.
    files : list of Path
        Each figure's files (relative to the folder).
    sha256 : dict of str to str
        Every figure file's SHA-256.
    kept : set of str
        The figure files left as they were.
    """

    def __init__(self, stage: Staging, look: Look, runner: Runner, store: FigureStore, *,
                 previous: Mapping[str, Any] | None = None,
                 progress: Callable[[str], None] | None = None) -> None:
        self.stage, self.look = stage, look
        self.runner, self.store, self.progress = runner, store, progress
        prev = previous or {}
        self.previous = {str(f.get("stem")): f for f in prev.get("figures") or []
                         if isinstance(f, dict)}
        self.previous_sha = {str(k): str(v) for k, v in
                             dict(prev.get("output_sha256") or {}).items()}
        self.records: list[FigureRecord] = []
        self.files: list[Path] = []
        self.sha256: dict[str, str] = {}
        self.kept: set[str] = set()
        self._late: list[FigureRecord] = []
        self._pending: list[_Pending] = []
        self._found: dict[str, str | None] = {}

    def emit(self, figure: PlannedFigure) -> None:
        """Write a figure once per format as ``figures/<stem>.<fmt>`` (or keep it), record it.

        Parameters
        ----------
        figure : PlannedFigure
            The figure, its names and drawing; one to look at (its spec's ``screen``) is
            written as PNG (else in the first format asked) at most at
            :data:`~evtribo.figures.trial_checks.CHECK_DPI` and recorded after the others
            (when :meth:`finish` is called).

        Returns
        -------
        None
        """
        screen = figure.spec.screen
        formats = self.look.formats
        if screen:  # a figure to look at, not to print
            formats = ("png",) if "png" in formats else formats[:1]
        dpi = float(min(self.look.dpi, CHECK_DPI) if screen else self.look.dpi)
        what, stem = figure.drawing, figure.stem
        key = figure_key(what.func, what.args, what.kwargs, self.look.width)
        record = FigureRecord(figure.spec.kind, figure.title, stem, figure.subject,
                              figure.caption, {**figure.placed(), "key": key, "dpi": dpi})
        (self._late if screen else self.records).append(record)
        todo = []
        for fmt in formats:
            rel = f"{FIGURES}/{stem}.{fmt}"
            self.files.append(Path(rel))
            if self._unchanged(rel, stem, key, dpi):
                continue
            data = self.store.get(file_key(key, fmt, dpi), fmt)
            if data is not None:
                self._place(rel, data)
            else:
                todo.append(fmt)
        if not todo and not figure.told:
            return
        future = (self.runner.submit(render, (self.look.width, what, tuple(todo), dpi))
                  if todo else None)
        self._pending.append(_Pending(stem, key, dpi, tuple(todo), future, figure.told))

    def _current(self, rel: str) -> str | None:
        """The SHA-256 of the result folder's file, as it is now (None: none)."""
        if rel not in self._found:
            try:
                self._found[rel] = sha256_file(self.stage.target / rel)
            except OSError:
                self._found[rel] = None
        return self._found[rel]

    def _holds(self, rel: str, sha: str | None) -> bool:
        """Whether the result folder's file is compare's, as written, with these bytes."""
        return sha is not None and self.previous_sha.get(rel) == sha == self._current(rel)

    def _unchanged(self, rel: str, stem: str, key: str, dpi: float) -> bool:
        """Whether the last comparison drew this file from the same key and it is as it
        wrote it (then it is left as it is)."""
        prev = self.previous.get(stem) or {}
        if prev.get("key") != key or prev.get("dpi") != dpi:
            return False
        if not self._holds(rel, self.previous_sha.get(rel)):
            return False
        self.kept.add(rel)
        self.sha256[rel] = self.previous_sha[rel]
        return True

    def _place(self, rel: str, data: bytes) -> None:
        """Write a figure's file, unless the result folder holds these very bytes."""
        sha = hashlib.sha256(data).hexdigest()
        if self._holds(rel, sha):
            self.kept.add(rel)
        else:
            atomic_write(self.stage.path(rel), data)
        self.sha256[rel] = sha

    def finish(self) -> None:
        """Wait for the figures being drawn, write them (and keep them in the cache
        folder), and record the figures to look at after the others.

        Returns
        -------
        None
        """
        told = [p for p in self._pending if p.tell]
        for p in self._pending:
            out = p.future.result() if p.future is not None else {}
            for fmt in p.formats:
                self.store.put(file_key(p.key, fmt, p.dpi), fmt, out[fmt])
                self._place(f"{FIGURES}/{p.stem}.{fmt}", out[fmt])
            if p.tell and self.progress is not None:
                self.progress(f"[{told.index(p) + 1}/{len(told)}] {p.tell}")
        self._pending.clear()
        self.records.extend(self._late)
        self._late.clear()


def trials_to_check(records: Iterable[WarningRecord], trials: Iterable[tuple[str, str]]
                    ) -> set[str]:
    """The trials (``subject/trial``) a warning names that is not only for information: one
    that may change a number or widens an interval (compare draws their checks by default
    in a large study; a drift followed or an offset removed is not a reason to look).

    Parameters
    ----------
    records : iterable of WarningRecord
        The analysis's warnings.
    trials : iterable of (str, str)
        The study's trials, ``(subject, trial)``.

    Returns
    -------
    set of str
    """
    trial_set = {(str(s), str(t)) for s, t in trials}
    return {f"{s}/{t}" for g in group(records) if g.effect != "information"
            for s, t in g.trials if (s, t) in trial_set}
