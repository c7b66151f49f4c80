"""``evtribo analyze`` of a study analysed before, with nothing changed: its result folder
written again from the cache, without loading the study or importing the analysis (numpy,
pandas, scipy, cantools), so that it takes a fraction of a second whatever the study's size.

After each analysis the command keeps, in the cache folder
(``studies/<key>.<checksum>.json``), the tables it wrote (their bytes) and its
summary.json, which lists the inputs it read (each file's name, size and SHA-256). The key
covers:

- what the study folder holds: the names of its files and folders, two levels deep (as the
  study's subjects and trials are found), and its absolute path, as listed before the
  analysis began (a trial recorded while it ran makes the next key another one);
- the options of the command that change the results (``--set`` and the settings' own
  options, ``--strict``);
- the software: evtribo's source files, the Python build and the libraries' versions
  (:func:`~evtribo.store.memo.software_fingerprint`), and the platform.

The next ``evtribo analyze`` of the same study with the same options finds the entry and
checks the SHA-256 of every input (with the remembered hashes of
:class:`~evtribo.store.memo.HashMemo`: a file unchanged since it was hashed is not read
again). If all are the same, it writes the same tables again, as one unit like any
analysis, with summary.json as before but for a new ``run_id``, ``created``, ``started``,
``elapsed_s``, and ``jobs`` 1 (no trial analysed, as when every trial's outcome is reused by
:mod:`.reuse`). Anything else (a file added, removed or renamed, an input's bytes, an
option, evtribo or a library upgraded, an entry damaged or unreadable) and the study is
analysed as usual, which still reuses each unchanged trial's outcome. ``--recompute`` and a
Dask cluster always analyse.
"""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import json
import logging
import os
import platform
import time
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from evtribo.documents.summary import Summary
from evtribo.results.outputs import check_out_dir, check_overwrite, write_analysis
from evtribo.store.files import read_entry, write_checksummed
from evtribo.store.memo import HashMemo, default_cache_dir, software_fingerprint
from evtribo.store.resultdir import locked, recover
from evtribo.warning.collect import replay

log = logging.getLogger(__name__)

__all__ = ["remember", "rerun", "study_key"]

#: Bumped whenever what an entry holds changes (2: summary.json's warnings as records).
ENTRY_VERSION = 2
ENTRIES = "studies"
SUFFIX = ".json"


def _listing(root: Path) -> list[str]:
    """The names under *root*, two levels deep (folders end with ``/``)."""
    out = []
    for entry in sorted(os.scandir(root), key=lambda e: e.name):
        if not entry.is_dir():
            out.append(entry.name)
            continue
        out.append(f"{entry.name}/")
        try:
            inner = sorted(os.scandir(entry.path), key=lambda e: e.name)
        except OSError:
            out.append(f"{entry.name}/?")
            continue
        out.extend(f"{entry.name}/{e.name}{'/' if e.is_dir() else ''}" for e in inner)
    return out


