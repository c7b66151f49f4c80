"""The study folder: ``study.toml``, one folder per subject, one log and sidecar per trial.

::

    my-study/
      study.toml              name, [rig] (DBC and which signals mean what)
      rig/loadcells.dbc
      P01/run-01.log          raw CAN log (candump -L, or .asc/.blf/.trc/.csv/.log.gz)
      P01/run-01.json         the trial's sidecar

This module finds the trials, validates names, ``study.toml`` and sidecars, and writes them
for ``evtribo acquire``. It reads no CAN log. Every error names the file and the line or key.
"""

from __future__ import annotations

import functools
import json
import logging
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from evtribo.documents.names import MAX_NAME_BYTES, NAME_PATTERN, validate_name
from evtribo.documents.replacing import replacing, stages, unfinished
from evtribo.documents.session import SESSION_FILE
from evtribo.documents.sidecar import (
    CONDITIONS,
    SIDECAR_KEYS,
    WAVEFORMS,
    Sidecar,
    parse_sidecar,
    read_sidecar,
    unknown_sidecar_keys,
    write_sidecar,
)
from evtribo.errors import LogFormatError, OutputExistsError, StudyError, toml_problem
from evtribo.store.files import PARTIAL_SUFFIX, atomic_write, read_limited
from evtribo.warning.collect import collecting, emitter, replay
from evtribo.warning.record import Scope, WarningRecord

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.canlog.rig import Rig

log = logging.getLogger(__name__)
emit = emitter(__name__)

STUDY_FILE = "study.toml"


@functools.cache
def log_suffixes() -> tuple[str, ...]:
    """Suffixes of raw logs, longest first (``.log.gz`` before ``.log``): every format
    :func:`evtribo.canlog.io.read_frames` reads, each also gzipped."""
    from evtribo.canlog.io.registry import supported_suffixes  # imports python-can: on use

    plain = supported_suffixes()
    return tuple(sorted([*plain, *(f"{x}.gz" for x in plain)], key=lambda x: (-len(x), x)))


#: Files an operating system leaves in folders (``Thumbs.db`` would read as a SQLite log).
OS_CLUTTER = {"thumbs.db", "ehthumbs.db", "desktop.ini", ".ds_store"}
#: Top-level keys of study.toml and their types.
STUDY_KEYS: dict[str, type | tuple[type, ...]] = {"name": str, "rig": dict, "analysis": dict,
                                                  "population": dict}
#: Folders of a study that are not subjects.
NOT_SUBJECTS = {"rig"}


def log_stem(path: Path) -> tuple[str, str] | None:
    """Split a log's file name into ``(trial, suffix)``, or None if it is no log.

    A log left as ``run-01.log.part`` by a killed acquisition is a log too (suffix
    ``.log.part``).

    Parameters
    ----------
    path : Path

    Returns
    -------
    (str, str) or None
    """
    name = path.name
    partial = name.lower().endswith(PARTIAL_SUFFIX)  # as the readers: RUN-01.LOG.PART too
    if partial:
        name = name[: -len(PARTIAL_SUFFIX)]
    for suffix in log_suffixes():
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)], suffix + (PARTIAL_SUFFIX if partial else "")
    return None


@dataclass(frozen=True)
class TrialRef:
    """One trial of a study: where its log and sidecar are, and the sidecar's content.

    Attributes
    ----------
    subject, name : str
        Subject (from the sidecar, else the folder) and trial (the log's stem).
    log_path : Path
    sidecar_path : Path or None
        None when the trial has no sidecar.
    sidecar : Sidecar
    partial : bool
        True for a log left under its temporary name (``.part``) by a killed acquisition.
    """

    subject: str
    name: str
    log_path: Path
    sidecar_path: Path | None
    sidecar: Sidecar
    partial: bool = False

    @property
    def key(self) -> str:
        """``subject/trial``, unique within a study."""
        return f"{self.subject}/{self.name}"


@dataclass
class StudyFolder:
    """A study folder, loaded and validated (its logs not yet read)."""

    root: Path
    name: str
    config: dict[str, Any]
    rig: Rig | None
    trials: list[TrialRef]
    warnings: list[WarningRecord] = field(default_factory=list)

    @property
    def subjects(self) -> list[str]:
        """Subject names in order of first appearance."""
        return list(dict.fromkeys(t.subject for t in self.trials))


