"""The rig as acquisition needs it: a rig TOML or a study's ``study.toml``, and its DBC.

A rig TOML (``src/evtribo/data/rigs/default.toml``) holds the keys of the ``[rig]`` table of
``study.toml`` (spec §1) at top level, plus ``name`` and, optionally, the rolling counters of
the load cells (``normal_force_counter``, ``tangential_force_counter``), with ``dbc``
relative to the TOML. A new study folder gets a copy of the DBC under ``canlog/rig/`` and a
``study.toml`` whose ``[rig]`` table names it, both written under temporary names and renamed
into place (``study.toml`` last): a failure (a full disk) leaves nothing that blocks a retry.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cantools.database.can import Database, Message

from evtribo.acquisition.counters import CounterSpec, counter_spec_from_dbc
from evtribo.canlog.io.ids import frame_key, id_text
from evtribo.canlog.rig import Rig, default_rig_path, load_rig
from evtribo.errors import AcquisitionError, OutputExistsError, RigConfigError, StudyError
from evtribo.study import STUDY_FILE, read_study_toml, validate_name, write_study_toml

log = logging.getLogger(__name__)

#: The roles of the load cells, whose frames a recording must receive.
LOAD_CELL_ROLES = ("normal_force", "tangential_force")


def check_name(value: str, key: str) -> str:
    """Return *value* if it is a plain name (letters, digits, ``-``, ``_``).

    Parameters
    ----------
    value : str
        The proposed name.
    key : str
        What it names (``"subject"``, ``"trial"``), for the message.

    Returns
    -------
    str
        *value*.

    Raises
    ------
    StudyError
        For anything else (a path, ``..``, spaces, an empty name), naming *key*.
    """
    return validate_name(value, what=key, key=key)


@dataclass
class AcquisitionRig:
    """A rig as the logger needs it: its DBC, its roles, the counters to check for losses.

    Attributes
    ----------
    name : str
        Free text.
    dbc_path : Path
        The DBC file.
    database : cantools.database.can.Database
        The parsed DBC.
    signals : dict
        ``{"normal_force": "FzCell.Fz", ...}``: the roles the rig names.
    counters : list of CounterSpec
        Rolling frame counters (the rig's counter roles, or signals named ``*Counter`` /
        ``*Cnt`` in the force messages).
    source : Path
        The TOML it was read from.
    """

    name: str
    dbc_path: Path
    database: Database
    signals: dict[str, str]
    counters: list[CounterSpec] = field(default_factory=list)
    source: Path | None = None
    #: The DBC's messages by :func:`~evtribo.canlog.io.ids.frame_key`.
    messages: dict[int, Message] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.messages = {frame_key(int(m.frame_id), bool(m.is_extended_frame)): m
                         for m in self.database.messages}

    def _message(self, role: str) -> Message:
        """The DBC message of a role's signal (``FzCell`` of ``"FzCell.Fz"``)."""
        return self.database.get_message_by_name(self.signals[role].split(".")[0])

    @classmethod
    def from_rig(cls, rig: Rig, name: str | None = None) -> AcquisitionRig:
        """Wrap a :class:`evtribo.canlog.rig.Rig` (names already checked against its DBC)."""
        signals = {role: ref.qualified_name for role, ref in rig.roles.items()}
        return cls(name=name or rig.name, dbc_path=rig.dbc, database=rig.database,
                   signals=signals, counters=_counters(rig),
                   source=None if rig.source is None else Path(rig.source))

    def role_messages(self, roles: tuple[str, ...] = LOAD_CELL_ROLES) -> dict[str, int]:
        """``{message name: frame_key}`` of the messages carrying *roles* (by default the
        load cells'), in the order of the roles."""
        out: dict[str, int] = {}
        for role in roles:
            if role in self.signals:
                msg = self._message(role)
                out[str(msg.name)] = frame_key(int(msg.frame_id), bool(msg.is_extended_frame))
        return out

    def describe(self) -> str:
        """Its messages and what they carry, for a person: ``FzCell (0x0C1): normal_force;
        FxCell (0x0C2): tangential_force; HvStatus (0x1A0): excitation_enabled, ...``."""
        by_message: dict[str, list[str]] = {}
        for role, ref in self.signals.items():
            if role.endswith("_counter"):
                continue
            by_message.setdefault(ref.split(".")[0], []).append(role)
        parts = []
        for name, roles in by_message.items():
            msg = self.database.get_message_by_name(name)
            ident = "0x" + id_text(int(msg.frame_id), bool(msg.is_extended_frame))
            parts.append(f"{name} ({ident}): {', '.join(roles)}")
        return "; ".join(parts)

    def message_name(self, arbitration_id: int, is_extended: bool = False) -> str | None:
        """The DBC message name of a standard (or, with *is_extended*, 29-bit) identifier,
        or None."""
        msg = self.messages.get(frame_key(arbitration_id, is_extended))
        return None if msg is None else str(msg.name)