def study_key(study_dir: str | os.PathLike[str], options: Mapping[str, Any]) -> str:
    """The key of a study's entry: its folder's names, its path, *options*, the software.

    Parameters
    ----------
    study_dir : path-like
        The study folder.
    options : mapping
        The command's options that change the results (JSON-able).

    Returns
    -------
    str
        Hex SHA-256.
    """
    root = os.path.abspath(study_dir)
    text = json.dumps({"version": ENTRY_VERSION, "study": root, "listing": _listing(Path(root)),
                       "options": options, "software": software_fingerprint(),
                       "platform": platform.platform()}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()


def _input_path(summary: Mapping[str, Any], rec: Mapping[str, Any]) -> Path:
    name = Path(rec["file"])
    return name if name.is_absolute() else Path(summary["study_dir"]) / name


def _inputs_unchanged(summary: Mapping[str, Any], memo: HashMemo) -> bool:
    """Whether every input of *summary* still has its size and SHA-256."""
    for rec in summary["inputs"]:
        try:
            digest, st = memo.sha256(_input_path(summary, rec))
        except OSError:
            return False
        if digest != rec["sha256"] or st.st_size != rec["bytes"]:
            log.debug("%s changed since the last analysis", rec["file"])
            return False
    return True


def remember(study_dir: str | os.PathLike[str], options: Mapping[str, Any],
             summary: Mapping[str, Any], out_dir: str | os.PathLike[str],
             cache_dir: str | os.PathLike[str] | None = None, *,
             key: str | None = None) -> Path | None:
    """Keep what an analysis wrote, for :func:`rerun`; nothing when a trial failed (the
    failure might not happen again), when its inputs or its result folder changed meanwhile,
    or when the cache cannot be written.

    Parameters
    ----------
    study_dir : path-like
        The study folder, as given to the analysis.
    options : mapping
        As for :func:`study_key`.
    summary : mapping
        The summary.json the analysis wrote.
    out_dir : path-like
        The result folder it wrote.
    cache_dir : path-like, optional
        The cache folder (default: :func:`~evtribo.store.memo.default_cache_dir`).
    key : str, optional
        The study's key (:func:`study_key`) taken BEFORE the analysis started: a trial
        recorded while it ran is then not filed as analysed. Default: taken now (only
        right when nothing was added meanwhile).

    Returns
    -------
    Path or None
        The entry written.
    """
    if summary.get("failed_trials") or not summary.get("trials_analysed"):
        return None  # a failure may not happen again: such a study is always analysed
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    try:
        key = key if key is not None else study_key(study_dir, options)
        memo = HashMemo(folder, study_dir)
        unchanged = _inputs_unchanged(summary, memo)
        memo.save()
        if not unchanged:
            return None
        files = {}
        for name, digest in summary["output_sha256"].items():
            data = (Path(out_dir) / name).read_bytes()
            if hashlib.sha256(data).hexdigest() != digest:
                return None  # rewritten since
            files[name] = data.decode("utf-8")
        entry = {"version": ENTRY_VERSION, "key": key, "summary": summary, "files": files}
        return write_checksummed(folder / ENTRIES, key, json.dumps(entry).encode(), SUFFIX)
    except (OSError, ValueError, KeyError, TypeError) as err:  # the analysis stands
        log.debug("the analysis of %s is not kept: %s", study_dir, err)
        return None


def _entry(folder: Path, key: str) -> dict[str, Any] | None:
    """The entry of *key*, or None (none, or damaged: then it is removed)."""
    def parse(data: bytes) -> dict[str, Any]:
        entry = dict(json.loads(data))
        if (entry["version"] != ENTRY_VERSION or entry["key"] != key
                or set(entry["summary"]["output_sha256"]) != set(entry["files"])):
            raise ValueError("not an entry of this version and key")
        return entry
    return read_entry(folder / ENTRIES, key, SUFFIX, parse,
                      what="entry of the study's last analysis", then="the study is analysed")


def _write_text(text: str, path: Path) -> str:
    data = text.encode("utf-8")
    path.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


def rerun(study_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str], *,
          options: Mapping[str, Any], force: bool = False,
          cache_dir: str | os.PathLike[str] | None = None) -> dict[str, Any] | None:
    """Write the results of the last analysis of an unchanged study into *out_dir*.

    Parameters
    ----------
    study_dir : path-like
        The study folder.
    out_dir : path-like
        The result folder (as for :func:`~evtribo.results.pipeline.analyze_study`).
    options : mapping
        As for :func:`study_key`.
    force : bool
        Replace the results in *out_dir*.
    cache_dir : path-like, optional
        The cache folder (default: :func:`~evtribo.store.memo.default_cache_dir`).

    Returns
    -------
    dict or None
        The summary written; None when the study must be analysed (nothing written).

    Raises
    ------
    OutputExistsError, OutputBusyError, UserInputError, OutputWriteError
        As :func:`~evtribo.results.pipeline.analyze_study`; *out_dir* is left as it was.
    """
    started = time.perf_counter()
    started_at = time.time()
    root = Path(study_dir)
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    try:
        if not (root / "study.toml").is_file():
            return None  # the analysis says what is wrong
        entry = _entry(folder, study_key(root, options))
    except OSError as err:
        log.debug("cannot look for an earlier analysis of %s: %s", study_dir, err)
        return None
    if entry is None:
        return None
    before = entry["summary"]
    memo = HashMemo(folder, root)
    unchanged = _inputs_unchanged(before, memo)
    memo.save()
    if not unchanged:
        return None
    out = Path(out_dir)
    check_overwrite(out, force)
    check_out_dir(out, root)
    summary = {**before, "run_id": uuid.uuid4().hex,
               "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
               "started": dt.datetime.fromtimestamp(started_at, dt.UTC)
               .isoformat(timespec="seconds").replace("+00:00", "Z"),
               "jobs": 1, "output_sha256": {}, "elapsed_s": None}
    with locked(out, "evtribo analyze"):
        recover(out)
        check_overwrite(out, force)
        write_analysis(out, {name: functools.partial(_write_text, text)
                             for name, text in entry["files"].items()},
                       summary, time.perf_counter() - started)
    log.info("%s: unchanged since its analysis of %s; its results written again",
             study_dir, before.get("created"))
    replay(Summary(summary).warnings)  # said again, each by the module that said it
    return summary