def read_study_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read ``study.toml`` and check its top-level keys and their types.

    Parameters
    ----------
    path : path-like
        The ``study.toml``.

    Returns
    -------
    dict
        Its tables and keys.
    """
    p = Path(path)
    text = ""
    try:
        text = read_limited(p, StudyError, what=STUDY_FILE).decode("utf-8")
        config = tomllib.loads(text)
    except FileNotFoundError as err:
        above, name = p.parent.parent, os.path.basename(os.path.abspath(p.parent))
        if (above / STUDY_FILE).is_file():  # a subject's folder (or any folder) of a study
            raise StudyError(f"no {STUDY_FILE}: {name} is a folder of the study {above}, "
                             f"not a study; give the study folder: {above}", path=p) from err
        raise StudyError(f"no {STUDY_FILE}: this folder is not a study (`evtribo init "
                         f"{p.parent} --dbc YOUR.dbc` makes one for your rig)",
                         path=p) from err
    except tomllib.TOMLDecodeError as err:
        reason, line, key = toml_problem(err, text)
        raise StudyError(f"invalid TOML: {reason}", path=p, line=line, key=key) from err
    except UnicodeDecodeError as err:
        raise StudyError(f"not UTF-8 text: {err.reason}", path=p) from err
    except RecursionError as err:
        raise StudyError("invalid TOML: nested too deeply", path=p) from err
    except OSError as err:
        raise StudyError(f"cannot read: {err.strerror or err}", path=p) from err
    for key, value in config.items():
        if key not in STUDY_KEYS:
            raise StudyError(f"unknown key; allowed: {', '.join(STUDY_KEYS)}", path=p, key=key)
        if not isinstance(value, STUDY_KEYS[key]):
            kind = STUDY_KEYS[key]
            wanted = "a table" if kind is dict else "text" if kind is str else str(kind)
            raise StudyError(f"expected {wanted}, got {value!r}", path=p, key=key)
    if "rig" not in config:
        raise StudyError("missing the [rig] table (dbc, normal_force, tangential_force)",
                         path=p, key="rig")
    return config


def _logs_of(folder: Path) -> tuple[dict[str, tuple[Path, bool]], dict[str, list[str]]]:
    """The logs in a subject's *folder* by trial (each with whether it is a partial log)
    and the files that are no log, by stem; a trial with a complete log and a partial one
    is its complete one (said: ``log-part-superseded``)."""
    logs: dict[str, tuple[Path, bool]] = {}
    others: dict[str, list[str]] = {}   # files that are no log, by stem
    for f, _, is_file in _listing(folder):
        if f.name.startswith((".", "~$")) or f.name.lower() in OS_CLUTTER \
                or f.name == SESSION_FILE:
            continue
        split = log_stem(f) if is_file else None
        if split is None:
            if is_file:
                others.setdefault(f.name.split(".", 1)[0], []).append(f.name)
            continue
        trial, suffix = split
        partial = suffix.endswith(PARTIAL_SUFFIX)
        if trial in logs:
            kept, kept_partial = logs[trial]
            if partial == kept_partial:
                raise StudyError(f"two logs for trial {trial!r}: {kept.name} and {f.name}",
                                 path=folder)
            complete, part = (f, kept) if kept_partial else (kept, f)
            logs[trial] = (complete, False)
            emit("log-part-superseded", Scope(folder.name, trial), part=str(part),
                 complete=complete.name)
            continue
        logs[trial] = (f, partial)
    return logs, others


def _rerecorded(folder: Path, logs: dict[str, tuple[Path, bool]]) -> dict[str, Path | None]:
    """The trials of *folder* that a forced re-recording is replacing (its log put in
    *logs*), with their sidecars; the re-recordings that did not finish, said
    (:mod:`evtribo.documents.replacing`)."""
    sidecars: dict[str, Path | None] = {}
    for trial in stages(folder):
        for stage in unfinished(folder, trial):
            emit("rerecording-unfinished", Scope(folder.name, trial), stage=str(stage),
                 trial=trial)
        now = replacing(folder, trial)
        if now is None or now.log is None:
            continue
        logs[trial] = (now.log, False)
        sidecars[trial] = now.sidecar
        for p in now.leftover:
            emit("rerecording-leftover", Scope(folder.name, trial), path=str(p), trial=trial)
    return sidecars


def discover_trials(root: str | os.PathLike[str]
                    ) -> tuple[list[TrialRef], list[WarningRecord]]:
    """Find every trial under *root*'s subject folders; returns ``(trials, warnings)``
    (the warnings not said: :func:`load_study` says them).

    A trial being recorded again over itself (``acquire --force``) is the recording the
    moment's files make whole: the one recorded before, until the new one is complete
    (:mod:`evtribo.documents.replacing`).

    Parameters
    ----------
    root : path-like
        The study folder.

    Returns
    -------
    trials : list of TrialRef
    warnings : list of WarningRecord
        Logs without sidecars, unknown sidecar keys, partial logs... one each.
    """
    with collecting(quiet=True) as warnings:
        return _discover(Path(root)), warnings


def _discover(root: Path) -> list[TrialRef]:
    """:func:`discover_trials`' trials, its warnings said."""
    trials: list[TrialRef] = []
    for folder in (p for p, is_dir, _ in _listing(root) if is_dir):
        if folder.name.startswith(".") or folder.name in NOT_SUBJECTS:
            continue
        logs, others = _logs_of(folder)
        sidecars = _rerecorded(folder, logs)
        _sidecars_without_logs(folder, others, logs)
        if not logs:
            continue
        validate_name(folder.name, what="subject folder", path=folder)
        _outside(folder, root)
        for trial, (log_path, partial) in logs.items():
            validate_name(trial, what="trial", path=log_path)
            _readable(log_path)
            where = Scope(folder.name, trial)
            sidecar_path = sidecars.get(trial, folder / f"{trial}.json")
            if sidecar_path is not None and sidecar_path.exists():
                sidecar = read_sidecar(sidecar_path, default_subject=folder.name)
                for key, close in unknown_sidecar_keys(sidecar):
                    emit("sidecar-unknown-key", where, sidecar=str(sidecar_path), key=key,
                         suggestion=f" (did you mean {close!r}?)" if close else "")
            else:
                sidecar_path = None
                sidecar = Sidecar(subject=folder.name)
                emit("sidecar-missing", where, log=str(log_path), trial=trial)
            if partial:
                emit("log-partial", where, log=str(log_path))
            elif (cut := _cut_short(sidecar.extra)) is not None:
                emit("cut-short", where, log=str(log_path), **cut)
            trials.append(TrialRef(subject=sidecar.subject, name=trial, log_path=log_path,
                                   sidecar_path=sidecar_path, sidecar=sidecar, partial=partial))
    seen: dict[str, Path] = {}
    for t in trials:
        if t.key in seen:
            raise StudyError(f"trial {t.key} appears twice: {seen[t.key]} and {t.log_path}",
                             path=t.sidecar_path or t.log_path, key="subject")
        seen[t.key] = t.log_path
    return trials