def _counters(rig: Rig) -> list[CounterSpec]:
    specs: list[CounterSpec] = []
    for cell in ("normal", "tangential"):
        ref = rig.counter(cell)  # the rig's counter role, or a *Counter signal: as decoding
        if ref is None:
            continue
        spec = counter_spec_from_dbc(rig.database, ref.message.name, ref.signal.name,
                                     period=rig.counter_period(cell),
                                     period_key=f"{cell}_force_counter_period")
        if spec.key not in {s.key for s in specs}:
            specs.append(spec)
    return specs


def load_rig_toml(path: str | Path) -> AcquisitionRig:
    """Read a rig TOML (keys of spec §1's ``[rig]`` at top level, ``dbc`` relative to it).

    Parameters
    ----------
    path : path
        The rig TOML.

    Returns
    -------
    AcquisitionRig

    Raises
    ------
    RigConfigError
        Unreadable TOML, missing or unknown key, DBC not found or not parsing, unknown
        message or signal.
    """
    return AcquisitionRig.from_rig(load_rig(path))


def load_study_rig(study: str | Path) -> AcquisitionRig:
    """The rig named by ``STUDY/study.toml``'s ``[rig]`` table.

    Parameters
    ----------
    study : path
        The study folder.

    Returns
    -------
    AcquisitionRig

    Raises
    ------
    StudyError
        study.toml unreadable, with unknown keys, or without ``[rig]``.
    RigConfigError
        The ``[rig]`` table is wrong.
    """
    path = Path(study) / "study.toml"
    table = read_study_toml(path)["rig"]
    rig = Rig.from_mapping(table, path.parent, source=path, key_prefix="rig")
    return AcquisitionRig.from_rig(
        rig, name=str(table.get("name") or rig.database.version or rig.dbc.name))


def _make_dirs(folder: Path) -> list[Path]:
    """Create *folder* and its missing parents; return those created, deepest first."""
    missing = []
    for p in [folder, *folder.parents]:
        if p.exists():
            break
        missing.append(p)
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def _place(src: Path, dst: Path) -> bool:
    """Move the finished file *src* to *dst* unless *dst* exists; True if it was moved."""
    try:
        os.link(src, dst)  # fails if dst exists, even if another process just made it
    except FileExistsError:
        return False
    except OSError:  # a file system without hard links
        if dst.exists():
            return False
        os.replace(src, dst)
        return True
    src.unlink()
    return True


def _place_dbc(staged: Path, target: Path) -> bool:
    """Put the rig's DBC in the study; True if this call put it there.

    A DBC already there with the same bytes is kept; an empty one (left by an older,
    interrupted study creation) is replaced; another one is an error.
    """
    if _place(staged, target):
        return True
    old = target.read_bytes()
    if old == staged.read_bytes():
        return False
    if not old:
        os.replace(staged, target)
        return True
    raise StudyError(f"a different DBC is in the way of the rig's {staged.name} (move it "
                     "away, or give --rig for it)", path=target)


def write_new_study(study: str | Path, dbc: str | Path, *, dbc_rel: str, name: str,
                    rig: dict[str, Any], calibration: dict[str, Any] | None = None,
                    calibration_note: str = "") -> Path:
    """Create the study folder *study*: a copy of *dbc* at *dbc_rel* and ``study.toml``.

    Everything is written under temporary names in *study* and renamed into place,
    ``study.toml`` last; on a failure, what this call created is removed again.

    Parameters
    ----------
    study : path
        The study folder (created with its parents if missing).
    dbc : path
        The rig's DBC.
    dbc_rel : str
        Where its copy goes, relative to the study (``rig/default.dbc``).
    name : str
        The study's ``name``.
    rig : dict
        The ``[rig]`` table (its ``dbc`` key should be *dbc_rel*).
    calibration : dict, optional
        The ``[rig.calibration]`` table.
    calibration_note : str
        A comment above it.

    Returns
    -------
    Path
        The new ``study.toml``.

    Raises
    ------
    OutputExistsError
        The folder has a ``study.toml`` already (it is left alone).
    StudyError
        A different DBC is in the way.
    OSError
        Writing failed (a full disk...): nothing of this call is left behind.
    """
    study = Path(study)
    toml = study / STUDY_FILE
    if toml.exists():
        raise OutputExistsError("exists already", path=toml)
    target = study / dbc_rel
    created = _make_dirs(target.parent)
    placed_dbc = False
    staging = Path(tempfile.mkdtemp(prefix=".evtribo-new-study-", dir=study))
    try:
        staged = staging / target.name
        shutil.copyfile(dbc, staged)
        written = write_study_toml(staging, name=name, rig=rig, calibration=calibration,
                                   calibration_note=calibration_note)
        placed_dbc = _place_dbc(staged, target)
        if not _place(written, toml):
            raise OutputExistsError("exists already", path=toml)
    except BaseException:
        if placed_dbc:
            target.unlink(missing_ok=True)
        shutil.rmtree(staging, ignore_errors=True)
        for folder in created:  # deepest first
            try:
                folder.rmdir()
            except OSError:
                break
        raise
    shutil.rmtree(staging, ignore_errors=True)
    return toml


