"""The rig as acquisition needs it: a rig TOML or a study's ``study.toml``, and its DBC.

A rig TOML (``src/evtribo/data/rigs/default.toml``) holds the keys of the ``[rig]`` table of
``study.toml`` (spec §1) at top level, plus ``name`` and, optionally, the rolling counters of
the load cells (``normal_force_counter``, ``tangential_force_counter``), with ``dbc``
relative to the TOML. A new study folder gets a copy of the DBC under ``rig/`` and a
``study.toml`` whose ``[rig]`` table names it.
"""

from __future__ import annotations

import logging
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evtribo.acquisition.logger import CounterSpec, counter_spec_from_dbc
from evtribo.errors import OutputExistsError, RigConfigError, StudyError
from evtribo.rig import Rig, default_rig_path, load_rig
from evtribo.study import read_study_toml, validate_name, write_study_toml

log = logging.getLogger(__name__)



def check_name(value: str, key: str) -> str:
    """Return *value* if it is a plain name (letters, digits, ``-``, ``_``).

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
    database: Any
    signals: dict[str, str]
    counters: list[CounterSpec] = field(default_factory=list)
    source: Path | None = None

    @classmethod
    def from_rig(cls, rig: Rig, name: str | None = None) -> AcquisitionRig:
        """Wrap a :class:`evtribo.rig.Rig` (names already checked against its DBC)."""
        signals = {role: ref.qualified_name for role, ref in rig.roles.items()}
        return cls(name=name or rig.name, dbc_path=rig.dbc, database=rig.database,
                   signals=signals, counters=_counters(rig),
                   source=None if rig.source is None else Path(rig.source))

    def message_name(self, arbitration_id: int, is_extended: bool = False) -> str | None:
        """The DBC message name of a standard (or, with *is_extended*, 29-bit) identifier,
        or None."""
        for msg in self.database.messages:
            if msg.frame_id == arbitration_id and bool(msg.is_extended_frame) == is_extended:
                return str(msg.name)
        return None


def _counters(rig: Rig) -> list[CounterSpec]:
    specs: list[CounterSpec] = []
    for cell in ("normal", "tangential"):
        ref = rig.counter(cell)  # the rig's counter role, or a *Counter signal: as decoding
        if ref is None:
            continue
        spec = counter_spec_from_dbc(rig.database, ref.message.name, ref.signal.name)
        if spec.key not in {s.key for s in specs}:
            specs.append(spec)
    return specs


def load_rig_toml(path: str | Path) -> AcquisitionRig:
    """Read a rig TOML (keys of spec §1's ``[rig]`` at top level, ``dbc`` relative to it).

    Raises
    ------
    RigConfigError
        Unreadable TOML, missing or unknown key, DBC not found or not parsing, unknown
        message or signal.
    """
    return AcquisitionRig.from_rig(load_rig(path))


def load_study_rig(study: str | Path) -> AcquisitionRig:
    """The rig named by ``STUDY/study.toml``'s ``[rig]`` table.

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


def create_study(study: str | Path, rig: AcquisitionRig, name: str | None = None) -> Path:
    """Make *study* a study folder for *rig*: copy its DBC to ``rig/``, write ``study.toml``.

    Returns
    -------
    Path
        The new ``study.toml``.

    Raises
    ------
    OutputExistsError
        If the folder already has a ``study.toml`` (it is left alone).
    """
    study = Path(study)
    dbc_rel = f"rig/{rig.dbc_path.name}"
    try:
        (study / "rig").mkdir(parents=True, exist_ok=True)
        if not (study / dbc_rel).exists():
            shutil.copyfile(rig.dbc_path, study / dbc_rel)
        table = {"name": rig.name, "dbc": dbc_rel, **rig.signals}
        path = write_study_toml(study, name=name or study.resolve().name, rig=table)
    except OutputExistsError:
        raise
    except (NotADirectoryError, FileExistsError) as err:
        raise StudyError("cannot create the study folder: a file is in the way "
                         f"({err.filename})", path=study) from err
    except PermissionError as err:
        raise StudyError(f"cannot create the study folder: {err.strerror} "
                         f"({err.filename})", path=study) from err
    log.info("new study folder %s for rig %r", study, rig.name)
    return path


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
    create_study(study, given)
    rig = load_study_rig(study)
    rig.name = given.name
    rig.counters = given.counters or rig.counters
    return rig


__all__ = [
    "AcquisitionRig",
    "check_name",
    "create_study",
    "default_rig_path",
    "load_rig_toml",
    "load_study_rig",
    "open_study",
]
