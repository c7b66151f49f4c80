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

import difflib
import functools
import json
import logging
import math
import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from evtribo.errors import OutputExistsError, SidecarError, StudyError, toml_error_line
from evtribo.files import PARTIAL_SUFFIX, atomic_write, read_limited

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.rig import Rig

log = logging.getLogger(__name__)

STUDY_FILE = "study.toml"
#: Plain names: subjects and trials (no path separators, no ``..``).
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_-]+$")
CONDITIONS = ("on", "off", "alternating")
WAVEFORMS = ("sine", "square")


@functools.cache
@functools.cache
def log_suffixes() -> tuple[str, ...]:
    """Suffixes of raw logs, longest first (``.log.gz`` before ``.log``): every format
    :func:`evtribo.frames.read_frames` reads, each also gzipped."""
    from evtribo.frames.registry import supported_suffixes  # imports python-can: on use

    plain = supported_suffixes()
    return tuple(sorted([*plain, *(f"{x}.gz" for x in plain)], key=lambda x: (-len(x), x)))


#: Files an operating system leaves in folders (``Thumbs.db`` would read as a SQLite log).
OS_CLUTTER = {"thumbs.db", "ehthumbs.db", "desktop.ini", ".ds_store"}
#: Sidecar keys evtribo reads (spec) or writes (``evtribo acquire``, ``evtribo simulate
#: --study``, ``scripts/record_traces.py``); any other key is reported with the closest of
#: these (a misspelt ``amplitde_V`` would otherwise be ignored in silence).
SIDECAR_KEYS = frozenset({
    "subject", "waveform", "frequency_Hz", "amplitude_V", "condition", "notes", "tare_s",
    "trial", "rig", "interface", "channel", "bitrate", "bus_options", "log_channel",
    "evtribo_version", "python_can_version", "cantools_version", "python_version",
    "start_time", "end_time", "requested_duration_s", "duration_s", "log", "log_compressed",
    "ended", "end_detail", "frames", "frames_by_id", "first_frame_time", "error_frames",
    "dropped_frames", "dropped_frames_by_message", "longest_gap_s_by_message", "bus_errors",
    "bus_exceptions", "damaged_lines", "bus", "software", "simulation",
})
#: Longest subject or trial name, bytes (the file system allows 255 for a whole file name,
#: which adds suffixes such as ``.log.part``).
MAX_NAME_BYTES = 100
#: Top-level keys of study.toml and their types.
STUDY_KEYS: dict[str, type | tuple[type, ...]] = {"name": str, "rig": dict, "analysis": dict}
#: Folders of a study that are not subjects.
NOT_SUBJECTS = {"rig"}


def validate_name(value: object, *, what: str, path: str | os.PathLike[str] | None = None,
                  key: str | None = None, error: type[StudyError] | type[SidecarError] = StudyError
                  ) -> str:
    """Return *value* if it is a plain name (letters, digits, ``-``, ``_``), else raise.

    Parameters
    ----------
    value : object
        The proposed subject or trial name.
    what : str
        What the name is for, used in the message (``"subject"``, ``"trial"``).
    path, key : optional
        Where the name came from, for the message.
    error : type
        The error class to raise.
    """
    if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
        raise error(
            f"{what} name {value!r} is not allowed: use letters, digits, '-' and '_' only "
            "(no paths, no spaces)",
            path=path, key=key,
        )
    if len(value.encode()) > MAX_NAME_BYTES:
        raise error(f"{what} name {value[:20]}... is {len(value)} characters long; at most "
                    f"{MAX_NAME_BYTES} are allowed (file names have a length limit)",
                    path=path, key=key)
    return value


