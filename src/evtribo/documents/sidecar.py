"""A trial's sidecar, ``SUBJECT/TRIAL.json``: its version, its fields, its reader and writer.

Spec §1 defines the keys a person writes (``subject``, ``waveform``, ``frequency_Hz``,
``amplitude_V``, ``condition``, ``notes``); ``evtribo acquire`` and ``evtribo simulate
--study`` add the recording's facts (:data:`SIDECAR_KEYS`). Every sidecar evtribo writes goes
through :func:`write_sidecar`, every one it reads through :func:`read_sidecar` (or
:func:`parse_sidecar` for JSON already decoded).

The rig that recorded a trial is one shape on disk, ``"rig": {"name": ..., "dbc": ...,
"dbc_version": ...}`` (:func:`rig_entry`, ``dbc`` relative to the study folder). Sidecars
written by evtribo before that by ``evtribo simulate --study`` hold the DBC's path alone
(``"rig": "rig/default.dbc"``); they are read as ``{"dbc": "rig/default.dbc"}``
(:attr:`Sidecar.rig`).
"""

from __future__ import annotations

import difflib
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evtribo.documents.names import validate_name
from evtribo.errors import OutputExistsError, SidecarError
from evtribo.store.files import DuplicateKeyError, atomic_write, loads_json_unique, read_limited

__all__ = ["CONDITIONS", "SIDECAR_BOUNDS", "SIDECAR_KEYS", "VERSION", "WAVEFORMS", "Sidecar",
           "parse_sidecar", "read_sidecar", "rig_entry", "unknown_sidecar_keys",
           "write_sidecar"]

#: Version of the sidecar's format. Sidecars carry no version key (spec §1 defines a plain
#: JSON object); a change of a key's meaning raises this number and is read by both shapes.
VERSION = 1
CONDITIONS = ("on", "off", "alternating")
WAVEFORMS = ("sine", "square")
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
    "discarded_before_start", "error_frames_by_kind", "controller_state",
    "worst_controller_state", "queue_dropped_frames", "receive", "duplicate_frames",
    "counter_restarts_s", "counter_notes",
})


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

    @property
    def rig(self) -> dict[str, Any] | None:
        """The rig that recorded the trial (``name``, ``dbc``, ``dbc_version``), or None.

        A sidecar of the older shape, the DBC's path alone, reads as ``{"dbc": path}``.
        """
        return _rig_shape(self.extra.get("rig"))

    def to_dict(self) -> dict[str, Any]:
        """The sidecar as JSON-ready mapping (spec keys first, then the others)."""
        out: dict[str, Any] = {
            "subject": self.subject, "waveform": self.waveform,
            "frequency_Hz": self.frequency_Hz, "amplitude_V": self.amplitude_V,
            "condition": self.condition, "notes": self.notes,
        }
        out.update(self.extra)
        return out


def rig_entry(dbc: str, *, name: str | None = None, dbc_version: str | None = None
              ) -> dict[str, Any]:
    """The sidecar's ``rig`` value: the one shape evtribo writes.

    Parameters
    ----------
    dbc : str
        The rig's DBC, relative to the study folder (``rig/default.dbc``).
    name : str, optional
        The rig's name (free text).
    dbc_version : str, optional
        The DBC's ``VERSION``.

    Returns
    -------
    dict
        ``{"name": name, "dbc": dbc, "dbc_version": dbc_version}``.
    """
    return {"name": name, "dbc": dbc, "dbc_version": dbc_version}


def _rig_shape(value: object) -> dict[str, Any] | None:
    if value is None:
        return None
    if isinstance(value, str):  # evtribo simulate --study before the shapes were one
        return {"dbc": value}
    if isinstance(value, Mapping):
        return dict(value)
    return None


#: The largest value of each number of a sidecar evtribo reads, its unit, and why: bounds no
#: electrovibration rig or protocol reaches (beyond them the model's numbers would overflow).
SIDECAR_BOUNDS: dict[str, tuple[float, str, str]] = {
    "amplitude_V": (1e5, "V", "no amplifier drives a finger's screen beyond 100 kV"),
    "frequency_Hz": (1e8, "Hz", "no drive of a screen is faster than 100 MHz"),
    "tare_s": (3600.0, "s", "no trial begins with an hour of the finger lifted"),
}


