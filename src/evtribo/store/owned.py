"""What evtribo may replace or delete: the files it wrote, as its manifests record them
(:mod:`evtribo.store.manifest`).

Only a file evtribo wrote (:func:`~evtribo.store.manifest.owned`) is ever replaced (with
``--force``) or removed (an output of the same command that the new run does not write).
Anything else (a user's file, a file evtribo wrote that someone has edited since, a
symbolic link, a FIFO) is left as it is, ``--force`` or not, and the command says so before
it writes anything (:func:`refuse_foreign`, exit 2). So it does, before anything is
written, when the folder's manifest is not a file, when a link stands on the way to an
output (named with where it leads: nothing is written through a link), when the folder is
one whose files another output's manifest lists (a result folder's ``figures/``, compare's),
and when the folder cannot be written (:func:`check_writable`, exit 1).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Collection, Iterable, Mapping
from pathlib import Path

from evtribo.errors import FORCE, OutputExistsError, OutputWriteError
from evtribo.store.manifest import (
    HISTORY,
    MANIFEST,
    Entry,
    check_manifest,
    file_sha256,
    folder_lock,
    output_name,
    owned,
    plain_path,
    read_manifest,
    record,
)
from evtribo.store.names import check_new_path

__all__ = ["HISTORY", "MANIFEST", "Entry", "check_manifest", "check_output", "check_writable",
           "claim", "file_sha256", "folder_lock", "foreign", "output_name", "owned", "plain_path",
           "read_manifest", "record", "refuse_foreign"]


def foreign(folder: str | os.PathLike[str], rels: Iterable[str],
            by: Collection[str] | None = None, *,
            also: Mapping[str, Entry] | None = None) -> list[str]:
    """The names among *rels* that exist in *folder* and are not evtribo's (:func:`owned`).

    Parameters
    ----------
    folder : path-like
    rels : iterable of str
        Names relative to *folder*.
    by : collection of str, optional
        The commands whose files count as evtribo's (default: any).
    also : mapping of str to Entry, optional
        Files evtribo wrote that the manifest does not list (yet): those that documents
        evtribo wrote vouch for with their SHA-256 (:func:`record` them before replacing).

    Returns
    -------
    list of str
    """
    manifest = {**(also or {}), **read_manifest(folder)}
    out = []
    for rel in rels:
        path = Path(folder) / rel
        if os.path.lexists(path) and owned(folder, rel, by, manifest=manifest) is None:
            out.append(rel)
    return out


def _existing(path: Path) -> Path:
    """*path*, or the nearest folder above it that exists (where it would be made)."""
    while not os.path.lexists(path) and path != path.parent:
        path = path.parent
    return path


def check_writable(folder: str | os.PathLike[str], rels: Iterable[str] = ()) -> None:
    """Refuse, before anything is written, to write into *folder* (its manifest, and the
    files *rels* in it) when this process cannot write there: *folder* and each folder of
    *rels* (or the nearest one above that exists, where it would be made).

    Parameters
    ----------
    folder : path-like
    rels : iterable of str
        Names relative to *folder* that are to be written, replaced or removed.

    Raises
    ------
    OutputWriteError
        Naming the first folder that cannot be written (exit code 1): nothing was written.
    """
    root = Path(folder)
    folders = dict.fromkeys([_existing(root), *(_existing((root / rel).parent)
                                                for rel in rels)])
    ids = os.access in os.supports_effective_ids
    for path in folders:  # a link below the folder: nothing is written through it
        if path != _existing(root) and os.path.islink(path):
            continue
        if os.path.isdir(path) and not os.access(path, os.W_OK | os.X_OK, effective_ids=ids):
            raise OutputWriteError(
                "cannot be written (permission denied, or a read-only file system): evtribo "
                "writes its outputs there; make it writable, then run this again (nothing "
                "was written)", path=path)


def _link_on_the_way(folder: str | os.PathLike[str], rel: str) -> Path | None:
    """The first part of ``folder / rel`` below *folder* that is a symbolic link (the last
    one included), if any."""
    path = Path(folder)
    for part in rel.split("/"):
        path = path / part
        try:
            if stat.S_ISLNK(os.lstat(path).st_mode):
                return path
        except OSError:
            return None
    return None


def _refuse_link(folder: str | os.PathLike[str], rel: str, by: Collection[str] | None,
                 key: str | None) -> None:
    """Refuse, naming it and where it leads, a link on the way to ``folder / rel``."""
    link = _link_on_the_way(folder, rel)
    if link is None:
        return
    try:
        to = os.readlink(link)
    except OSError:
        to = "?"
    who = "evtribo" if by is None else f"evtribo {' or '.join(sorted(by))}"
    if link == Path(folder) / rel:
        todo = "move it away or choose another output"
    else:
        todo = f"remove the link ({who} makes a folder of its own there) or choose another output"
    raise OutputExistsError(
        f"is a symbolic link (to {to}): {who} writes, replaces and removes nothing through a "
        f"link, {FORCE} included; {todo}", path=link, key=key)


def _refuse_governed(folder: str | os.PathLike[str], rel: str, by: Collection[str] | None,
                     key: str | None) -> None:
    """Refuse to write into a folder whose files another command writes, as the manifest
    of a folder above it lists them (a result folder's ``figures/``: compare's)."""
    here = Path(os.path.abspath(folder))
    for depth in (1, 2):
        if len(here.parts) <= depth:
            return
        above = here.parents[depth - 1]
        inner = "/".join(here.parts[-depth:])
        theirs = sorted({e.by for name, e in read_manifest(above, quiet=True).items()
                         if name.startswith(f"{inner}/")})
        if theirs:
            who = "evtribo" if by is None else f"evtribo {' or '.join(sorted(by))}"
            spelt = Path(folder)  # as the user gave it, where it names the folder above
            if len(spelt.parts) > depth:
                above = spelt.parents[depth - 1]
            raise OutputExistsError(
                f"is inside {Path(folder)}, a folder of {above} whose files evtribo "
                f"{' and '.join(theirs)} writes and replaces ({above / MANIFEST} lists them): "
                f"{who} writes nothing else there, {FORCE} included; write it outside "
                f"{Path(folder)}", path=Path(folder) / rel, key=key)


def refuse_foreign(folder: str | os.PathLike[str], rels: Iterable[str],
                   by: Collection[str] | None = None, *, key: str | None = None,
                   also: Mapping[str, Entry] | None = None) -> None:
    """Refuse to write where a file evtribo did not write is (see the module's notes),
    ``--force`` or not.

    Parameters
    ----------
    folder : path-like
        The folder the outputs go into.
    rels : iterable of str
        The outputs, relative to *folder*.
    by : collection of str, optional
        The commands whose files may be replaced (default: any).
    key : str, optional
        The option that named the output (``"-o"``).
    also : mapping of str to Entry, optional
        As for :func:`foreign`.

    Raises
    ------
    OutputExistsError
        Naming the first such file (exit code 2).
    UserInputError
        The folder's manifest is not a file (:func:`check_manifest`).
    OutputWriteError
        The folder cannot be written (:func:`check_writable`).
    """
    check_manifest(folder)
    rels = list(rels)
    for rel in rels:  # there or not: nothing is written through a link
        _refuse_link(folder, rel, by, key)
    if rels:  # nor into a folder of another output's files
        _refuse_governed(folder, rels[0], by, key)
    found = foreign(folder, rels, by, also=also)
    if not found:
        check_writable(folder, rels)
        return
    path = Path(folder) / found[0]
    entry = {**(also or {}), **read_manifest(folder)}.get(found[0])
    if entry is not None and by is not None and entry.holds(file_sha256(path)):
        raise OutputExistsError(
            f"is an output of evtribo {entry.by}, which evtribo {' or '.join(sorted(by))} "
            f"never replaces, {FORCE} included; choose another output", path=path, key=key)
    what = "not a regular file" if not path.is_file() else "not a file evtribo wrote"
    whose = "" if by is None else f" as evtribo {' or '.join(sorted(by))}'s"
    raise OutputExistsError(
        f"is {what} ({Path(folder) / MANIFEST} does not list it with these bytes{whose}): "
        f"evtribo replaces only its own outputs, {FORCE} included; move it away or "
        "choose another output", path=path, key=key)


def check_output(path: str | os.PathLike[str], by: str, *, force: bool,
                 key: str | None = None) -> None:
    """The check before a command writes the single file *path* (``decode -o``, ``plot
    -o``, ``export -o``): a file there that evtribo did not write (:func:`refuse_foreign`)
    is refused, ``--force`` or not; one it did is refused without *force*.

    Parameters
    ----------
    path : path-like
        The output.
    by : str
        The command writing it (only its own earlier outputs are replaced).
    force : bool
        Replace an earlier output of the command.
    key : str, optional
        The option that named it (``"-o"``).

    Raises
    ------
    UserInputError
        A name evtribo does not write (:func:`~evtribo.store.names.check_new_path`).
    OutputExistsError
        Naming *path* (exit code 2).
    """
    check_new_path(path, key=key)
    path = Path(path)
    refuse_foreign(path.parent, [path.name], {by}, key=key)
    if os.path.lexists(path) and not force:
        raise OutputExistsError(f"exists; use {FORCE} to overwrite", path=path)


def claim(path: str | os.PathLike[str], by: str) -> None:
    """Record *path*, a file evtribo has just written whole, in its folder's manifest.

    Parameters
    ----------
    path : path-like
    by : str
        The command that wrote it.
    """
    path = Path(path)
    digest = file_sha256(path)
    if digest is not None:
        record(path.parent, {path.name: Entry(digest, by)})