def _listing(folder: Path) -> list[tuple[Path, bool, bool]]:
    """The entries of *folder* in order, each with whether it is a folder and a regular
    file (links followed); a folder the user may not list or enter is refused by name
    (rather than its trials left out without a word)."""
    try:
        return [(p, p.is_dir(), p.is_file()) for p in sorted(folder.iterdir())]
    except PermissionError as err:
        raise StudyError(f"cannot read the folder: {err.strerror}", path=folder) from err


def _readable(log_path: Path) -> None:
    """Refuse a log the user may not read (mode 000, another user's), by name, before any
    trial is analysed; nothing of it is read here."""
    try:
        fd = os.open(log_path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC)
    except PermissionError as err:
        raise LogFormatError(f"cannot read: {err.strerror}", path=log_path) from err
    os.close(fd)


#: How a recording can end before its time, in words (``ended`` of the sidecar).
_ENDED_EARLY = {"interrupted": "interrupted (Ctrl-C or SIGTERM)",
                "bus-error": "ended by a bus fault", "disk-error": "ended by a disk fault",
                "no-rig-data": "ended with no frame of the rig's load cells"}


def _cut_short(extra: Mapping[str, Any]) -> dict[str, str] | None:
    """What a sidecar says of a recording that ended before its requested duration (an
    interrupted or faulted trial: how it ``ended`` and ``after`` how long, the values of
    ``cut-short``), or None (completed; or stopped by hand when no duration was asked, the
    way such a recording ends)."""
    ended = extra.get("ended")
    if ended not in _ENDED_EARLY:
        return None
    asked, lasted = extra.get("requested_duration_s"), extra.get("duration_s")
    if ended == "interrupted" and not isinstance(asked, int | float):
        return None
    after = (f" after {lasted:.1f} s of the {asked:g} s asked"
             if isinstance(lasted, int | float) and isinstance(asked, int | float) else "")
    return {"ended": _ENDED_EARLY[ended], "after": after}