def _number(value: object, key: str, path: Path) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SidecarError(f"expected a number, got {value!r} ({type(value).__name__})",
                           path=path, key=key)
    try:
        number = float(value)
    except OverflowError:  # an integer beyond any float
        number = math.inf
    if not math.isfinite(number) or number < 0:
        shown = f"{value!r}" if math.isfinite(number) or isinstance(value, float) else \
            f"an integer of {len(str(abs(value)))} digits"
        raise SidecarError(f"expected a finite number >= 0, got {shown}", path=path, key=key)
    high, unit, why = SIDECAR_BOUNDS[key]
    if number > high:
        raise SidecarError(f"{value!r} {unit} is not allowed: at most {high:g} {unit} ({why})",
                           path=path, key=key)
    return number


def _choice(value: object, key: str, path: Path, allowed: tuple[str, ...]) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or value.lower() not in allowed:
        raise SidecarError(f"unknown value {value!r}; allowed: {', '.join(allowed)}",
                           path=path, key=key)
    return value.lower()


def parse_sidecar(data: object, *, path: str | os.PathLike[str], default_subject: str) -> Sidecar:
    """Validate a sidecar's decoded JSON.

    Parameters
    ----------
    data : object
        The decoded JSON.
    path : path-like
        The sidecar, for messages.
    default_subject : str
        The folder's name, which a ``subject`` in the sidecar must equal.

    Returns
    -------
    Sidecar

    Raises
    ------
    SidecarError
        Naming *path* and the key at fault.
    """
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
    _number(data.get("tare_s"), "tare_s", p)  # checked; kept with the other keys
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
    """Read and validate a trial's JSON sidecar (a regular file of at most 1 MiB).

    Parameters
    ----------
    path : path-like
        The sidecar.
    default_subject : str
        The folder's name (see :func:`parse_sidecar`).

    Returns
    -------
    Sidecar

    Raises
    ------
    SidecarError
        Unreadable, not UTF-8, not JSON (with its line), or a bad key.
    """
    p = Path(path)
    try:
        raw = read_limited(p, SidecarError, what="sidecar")
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SidecarError(f"not UTF-8 text ({err.reason} at byte {err.start})", path=p) from err
    except OSError as err:
        raise SidecarError(f"cannot read: {err.strerror}", path=p) from err
    try:
        data = loads_json_unique(text)
    except DuplicateKeyError as err:
        raise SidecarError(f"invalid JSON: {err} (JSON allows a key once in an object; a reader "
                    "would keep either)", path=p, line=err.line, key=err.key) from err
    except json.JSONDecodeError as err:
        raise SidecarError(f"invalid JSON: {err.msg} (column {err.colno})", path=p,
                           line=err.lineno) from err
    except RecursionError as err:
        raise SidecarError("invalid JSON: nested too deeply to be a sidecar", path=p) from err
    return parse_sidecar(data, path=p, default_subject=default_subject)


def unknown_sidecar_keys(sidecar: Sidecar) -> list[tuple[str, str | None]]:
    """Keys of *sidecar* evtribo neither reads nor writes.

    Parameters
    ----------
    sidecar : Sidecar

    Returns
    -------
    list of (str, str or None)
        Each unknown key with the closest known key (or None).
    """
    out = []
    for key in sidecar.extra:
        if key not in SIDECAR_KEYS:
            close = difflib.get_close_matches(key, sorted(SIDECAR_KEYS), n=1, cutoff=0.6)
            out.append((key, close[0] if close else None))
    return out


def write_sidecar(path: str | os.PathLike[str], sidecar: Sidecar | Mapping[str, Any], *,
                  force: bool = False) -> Path:
    """Write a sidecar atomically and durably (temporary file, fsync, rename).

    Parameters
    ----------
    path : path-like
        The sidecar to write.
    sidecar : Sidecar or mapping
        Its content; a ``rig`` given as the DBC's path alone is written in the one shape
        (``{"dbc": path}``).
    force : bool
        Replace an existing sidecar.

    Returns
    -------
    Path
        *path*.

    Raises
    ------
    OutputExistsError
        *path* exists and *force* is False.
    ValueError
        A value JSON cannot hold (nothing is written).
    """
    p = Path(path)
    if p.exists() and not force:
        raise OutputExistsError("exists already; use {force} to overwrite", path=p)
    payload = sidecar.to_dict() if isinstance(sidecar, Sidecar) else dict(sidecar)
    if isinstance(payload.get("rig"), str):
        payload["rig"] = _rig_shape(payload["rig"])
    # a value JSON cannot hold, a full disk: nothing is left behind
    text = json.dumps(payload, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
    atomic_write(p, text, durable=True)
    return p
