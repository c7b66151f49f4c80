"""What an analysis was run on and with: the provenance block of ``summary.json``.

``evtribo report`` shows it (:mod:`evtribo.report.study_report` reads ``inputs``, whose
entries carry ``file``, ``bytes`` and ``sha256``, ``rig``, ``software`` and ``settings``),
so that a result folder says exactly which recorded files, rig and software produced it,
even when the study folder is no longer at hand.

Each input is hashed once, when the analysis starts (:func:`input_files`); the workers
analyse a log only if it still is the file of that hash (see
:func:`evtribo.canlog.cache.load_trial`), so the hashes in ``summary.json`` are those of the bytes
analysed.
"""

from __future__ import annotations

import datetime as dt
import os
import platform
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from evtribo.errors import (
    LogFormatError,
    RigConfigError,
    SidecarError,
    StudyError,
    UserInputError,
)
from evtribo.store.files import sha256_file
from evtribo.store.memo import HashMemo, software_versions
from evtribo.study import StudyFolder
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

__all__ = ["changed_since", "file_record", "input_files", "provenance", "software_versions"]

emit = emitter(__name__)

#: The error that names an input of each role the user may not read.
_UNREADABLE: dict[str, type[UserInputError]] = {
    "log": LogFormatError, "sidecar": SidecarError, "dbc": RigConfigError}

#: Threads hashing the inputs (at most the machine's cores).
HASH_THREADS = min(4, os.cpu_count() or 1)

def file_record(path: Path, root: Path, role: str, memo: HashMemo | None = None
                ) -> dict[str, Any]:
    """``{"file", "role", "bytes", "sha256"}`` of one input file (name relative to *root*).

    The size is the one of the bytes hashed. For the analysis (not written out): the
    file's absolute path under ``"_path"`` and its modification time (ns) when hashed under
    ``"_mtime_ns"`` (-1 when the file changed while it was hashed).

    Parameters
    ----------
    path : Path
        The file.
    root : Path
        The study folder its name is given relative to.
    role : str
        ``"study"``, ``"dbc"``, ``"log"`` or ``"sidecar"``.
    memo : HashMemo, optional
        Hashes of files as they were when last hashed (:mod:`evtribo.results.reuse`): a
        file unchanged since is not read again.

    Returns
    -------
    dict
    """
    try:
        name = path.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        name = str(path.resolve())
    try:
        if memo is None:
            before = path.stat()
            digest = sha256_file(path)
        else:
            digest, before = memo.sha256(path)
    except PermissionError as err:  # made unreadable since the study was loaded
        raise _UNREADABLE.get(role, StudyError)(f"cannot read: {err.strerror}",
                                                path=path) from None
    after = path.stat()
    stamp = after.st_mtime_ns if (before.st_size, before.st_mtime_ns) == (
        after.st_size, after.st_mtime_ns) else -1  # written to while hashed
    if stamp < 0 and memo is not None:
        memo.forget(path)
    return {"file": name, "role": role, "bytes": after.st_size, "sha256": digest,
            "_mtime_ns": stamp, "_path": os.path.abspath(path)}


def input_files(study: StudyFolder, memo: HashMemo | None = None) -> list[dict[str, Any]]:
    """Records of a study's inputs: study.toml, the rig's DBC, each trial's log and sidecar.

    Parameters
    ----------
    study : evtribo.study.StudyFolder
        The study, as loaded.
    memo : HashMemo, optional
        Hashes of the files as they were when last hashed: a file unchanged since is not
        read again (:meth:`HashMemo.save` keeps the new ones).

    Returns
    -------
    list of dict
    """
    root = Path(study.root)
    files: list[tuple[Path, str]] = []
    toml = root / "study.toml"
    if toml.is_file():
        files.append((toml, "study"))
    rig = study.rig
    if rig is not None and Path(rig.dbc).is_file():
        files.append((Path(rig.dbc), "dbc"))
    for ref in study.trials:
        files.append((Path(ref.log_path), "log"))
        if ref.sidecar_path is not None and Path(ref.sidecar_path).is_file():
            files.append((Path(ref.sidecar_path), "sidecar"))
    # hashlib and the reads release the GIL: the files are hashed on every core, in order
    with ThreadPoolExecutor(max_workers=min(HASH_THREADS, len(files) or 1)) as pool:
        return list(pool.map(lambda item: file_record(item[0], root, item[1], memo), files))


def rig_roles(study: StudyFolder) -> dict[str, Any]:
    """The rig as a flat mapping: name, DBC (relative to the study), each role's signal and
    the counters' periods the rig file declares."""
    rig = study.rig
    if rig is None:
        return {}
    root = Path(study.root).resolve()
    dbc = Path(rig.dbc).resolve()
    try:
        dbc_name = dbc.relative_to(root).as_posix()
    except ValueError:
        dbc_name = str(dbc)
    out: dict[str, Any] = {"name": rig.name, "dbc": dbc_name,
                           "dbc_version": getattr(rig.database, "version", None)}
    out.update({role: ref.qualified_name for role, ref in rig.roles.items()})
    out.update({cell + "_force_counter_period": rig.counter_period(cell)
                for cell in ("normal", "tangential") if rig.counter_period(cell) is not None})
    return out


def provenance(study: StudyFolder, started: float,
               inputs: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """The provenance keys of summary.json.

    Parameters
    ----------
    study : evtribo.study.StudyFolder
        The study, as loaded.
    started : float
        Epoch time at which the analysis started, s.
    inputs : list of dict, optional
        :func:`input_files` of the study, as taken when the analysis started (default: hash
        them now).

    Returns
    -------
    dict
        ``study_dir`` (absolute), ``started`` (ISO 8601, UTC), ``inputs`` (see
        :func:`input_files`), ``rig`` (:func:`rig_roles`), ``software``
        (:func:`software_versions`), ``host`` (platform).
    """
    return {
        "study_dir": os.fspath(Path(study.root).resolve()),
        "started": dt.datetime.fromtimestamp(started, dt.UTC)
        .isoformat(timespec="seconds").replace("+00:00", "Z"),
        "inputs": [{k: v for k, v in r.items() if not k.startswith("_")}
                   for r in (input_files(study) if inputs is None else inputs)],
        "rig": rig_roles(study),
        "software": software_versions(),
        "host": {"platform": platform.platform(), "machine": platform.machine()},
    }


def changed_since(inputs: list[dict[str, Any]]) -> list[WarningRecord]:
    """Say each input that changed since :func:`input_files` hashed it
    (``input-changed-during``).

    Parameters
    ----------
    inputs : list of dict
        :func:`input_files`'s records.

    Returns
    -------
    list of WarningRecord
        The warnings said.
    """
    out = []
    for rec in inputs:
        try:
            st = os.stat(rec["_path"])
            now: tuple[int, int] | None = (st.st_size, st.st_mtime_ns)
        except OSError:
            now = None
        if now != (rec["bytes"], rec["_mtime_ns"]) and rec["_mtime_ns"] >= 0:
            out.append(emit("input-changed-during", file=rec["file"],
                            sha256=rec["sha256"][:12]))
    return out
