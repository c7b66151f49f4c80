"""The commit record of an output written as one unit, and its replay.

A commit (:class:`~evtribo.store.resultdir.Staging`) writes ``.evtribo-commit.json`` into
its new folder: the output it belongs to (``unit``), the folder its files go into
(``target``), the command, the files to install (each with its SHA-256, and the SHA-256 of
the file it replaces, if any) and the files to remove (each with its SHA-256). Its presence
is the commit; :func:`apply` carries it out, and finishes it after a crash.

A record found beside an output is replayed only when it passes every check
(:func:`read_record`): a regular file (never through a link) in a folder of the output's own
new-folder name, of this version, naming this output, with a target that is the output
itself, a folder inside it, or (for an output that is a single file, a report page) the
folder the output is in, and only names evtribo writes (:func:`~evtribo.store.owned.
output_name`; a hidden one only for an output that is a single file, its own name).
Anything else is refused by name (exit 2), and nothing of it is done.

Even a record that passes replaces or removes only what evtribo can show it wrote: a file
is removed only if the target's manifest lists it with the bytes the record names and it
still has them, and replaced only if it is absent, already the new file, or the manifest's
file of the bytes the record names (:mod:`evtribo.store.owned`). No path is followed
through a symbolic link.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from evtribo.errors import ResultFolderError
from evtribo.store.files import fsync_path, read_limited
from evtribo.store.manifest import (
    Entry,
    file_sha256,
    folder_lock,
    output_name,
    plain_path,
    read_manifest,
    record,
)

log = logging.getLogger(__name__)

__all__ = ["COMMIT_RECORD", "STAGE_MARK", "VERSION", "apply", "discard", "read_record", "withdraw"]

#: The commit record in a new folder: its presence is the commit.
COMMIT_RECORD = ".evtribo-commit.json"
#: What a new folder holds from its making to its removal: a folder without it is not one
#: evtribo made (but an empty one, the last step of a removal).
STAGE_MARK = ".evtribo-stage"
#: The record's version.
VERSION = 2
#: Largest record read, bytes.
_MAX_BYTES = 16 << 20
_HEX = frozenset("0123456789abcdef")


def _digest(value: Any, *, optional: bool = False) -> bool:
    if value is None:
        return optional
    return isinstance(value, str) and len(value) == 64 and set(value) <= _HEX


def _target_ok(doc: Mapping[str, Any], stage: Path, unit: Path) -> bool:
    """Whether the record's target is *unit*, a folder inside it, or (for a unit that is
    not a folder) the folder it is in, named as a commit names it."""
    home = stage.parent
    target = doc.get("target")
    if not isinstance(target, str):
        return False
    own = os.path.relpath(unit, home)
    if target == own or (target == "." and not unit.is_dir() and home == unit.parent):
        return True
    prefix = "" if own == "." else f"{own}/"
    inner = target[len(prefix):] if target.startswith(prefix) else ""
    return bool(inner) and plain_path(unit, inner) is not None


def _files_wrong(doc: Mapping[str, Any]) -> str | None:
    """What is wrong with a record's lists of files (None: nothing)."""
    install, remove = doc.get("install"), doc.get("remove")
    if not isinstance(install, list) or not isinstance(remove, list):
        return "no list of files"
    own = doc.get("unit") if doc.get("target") == "." else None  # a file: its own name

    def named(rel: Any) -> bool:
        return output_name(rel, hidden=rel == own)

    for item in install:
        if not (isinstance(item, list) and len(item) == 3 and named(item[0])
                and _digest(item[1]) and _digest(item[2], optional=True)):
            return f"a file to install that evtribo does not write ({item!r:.80})"
    for item in remove:
        if not (isinstance(item, list) and len(item) == 2 and named(item[0])
                and _digest(item[1])):
            return f"a file to remove that evtribo does not write ({item!r:.80})"
    return None


def _why_not(doc: Any, stage: Path, unit: Path) -> str | None:
    """What is wrong with a record (None: nothing)."""
    checks = (
        (lambda: isinstance(doc, dict) and doc.get("evtribo") == "commit",
         lambda: "not a commit record of evtribo's"),
        (lambda: doc.get("version") == VERSION,
         lambda: f"version {doc.get('version')!r}, not {VERSION}"),
        (lambda: doc.get("unit") == unit.name,
         lambda: f"it names another output ({doc.get('unit')!r})"),
        (lambda: _target_ok(doc, stage, unit),
         lambda: f"its target {doc.get('target')!r} is not {unit.name}'s"),
        (lambda: isinstance(doc.get("by"), str) and doc["by"].isidentifier(),
         lambda: "no command named"))
    for ok, why in checks:
        if not ok():
            return why()
    return _files_wrong(doc)


