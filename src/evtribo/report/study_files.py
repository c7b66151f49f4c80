"""What the report reads of the study folder: its inputs hashed again, notes, the rig.

``summary.json`` names the study folder and the inputs the analysis read; when that folder
still exists (one with a study.toml), each input is hashed again (a warning for each one
changed, missing or added since the analysis) and the trials' sidecars give their notes. A
``summary.json`` is not trusted with paths: only inputs inside the study folder (and the DBC
the study's own study.toml names) are listed or read.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo.documents.summary import Summary
from evtribo.errors import EvtriboError
from evtribo.fit.tables import ResultTables
from evtribo.store.files import sha256_file
from evtribo.store.resultdir import inside
from evtribo.study import STUDY_FILE, discover_trials, read_study_toml
from evtribo.warning.collect import collecting, emitter
from evtribo.warning.record import Scope, WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["file_hashes", "input_table", "study_dir_of", "study_name", "study_rig",
           "trials_with_notes"]


def file_hashes(paths: list[Path], root: Path) -> pd.DataFrame:
    """``file, bytes, sha256`` of each existing file, names relative to *root*.

    Parameters
    ----------
    paths : list of Path
        The files (those that do not exist are left out).
    root : Path
        The folder the names are relative to (a file outside it keeps its full path).

    Returns
    -------
    DataFrame
        One row per file.
    """
    rows = []
    for p in paths:
        if p.is_file():
            try:
                name = str(p.relative_to(root))
            except ValueError:
                name = str(p)
            rows.append({"file": name, "bytes": p.stat().st_size, "sha256": sha256_file(p)})
    return pd.DataFrame(rows, columns=["file", "bytes", "sha256"])


def study_name(summary: Summary, out: Path) -> str:
    """The study's name as summary.json records it (else the result folder's).

    Parameters
    ----------
    summary : Summary
        The result folder's summary.json.
    out : Path
        The result folder.

    Returns
    -------
    str
        The name.
    """
    return summary.study or out.name


def study_dir_of(summary: Summary, out: Path) -> Path | None:
    """The study folder summary.json names, if it exists and is a study.

    Parameters
    ----------
    summary : Summary
        The result folder's summary.json.
    out : Path
        The result folder (a relative study path is tried from the working directory, then
        from the result folder's parent).

    Returns
    -------
    Path or None
        The folder holding a study.toml, or None.
    """
    raw = summary.study_dir
    if not raw:
        return None
    path = Path(raw)
    for candidate in (path, out.parent / path) if not path.is_absolute() else (path,):
        if (candidate / STUDY_FILE).is_file():
            return candidate
    return None


def study_rig(study_dir: Path | None) -> dict[str, Any]:
    """The [rig] table of the study's own study.toml.

    Parameters
    ----------
    study_dir : Path or None
        The study folder.

    Returns
    -------
    dict
        The table ({} when there is no study or it is unreadable).
    """
    if study_dir is None:
        return {}
    try:
        rig = read_study_toml(study_dir / STUDY_FILE).get("rig", {})
    except EvtriboError as err:
        log.warning("report: %s", err)
        return {}
    return dict(rig) if isinstance(rig, dict) else {}


def _study_dbc(study_dir: Path) -> Path | None:
    """The DBC the study's own study.toml names (it may lie outside the study folder)."""
    dbc = study_rig(study_dir).get("dbc")
    return (study_dir / dbc).resolve() if isinstance(dbc, str) else None


def _input_path(name: str, role: str, study_dir: Path | None,
                dbc: Path | None) -> Path | bool | None:
    """Where a recorded input is now: a path inside the study (or the study's DBC); None if
    the study is not at hand; False if the name is not one to list or read."""
    if name and not Path(name).is_absolute() and ".." not in Path(name).parts:
        return None if study_dir is None else inside(study_dir, name) or False
    if role == "dbc" and dbc is not None and Path(name).resolve() == dbc:
        return dbc
    return False


def _of_trial(rel: str, role: str = "log") -> Scope:
    """The trial a log or sidecar is of (``P01/run-03.log``: P01's run-03), else (study.toml,
    the DBC) the study."""
    parts = Path(rel).parts
    return Scope(parts[0], parts[1].split(".", 1)[0]) \
        if role in ("log", "sidecar") and len(parts) == 2 else Scope()


def input_table(summary: Summary, study_dir: Path | None
                ) -> tuple[pd.DataFrame, list[WarningRecord]]:
    """The inputs summary.json records, each hashed again when the study is at hand.

    Parameters
    ----------
    summary : Summary
        The result folder's summary.json.
    study_dir : Path or None
        The study folder, when it exists.

    Returns
    -------
    (DataFrame, list of WarningRecord)
        ``file, bytes, sha256[, now]`` of the inputs inside the study, and a warning for
        each one changed, missing or added since the analysis, or not listed (not said:
        the caller says them).
    """
    with collecting(quiet=True) as warnings:
        table = _inputs(summary, study_dir)
    return table, warnings


def _inputs(summary: Summary, study_dir: Path | None) -> pd.DataFrame:
    """:func:`input_table`'s table, its warnings said."""
    dbc = _study_dbc(study_dir) if study_dir is not None else None
    rows: list[dict[str, Any]] = []
    outside = 0
    for rec in summary.inputs:
        where = _input_path(rec.file, rec.role, study_dir, dbc)
        if where is False:
            outside += 1
            continue
        row: dict[str, Any] = {"file": rec.file, "bytes": rec.bytes, "sha256": rec.sha256}
        if isinstance(where, Path):
            try:
                now = sha256_file(where) if where.is_file() else None
            except OSError as err:  # made unreadable since (mode 000): not known, said
                row["now"] = "unreadable"
                emit("input-unreadable", _of_trial(rec.file, rec.role), file=rec.file,
                     error=str(err.strerror))
                rows.append(row)
                continue
            row["now"] = "unchanged" if now == rec.sha256 else \
                "missing" if now is None else "changed"
            if now is None:
                emit("input-gone", _of_trial(rec.file, rec.role), file=rec.file,
                     study_dir=str(study_dir))
            elif now != rec.sha256:
                emit("input-changed", _of_trial(rec.file, rec.role), file=rec.file,
                     then=rec.sha256[:12], now=now[:12])
        rows.append(row)
    if outside:
        emit("inputs-outside", files=outside)
    if study_dir is not None:
        _added(study_dir, {r["file"] for r in rows})
    columns = ["file", "bytes", "sha256", *(["now"] if study_dir is not None else [])]
    return pd.DataFrame(rows, columns=columns)


def _added(study_dir: Path, recorded: set[str]) -> None:
    """Say each trial's file in the study folder that the analysis did not read."""
    try:
        trials, _ = discover_trials(study_dir)
    except (EvtriboError, OSError) as err:
        emit("trials-unlisted", error=str(err))
        return
    names = []
    for t in trials:
        names += [t.log_path] + ([t.sidecar_path] if t.sidecar_path is not None else [])
    for rel in (p.relative_to(study_dir).as_posix() for p in names):
        if rel not in recorded:
            emit("input-added", _of_trial(rel), file=rel)


def _notes(study_dir: Path | None) -> dict[str, str]:
    """The sidecars' notes of the trials in trials.csv, read from the study folder."""
    notes: dict[str, str] = {}
    if study_dir is None:
        return notes
    try:
        trials, _ = discover_trials(study_dir)
    except (EvtriboError, OSError) as err:
        log.warning("report: cannot list the study's trials: %s", err)
        return notes
    for t in trials:
        if t.sidecar.notes:
            notes[t.key] = t.sidecar.notes
    return notes


def trials_with_notes(tables: ResultTables, study_dir: Path | None) -> pd.DataFrame:
    """trials.csv with the notes of the trials' sidecars (when the study is at hand).

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables.
    study_dir : Path or None
        The study folder.

    Returns
    -------
    DataFrame
        trials.csv, its ``notes`` filled from the sidecars where it has none.
    """
    trials = tables.trials.copy()
    notes = _notes(study_dir)
    if notes:
        keys = trials["subject"].astype(str) + "/" + trials["trial"].astype(str)
        from_sidecar = keys.map(notes)
        if "notes" in trials.columns:
            trials["notes"] = trials["notes"].where(trials["notes"].notna(), from_sidecar)
        else:
            trials["notes"] = from_sidecar
    return trials