@dataclass(frozen=True)
class Sidecar:
    """A trial's metadata, validated.

    Attributes
    ----------
    subject : str
        Subject name (defaults to the folder's).
    waveform : {"sine", "square"} or None
    frequency_Hz : float or None
        Frequency of the applied voltage, Hz.
    amplitude_V : float or None
        Amplitude of the applied voltage, V.
    condition : {"on", "off", "alternating"} or None
    notes : str
    extra : dict
        Every other key, as written (``evtribo acquire`` writes many).
    """

    subject: str
    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None
    condition: str | None = None
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The sidecar as JSON-ready mapping (spec keys first, then the others)."""
        out: dict[str, Any] = {
            "subject": self.subject, "waveform": self.waveform,
            "frequency_Hz": self.frequency_Hz, "amplitude_V": self.amplitude_V,
            "condition": self.condition, "notes": self.notes,
        }
        out.update(self.extra)
        return out


def _number(value: object, key: str, path: Path) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SidecarError(f"expected a number, got {value!r} ({type(value).__name__})",
                           path=path, key=key)
    if not math.isfinite(value) or value < 0:
        raise SidecarError(f"expected a finite number >= 0, got {value!r}", path=path, key=key)
    return float(value)


def _choice(value: object, key: str, path: Path, allowed: tuple[str, ...]) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or value.lower() not in allowed:
        raise SidecarError(f"unknown value {value!r}; allowed: {', '.join(allowed)}",
                           path=path, key=key)
    return value.lower()


def parse_sidecar(data: object, *, path: str | os.PathLike[str], default_subject: str) -> Sidecar:
    """Validate a sidecar's decoded JSON; *default_subject* is the folder's name, which a
    ``subject`` in the sidecar must equal."""
    p = Path(path)
    if not isinstance(data, dict):
        raise SidecarError(f"expected a JSON object, got {type(data).__name__}", path=p)
    data = dict(data)
    subject = validate_name(data.pop("subject", default_subject), what="subject", path=p,
                            key="subject", error=SidecarError)
    if subject != default_subject:
        raise SidecarError(f"says subject {subject!r}, but the trial is in the folder "
                           f"{default_subject!r}: a subject's trials are in the folder of "
                           "its name (rename one of them)", path=p, key="subject")
    notes = data.pop("notes", "")
    if notes is None:
        notes = ""
    if not isinstance(notes, str):
        raise SidecarError(f"expected text, got {notes!r}", path=p, key="notes")
    return Sidecar(
        subject=subject,
        waveform=_choice(data.pop("waveform", None), "waveform", p, WAVEFORMS),
        frequency_Hz=_number(data.pop("frequency_Hz", None), "frequency_Hz", p),
        amplitude_V=_number(data.pop("amplitude_V", None), "amplitude_V", p),
        condition=_choice(data.pop("condition", None), "condition", p, CONDITIONS),
        notes=notes,
        extra=data,
    )


def read_sidecar(path: str | os.PathLike[str], *, default_subject: str) -> Sidecar:
    """Read and validate a trial's JSON sidecar (a regular file of at most 1 MiB)."""
    p = Path(path)
    try:
        raw = read_limited(p, SidecarError, what="sidecar")
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SidecarError(f"not UTF-8 text ({err.reason} at byte {err.start})", path=p) from err
    except OSError as err:
        raise SidecarError(f"cannot read: {err.strerror}", path=p) from err
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise SidecarError(f"invalid JSON: {err.msg} (column {err.colno})", path=p,
                           line=err.lineno) from err
    except RecursionError as err:
        raise SidecarError("invalid JSON: nested too deeply to be a sidecar", path=p) from err
    return parse_sidecar(data, path=p, default_subject=default_subject)


def unknown_sidecar_keys(sidecar: Sidecar) -> list[tuple[str, str | None]]:
    """Keys of *sidecar* evtribo neither reads nor writes, each with the closest known key
    (or None)."""
    out = []
    for key in sidecar.extra:
        if key not in SIDECAR_KEYS:
            close = difflib.get_close_matches(key, sorted(SIDECAR_KEYS), n=1, cutoff=0.6)
            out.append((key, close[0] if close else None))
    return out