def read_record(stage: Path, unit: Path) -> dict[str, Any]:
    """The commit record in *stage*, a new folder of *unit*, checked (see the module's
    notes).

    Parameters
    ----------
    stage : Path
        The new folder.
    unit : Path
        The output (its real path).

    Returns
    -------
    dict

    Raises
    ------
    ResultFolderError
        The record fails a check: naming it, and what to do.
    """
    path = stage / COMMIT_RECORD
    refuse = (f"it is not replayed, and nothing of it is done: if no evtribo command is "
              f"writing {unit.name}, remove {stage}")
    try:
        if not stat.S_ISDIR(os.lstat(stage).st_mode):
            raise ResultFolderError(f"not a folder evtribo made (a link?); {refuse}",
                                    path=stage)
        doc = json.loads(read_limited(path, ResultFolderError, limit=_MAX_BYTES,
                                      what="commit record", follow=False))
    except ResultFolderError as err:
        raise ResultFolderError(f"{err.message}; {refuse}", path=path) from None
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise ResultFolderError(f"cannot be read as a commit record ({err}); {refuse}",
                                path=path) from None
    why = _why_not(doc, stage, unit)
    if why is None:
        target = stage.parent / doc["target"]
        linked = [item[0] for item in (*doc["install"], *doc["remove"])
                  if plain_path(target, item[0]) is None]
        why = f"a name through a symbolic link ({linked[0]!r})" if linked else None
    if why is not None:
        raise ResultFolderError(f"not a record evtribo wrote for {unit.name} ({why}); "
                                f"{refuse}", path=path)
    return doc


def _remove(target: Path, rel: str, digest: str, manifest: Mapping[str, Entry]) -> bool:
    """Remove ``target / rel`` if it is the manifest's file of *digest*, and the folders
    of ours it leaves empty."""
    path = plain_path(target, rel)
    entry = manifest.get(rel)
    if path is None or entry is None or not entry.holds(digest) or \
            file_sha256(path) != digest:
        if path is None or os.path.lexists(path):
            log.warning("%s: not removed: not the file evtribo wrote", target / rel)
        return False
    path.unlink()
    parent = path.parent
    while parent != target and not any(parent.iterdir()):
        parent.rmdir()  # a folder of ours left empty (figures/, report_files/)
        parent = parent.parent
    return True


def _install(stage: Path, target: Path, item: list[Any],
             manifest: Mapping[str, Entry]) -> bool:
    """Put the new file of *item* (``[rel, sha256, replaces]``) in place, if what is there
    now may be replaced; whether the target now holds it."""
    rel, new, old = item
    dst = plain_path(target, rel)
    if dst is None:
        log.warning("%s: not written: a symbolic link is on its way", target / rel)
        return False
    src = stage / rel
    now = file_sha256(dst) if os.path.lexists(dst) else None
    if now == new and not os.path.lexists(src):
        return True  # installed before a crash
    entry = manifest.get(rel)
    if os.path.lexists(dst) and not (old is not None and now == old and entry is not None
                                     and entry.holds(old)):
        log.warning("%s: not replaced: not the file evtribo wrote", dst)
        return False
    try:
        if not stat.S_ISREG(os.lstat(src).st_mode):
            return False
    except FileNotFoundError:
        return False
    dst.parent.mkdir(parents=True, exist_ok=True)
    os.replace(src, dst)
    return True


def apply(stage: Path, doc: Mapping[str, Any]) -> None:
    """Carry out a commit record (:func:`read_record`'s, or the one just written), then
    remove the record and its folder. Done again after a crash, it finishes the work.

    Parameters
    ----------
    stage : Path
        The new folder holding the record and the files to install.
    doc : mapping
        The record.
    """
    target = stage.parent / doc["target"]
    target.mkdir(parents=True, exist_ok=True)
    with folder_lock(target):
        manifest = read_manifest(target)
        for rel, digest in doc["remove"]:
            _remove(target, rel, digest, manifest)
        installed = {item[0]: Entry(item[1], doc["by"]) for item in doc["install"]
                     if _install(stage, target, item, manifest)}
        for folder in {target, *((target / rel).parent for rel in installed)}:
            fsync_path(folder, directory=True)
        record(target, installed, locked=True)
    (stage / COMMIT_RECORD).unlink()
    discard(stage)


def withdraw(stage: Path, doc: Mapping[str, Any]) -> bool:
    """Take back a commit record none of which was carried out (its carrying out failed
    before it changed anything: a folder that cannot be written): every file to install is
    still in the new folder, every file to remove still there with its bytes. The record is
    removed for good, so that the failed write is never finished later.

    Parameters
    ----------
    stage : Path
        The new folder holding the record.
    doc : mapping
        The record.

    Returns
    -------
    bool
        Whether it was taken back (False: part of it was carried out; it stays, for the next
        command on the output to finish).
    """
    target = stage.parent / doc["target"]
    if not all(os.path.lexists(stage / item[0]) for item in doc["install"]):
        return False
    for rel, digest in doc["remove"]:
        path = plain_path(target, rel)
        if path is None or file_sha256(path) != digest:
            return False
    (stage / COMMIT_RECORD).unlink(missing_ok=True)
    fsync_path(stage, directory=True)
    return True


def discard(stage: Path) -> None:
    """Remove a new folder evtribo made: its files, then its mark, then the folder (so that
    a removal cut short leaves a folder still known as evtribo's, or an empty one).

    Parameters
    ----------
    stage : Path
    """
    try:
        children = [c for c in stage.iterdir() if c.name != STAGE_MARK]
    except OSError:
        return
    for child in children:
        if child.is_dir() and not child.is_symlink():
            shutil.rmtree(child, ignore_errors=True)
        else:
            child.unlink(missing_ok=True)
    (stage / STAGE_MARK).unlink(missing_ok=True)
    with contextlib.suppress(OSError):
        stage.rmdir()