def _sidecars_without_logs(folder: Path, others: Mapping[str, list[str]],
                           logs: Mapping[str, Any]) -> None:
    """Say each sidecar in *folder* whose trial has no log (*others*: the files that are no
    log, by stem)."""
    for stem, names in others.items():
        if f"{stem}.json" in names and stem not in logs:
            besides = [n for n in names if not n.startswith(f"{stem}.json")]
            emit("sidecar-without-log", Scope(folder.name, stem),
                 sidecar=str(folder / (stem + ".json")),
                 besides=f" ({', '.join(besides)}: not a log format)" if besides else "")


def _outside(folder: Path, root: Path) -> None:
    """Warn of a subject folder that is a symbolic link to a folder outside the study."""
    if not folder.is_symlink():
        return
    target = Path(os.path.realpath(folder))
    if not target.is_relative_to(Path(os.path.realpath(root))):
        emit("subject-outside", Scope(folder.name), folder=str(folder), target=str(target),
             subject=folder.name)


def load_study(path: str | os.PathLike[str], *, with_rig: bool = True) -> StudyFolder:
    """Load a study folder: ``study.toml``, its rig (DBC checked) and its trials.

    Parameters
    ----------
    path : path-like
        The study folder (or its ``study.toml``).
    with_rig : bool
        Load and check the rig's DBC and signal names (before any log is read).

    Returns
    -------
    StudyFolder

    Raises
    ------
    StudyError, SidecarError, RigConfigError
        With the file and the line or key at fault.
    """
    root = Path(path)
    if root.name == STUDY_FILE:
        root = root.parent
    if not root.is_dir():
        raise StudyError("no such study folder", path=root)
    toml_path = root / STUDY_FILE
    config = read_study_toml(toml_path)
    rig = None
    if with_rig:
        from evtribo.canlog.rig import Rig

        rig = Rig.from_mapping(config["rig"], base_dir=root, source=toml_path, key_prefix="rig")
    trials, warnings = discover_trials(root)
    replay(warnings)
    return StudyFolder(root=root, name=str(config.get("name", root.name)), config=config, rig=rig,
                       trials=trials, warnings=warnings)


def study_rig(path: str | os.PathLike[str]) -> Rig:
    """The rig of a study folder or study.toml, or of a rig TOML.

    Parameters
    ----------
    path : path-like
        A study folder, its ``study.toml`` (the ``[rig]`` table), or a rig TOML (the keys at
        the top level).

    Returns
    -------
    Rig

    Raises
    ------
    StudyError, RigConfigError
        With the file and the key at fault.
    """
    from evtribo.canlog.rig import Rig, load_rig

    p = Path(path)
    if p.is_dir() or p.name == STUDY_FILE:
        toml_path = p / STUDY_FILE if p.is_dir() else p
        config = read_study_toml(toml_path)
        return Rig.from_mapping(config["rig"], base_dir=toml_path.parent, source=toml_path,
                                key_prefix="rig")
    return load_rig(p)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    return json.dumps(str(value), ensure_ascii=False)  # a TOML basic string is JSON-compatible


def write_study_toml(root: str | os.PathLike[str], *, name: str, rig: Mapping[str, Any],
                     calibration: Mapping[str, Any] | None = None,
                     calibration_note: str = "") -> Path:
    """Create ``study.toml`` in *root* with a ``[rig]`` table; refuses to overwrite one.

    Parameters
    ----------
    root : path-like
        The study folder (created if missing).
    name : str
        The study's ``name``.
    rig : mapping
        The ``[rig]`` table.
    calibration : mapping, optional
        The ``[rig.calibration]`` table.
    calibration_note : str
        A comment above it (one line per line of the text).

    Returns
    -------
    Path
        The new ``study.toml``.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    p = root / STUDY_FILE
    if p.exists():
        raise OutputExistsError("exists already", path=p)
    lines = [f"name = {_toml_value(name)}", "", "[rig]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in rig.items()]
    if calibration:
        lines += ["", *(f"# {line}" for line in calibration_note.splitlines()),
                  "[rig.calibration]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in calibration.items()]
    atomic_write(p, "\n".join(lines) + "\n", durable=True)
    return p


# the sidecar's and the names' definitions live in evtribo.documents; imported from here too
__all__ = ["CONDITIONS", "MAX_NAME_BYTES", "NAME_PATTERN", "NOT_SUBJECTS", "OS_CLUTTER",
           "SIDECAR_KEYS", "STUDY_FILE", "STUDY_KEYS", "WAVEFORMS", "Sidecar", "StudyFolder",
           "TrialRef", "discover_trials", "load_study", "log_stem", "log_suffixes",
           "parse_sidecar", "read_sidecar", "read_study_toml", "study_rig",
           "unknown_sidecar_keys", "validate_name", "write_sidecar", "write_study_toml"]