def write_sidecar(path: str | os.PathLike[str], sidecar: Sidecar | Mapping[str, Any], *,
                  force: bool = False) -> Path:
    """Write a sidecar atomically (temporary file, then rename); refuse to overwrite."""
    p = Path(path)
    if p.exists() and not force:
        raise OutputExistsError("exists already; use {force} to overwrite", path=p)
    payload = sidecar.to_dict() if isinstance(sidecar, Sidecar) else dict(sidecar)
    # a value JSON cannot hold, a full disk: nothing is left behind
    text = json.dumps(payload, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
    atomic_write(p, text, durable=True)
    return p


def log_stem(path: Path) -> tuple[str, str] | None:
    """Split a log's file name into ``(trial, suffix)``, or None if it is no log.

    A log left as ``run-01.log.part`` by a killed acquisition is a log too (suffix
    ``.log.part``).
    """
    name = path.name
    partial = name.endswith(PARTIAL_SUFFIX)
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
class Study:
    """A study folder, loaded and validated (its logs not yet read)."""

    root: Path
    name: str
    config: dict[str, Any]
    rig: Rig | None
    trials: list[TrialRef]
    warnings: list[str] = field(default_factory=list)

    @property
    def subjects(self) -> list[str]:
        """Subject names in order of first appearance."""
        return list(dict.fromkeys(t.subject for t in self.trials))


def read_study_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read ``study.toml`` and check its top-level keys and their types."""
    p = Path(path)
    try:
        config = tomllib.loads(read_limited(p, StudyError, what=STUDY_FILE).decode("utf-8"))
    except FileNotFoundError as err:
        raise StudyError(f"no {STUDY_FILE}: this folder is not a study "
                         "(evtribo acquire creates one)", path=p) from err
    except tomllib.TOMLDecodeError as err:
        raise StudyError(f"invalid TOML: {err}", path=p, line=toml_error_line(err)) from err
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


def discover_trials(root: str | os.PathLike[str]) -> tuple[list[TrialRef], list[str]]:
    """Find every trial under *root*'s subject folders; returns ``(trials, warnings)``."""
    root = Path(root)
    trials: list[TrialRef] = []
    warnings: list[str] = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        if folder.name.startswith(".") or folder.name in NOT_SUBJECTS:
            continue
        logs: dict[str, tuple[Path, bool]] = {}
        others: dict[str, list[str]] = {}   # files that are no log, by stem
        for f in sorted(folder.iterdir()):
            if f.name.startswith((".", "~$")) or f.name.lower() in OS_CLUTTER:
                continue
            split = log_stem(f) if f.is_file() else None
            if split is None:
                if f.is_file():
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
                warnings.append(f"{part}: not analysed, {complete.name} is the trial's complete "
                                "log (the .part is a recording that did not finish, e.g. a "
                                "--force re-recording that was killed); nothing was deleted")
                continue
            logs[trial] = (f, partial)
        for stem, names in others.items():
            if f"{stem}.json" in names and stem not in logs:
                besides = [n for n in names if not n.startswith(f"{stem}.json")]
                warnings.append(
                    f"{folder / (stem + '.json')}: sidecar without a log"
                    + (f" ({', '.join(besides)}: not a log format)" if besides else "")
                    + "; not analysed")
        if not logs:
            continue
        validate_name(folder.name, what="subject folder", path=folder)
        for trial, (log_path, partial) in logs.items():
            validate_name(trial, what="trial", path=log_path)
            sidecar_path = folder / f"{trial}.json"
            if sidecar_path.exists():
                sidecar = read_sidecar(sidecar_path, default_subject=folder.name)
                for key, close in unknown_sidecar_keys(sidecar):
                    warnings.append(f"{sidecar_path}: unknown key {key!r} ignored"
                                    + (f" (did you mean {close!r}?)" if close else ""))
            else:
                sidecar_path = None
                sidecar = Sidecar(subject=folder.name)
                warnings.append(f"{log_path}: no sidecar {trial}.json; condition and amplitude "
                                "must come from the excitation signals")
            if partial:
                warnings.append(f"{log_path}: partial trial (acquisition did not finish); "
                                "analysing what was recorded")
            trials.append(TrialRef(subject=sidecar.subject, name=trial, log_path=log_path,
                                   sidecar_path=sidecar_path, sidecar=sidecar, partial=partial))
    seen: dict[str, Path] = {}
    for t in trials:
        if t.key in seen:
            raise StudyError(f"trial {t.key} appears twice: {seen[t.key]} and {t.log_path}",
                             path=t.sidecar_path or t.log_path, key="subject")
        seen[t.key] = t.log_path
    return trials, warnings


def load_study(path: str | os.PathLike[str], *, with_rig: bool = True) -> Study:
    """Load a study folder: ``study.toml``, its rig (DBC checked) and its trials.

    Parameters
    ----------
    path : path-like
        The study folder (or its ``study.toml``).
    with_rig : bool
        Load and check the rig's DBC and signal names (before any log is read).

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
        from evtribo.rig import Rig

        rig = Rig.from_mapping(config["rig"], base_dir=root, source=toml_path, key_prefix="rig")
    trials, warnings = discover_trials(root)
    for w in warnings:
        log.warning("%s", w)
    return Study(root=root, name=str(config.get("name", root.name)), config=config, rig=rig,
                 trials=trials, warnings=warnings)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    return json.dumps(str(value), ensure_ascii=False)  # a TOML basic string is JSON-compatible


def write_study_toml(root: str | os.PathLike[str], *, name: str, rig: Mapping[str, Any]) -> Path:
    """Create ``study.toml`` in *root* with a ``[rig]`` table; refuses to overwrite one."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    p = root / STUDY_FILE
    if p.exists():
        raise OutputExistsError("exists already", path=p)
    lines = [f"name = {_toml_value(name)}", "", "[rig]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in rig.items()]
    atomic_write(p, "\n".join(lines) + "\n", durable=True)
    return p