def create_study(study: str | Path, rig: AcquisitionRig, name: str | None = None) -> Path:
    """Make *study* a study folder for *rig*: copy its DBC to ``canlog/rig/``, write ``study.toml``
    (:func:`write_new_study`).

    Parameters
    ----------
    study : path
        The folder (created if missing).
    rig : AcquisitionRig
    name : str, optional
        The study's ``name`` (default: the folder's name).

    Returns
    -------
    Path
        The new ``study.toml``.

    Raises
    ------
    OutputExistsError
        If the folder already has a ``study.toml`` (it is left alone).
    StudyError
        A file is in the way, or the folder cannot be written.
    AcquisitionError
        Writing failed (a full disk): nothing of the new study is left.
    """
    study = Path(study)
    dbc_rel = f"rig/{rig.dbc_path.name}"
    table = {"name": rig.name, "dbc": dbc_rel, **rig.signals}
    try:
        path = write_new_study(study, rig.dbc_path, dbc_rel=dbc_rel,
                               name=name or study.resolve().name, rig=table)
    except (OutputExistsError, StudyError):
        raise
    except (NotADirectoryError, FileExistsError) as err:
        raise StudyError("cannot create the study folder: a file is in the way "
                         f"({err.filename})", path=study) from err
    except PermissionError as err:
        raise StudyError(f"cannot create the study folder: {err.strerror} "
                         f"({err.filename})", path=study) from err
    except OSError as err:  # a full disk: not the user's mistake (exit code 1)
        raise AcquisitionError(f"cannot create the study folder: {err.strerror or err} "
                               f"({err.filename or study}); nothing of it was kept",
                               path=study) from err
    log.info("new study folder %s for rig %r", study, rig.name)
    return path


def refuse_misspelt_study(study: str | Path, *, new: bool = False) -> None:
    """Refuse a study folder that is not there when a study of a similar name is beside
    it (``my-stuyd`` beside ``my-study``): a new study would be made for the default rig
    without a word about the one meant.

    Parameters
    ----------
    study : path
        The study folder given.
    new : bool
        A new study was asked for (``--new-study``): nothing is refused.

    Raises
    ------
    StudyError
        Naming the similar study (key ``--study``).
    """
    import difflib

    study = Path(study)
    if new or (study / STUDY_FILE).exists():
        return
    parent = study.absolute().parent
    try:
        beside = [p.name for p in parent.iterdir()
                  if p.name != study.name and (p / STUDY_FILE).is_file()]
    except OSError:
        return
    close = difflib.get_close_matches(study.name, beside, n=1, cutoff=0.75)
    if close:
        meant = study.with_name(close[0])
        raise StudyError(f"{study} is not a study; did you mean {meant}, the study beside "
                         f"it? (--new-study makes a new study named {study.name})",
                         key="--study")


def open_study(study: str | Path, rig_path: str | Path | None = None, *,
               create: bool = True) -> AcquisitionRig:
    """The rig of *study*, creating the study folder for *rig_path* when it has none.

    Parameters
    ----------
    study : path
        The study folder (created if missing).
    rig_path : path, optional
        Rig TOML for a new study (default: :func:`default_rig_path`). For an existing study
        it must describe the same DBC as the study's.

    create : bool
        False: only say which rig the study would use (nothing is written).

    Returns
    -------
    AcquisitionRig
        The study's rig (the new study's, when it was created).

    Raises
    ------
    RigConfigError
        Bad rig, or *rig_path* disagrees with the existing study's rig.
    StudyError
        *study* is a file, or its folder cannot be created.
    """
    study = Path(study)
    if study.exists() and not study.is_dir():
        raise StudyError("expected a study folder, found a file", path=study)
    if (study / "study.toml").exists():
        rig = load_study_rig(study)
        if rig_path is not None:
            given = load_rig_toml(rig_path)
            if given.dbc_path.read_bytes() != rig.dbc_path.read_bytes():
                raise RigConfigError(
                    f"the study already uses the DBC {rig.dbc_path}, which differs from "
                    f"{given.dbc_path} of --rig {rig_path}", path=study / "study.toml",
                    key="rig.dbc")
            rig.counters = rig.counters or given.counters
        return rig
    given = load_rig_toml(rig_path if rig_path is not None else default_rig_path())
    if not create:
        return given
    try:
        create_study(study, given)
    except OutputExistsError:  # another process created it meanwhile: use it
        return open_study(study, rig_path, create=False)
    rig = load_study_rig(study)
    rig.name = given.name
    rig.counters = given.counters or rig.counters
    return rig


__all__ = [
    "LOAD_CELL_ROLES",
    "AcquisitionRig",
    "check_name",
    "create_study",
    "default_rig_path",
    "load_rig_toml",
    "load_study_rig",
    "open_study",
    "refuse_misspelt_study",
    "write_new_study",
]
