"""What the analysis of a study depends on besides the bytes it reads, found cheaply: the
inputs' hashes remembered from the last time they were read, and the software's
fingerprint. Light on imports (the standard library only), so that ``evtribo analyze`` can
tell an unchanged study before it loads numpy, pandas or scipy
(:mod:`evtribo.results.unchanged`).

The hashes (``inputs/<study>.json`` in the cache folder): a file whose size, modification
and change times (ns), inode and device are those it had when it was hashed, and whose
change time was at least :data:`SETTLED_S` older than that hashing, is not read again. The
change time (``st_ctime``) moves whenever a file's bytes or its times are written, and no
program can set it back; the margin leaves out a file written in the same instant it was
hashed (as ``git`` does with its index).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import platform
import re
import signal
import sys
import threading
import time
import tomllib
from collections.abc import Iterable
from functools import cache
from pathlib import Path
from typing import Any

from evtribo.errors import UserInputError
from evtribo.store.files import atomic_write, open_regular, read_limited, sha256_file

log = logging.getLogger(__name__)

__all__ = [
    "SETTLED_S",
    "Halted",
    "HashMemo",
    "default_cache_dir",
    "installed_distributions",
    "plugin_distributions",
    "prehash",
    "software_fingerprint",
    "software_versions",
    "tree_digest",
]

#: A file changed less than this long before it was hashed is hashed again next time, s.
SETTLED_S = 3.0
#: How long the analysis waits for the head start's hashing to stop once told, s.
_FINISH_S = 5.0

#: What :func:`prehash` takes for a trial's log or sidecar (the log formats of
#: :mod:`evtribo.canlog.io.registry`, gzipped or not, and ``.json``): a guess, never a result.
_INPUT_SUFFIXES = (".log", ".asc", ".blf", ".trc", ".csv", ".db", ".mf4", ".json", ".gz")

_PACKAGES = {"python-can": "python-can", "cantools": "cantools", "numpy": "numpy",
             "scipy": "scipy", "pandas": "pandas", "pyarrow": "pyarrow"}


def default_cache_dir() -> Path:
    """Where decoded trials are cached by default.

    Returns
    -------
    Path
        ``$EVTRIBO_CACHE_DIR``, else ``$XDG_CACHE_HOME/evtribo``, else ``~/.cache/evtribo``.
    """
    env = os.environ.get("EVTRIBO_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "evtribo"


def _stat_key(st: os.stat_result) -> list[int]:
    return [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev]


class HashMemo:
    """SHA-256 of files as they were when last hashed, for one study.

    Parameters
    ----------
    directory : path-like or None
        The cache folder (None: nothing is remembered).
    study_root : path-like
        The study the files belong to (one memo file per study).
    """

    def __init__(self, directory: str | os.PathLike[str] | None,
                 study_root: str | os.PathLike[str]) -> None:
        self.path: Path | None = None
        self._known: dict[str, dict[str, Any]] = {}
        self._changed = False
        if directory is None:
            return
        root = os.path.abspath(study_root).encode("utf-8", "surrogateescape")
        self.path = (Path(directory).expanduser() / "inputs"
                     / f"{hashlib.sha256(root).hexdigest()[:24]}.json")
        try:
            known = json.loads(self.path.read_bytes())
            if isinstance(known, dict) and known.get("version") == 1:
                self._known = {str(k): v for k, v in dict(known.get("files", {})).items()
                               if isinstance(v, dict)}
        except (OSError, ValueError, TypeError):
            pass  # unreadable or foreign: every file is hashed

    def sha256(self, path: str | os.PathLike[str], *, halt: Any = None
               ) -> tuple[str, os.stat_result]:
        """The file's SHA-256 (remembered, or read now), and its stat from before hashing.

        Parameters
        ----------
        path : path-like
            A regular file (a FIFO or a device is refused, never read:
            :func:`~evtribo.store.files.open_regular`).
        halt : Event, optional
            Stop reading as soon as it is set (:class:`Halted`); the file is read a block
            at a time.

        Returns
        -------
        (str, os.stat_result)

        Raises
        ------
        UserInputError
            *path* is not a regular file.
        Halted
            *halt* was set while the file was read.
        """
        name = os.path.abspath(path)
        st = os.stat(path)
        rec = self._known.get(name)
        if (rec is not None and rec.get("stat") == _stat_key(st)
                and st.st_ctime_ns <= rec.get("hashed_ns", 0) - SETTLED_S * 1e9):
            return str(rec["sha256"]), st
        hashed_ns = time.time_ns()
        digest = sha256_file(path) if halt is None else _sha256_until(path, halt)
        self._known[name] = {"stat": _stat_key(st), "sha256": digest, "hashed_ns": hashed_ns}
        self._changed = True
        return digest, st

    def forget(self, path: str | os.PathLike[str]) -> None:
        """Do not remember *path* (it changed while it was hashed)."""
        self._changed |= self._known.pop(os.path.abspath(path), None) is not None

    def save(self) -> None:
        """Write what is remembered (of files that still exist); a cache folder that cannot
        be written is not an error."""
        if self.path is None or not self._changed:
            return
        files = {k: v for k, v in self._known.items() if os.path.exists(k)}
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(self.path, json.dumps({"version": 1, "files": files}))
        except OSError as err:
            log.debug("cannot write %s: %s", self.path, err)


class Halted(Exception):
    """Hashing was stopped before the file's end (its hash is not known)."""


#: Bytes read at a time by a hashing that can be stopped.
_BLOCK = 1 << 20


def _sha256_until(path: str | os.PathLike[str], halt: Any) -> str:
    """SHA-256 of a regular file, read a block at a time until *halt* is set."""
    h = hashlib.sha256()
    with os.fdopen(open_regular(path), "rb", buffering=0) as fh:
        while block := fh.read(_BLOCK):
            if halt.is_set():
                raise Halted(os.fspath(path))
            h.update(block)
    return h.hexdigest()


def tree_digest(folder: Path) -> str:
    """SHA-256 of the names and bytes of the ``.py`` files under *folder*.

    Parameters
    ----------
    folder : Path

    Returns
    -------
    str
    """
    h = hashlib.sha256()
    for path in sorted(folder.rglob("*.py")):
        data = path.read_bytes()
        h.update(f"{path.relative_to(folder).as_posix()}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def software_versions() -> dict[str, str | None]:
    """Versions of evtribo, Python and the libraries the analysis relies on.

    Returns
    -------
    dict
        Version by name (None for a library not installed).
    """
    from importlib.metadata import PackageNotFoundError, version

    import evtribo

    out: dict[str, str | None] = {"evtribo": evtribo.__version__,
                                  "python": platform.python_version()}
    for key, dist in _PACKAGES.items():
        try:
            out[key] = version(dist)
        except PackageNotFoundError:
            out[key] = None
    return out


def _normal(name: str) -> str:
    """A distribution's name as its metadata folder spells it (PEP 503, ``_`` for runs of
    ``-``, ``_`` and ``.``)."""
    return re.sub(r"[-_.]+", "_", name).lower()


def installed_distributions(names: Iterable[str]) -> list[str]:
    """Where the distributions named are installed, and at which version: the path of each
    one's metadata folder (``<name>-<version>.dist-info``, or ``.egg-info``), the first on
    :data:`sys.path` as Python finds the package, read from the folders' listings.

    What :func:`software_fingerprint` follows of the libraries: one listing per folder of
    :data:`sys.path` instead of importing importlib.metadata (40-60 ms), so that an
    unchanged study's results are written again that much sooner.

    Parameters
    ----------
    names : iterable of str
        Distribution names.

    Returns
    -------
    list of str
        One entry per name found, in the order of *names*; ``name: -`` for one not found.
    """
    wanted = {_normal(n): n for n in names}
    found: dict[str, str] = {}
    for entry in sys.path:
        try:
            listing = sorted(os.listdir(entry or "."))
        except OSError:  # a zip, a missing folder
            continue
        for item in listing:
            if item.endswith((".dist-info", ".egg-info")):
                key = _normal(item.split("-", 1)[0])
                if key in wanted and key not in found:
                    found[key] = os.path.join(os.path.abspath(entry or "."), item)
    return [found.get(key, f"{name}: -") for key, name in wanted.items()]


@cache
def plugin_distributions() -> tuple[str, ...]:
    """The distributions that plug into evtribo (a friction law, a population model, a log
    reader...): the metadata folders on :data:`sys.path` whose ``entry_points.txt`` declares
    one of evtribo's entry point groups (``[evtribo.friction_laws]``...), read from the
    folders' listings as :func:`installed_distributions` reads them.

    Returns
    -------
    tuple of str
        The path of each one's metadata folder (``<name>-<version>.dist-info``), in the order
        of :data:`sys.path`; empty when none is installed. Read once per process, as
        :func:`software_fingerprint` is.
    """
    found = []
    for entry in sys.path:
        try:
            listing = sorted(os.listdir(entry or "."))
        except OSError:
            continue
        for item in listing:
            if not item.endswith(".dist-info"):
                continue
            folder = os.path.join(os.path.abspath(entry or "."), item)
            try:
                with open(os.path.join(folder, "entry_points.txt"), encoding="utf-8") as f:
                    declared = "[evtribo." in f.read()
            except (OSError, UnicodeDecodeError):
                continue
            if declared:
                found.append(folder)
    return tuple(found)


@cache
def software_fingerprint() -> str:
    """SHA-256 of evtribo's source files, the Python build, the libraries the analysis
    runs on (their metadata folders: name, version and where they are installed) and the
    plug-ins installed (:func:`plugin_distributions`: a lab's friction law or log reader
    changes the results as evtribo's own code would).

    Returns
    -------
    str
    """
    h = hashlib.sha256(f"{sys.version}\0".encode())
    h.update(tree_digest(Path(__file__).resolve().parents[1]).encode())  # evtribo/, all of it
    h.update(json.dumps(installed_distributions(["evtribo", *_PACKAGES.values()])).encode())
    plugged = plugin_distributions()
    if plugged:  # none: the fingerprint evtribo alone has always had
        h.update(json.dumps(list(plugged)).encode())
    return h.hexdigest()


def _likely_inputs(root: Path) -> list[Path]:
    """study.toml, the DBC it names and the subjects' logs and sidecars, as found without
    loading the study (files of other names are left to the analysis). Not
    :func:`evtribo.study.discover_trials`: it imports python-can for the log formats'
    suffixes, which would hold this thread until the imports it is to overlap are done."""
    files = [root / "study.toml"]
    try:  # a FIFO or a device in its place is never read (the analysis says what it is)
        text = read_limited(files[0], UserInputError, what="study.toml").decode("utf-8")
        rig = tomllib.loads(text).get("rig", {})
        if isinstance(rig, dict) and isinstance(rig.get("dbc"), str):
            files.append(root / rig["dbc"])
    except (OSError, ValueError, UserInputError):
        pass
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        files += sorted(f for f in folder.iterdir() if not f.name.startswith(".")
                        and f.name.lower().endswith(_INPUT_SUFFIXES))
    return [f for f in files if f.is_file()]  # regular files only (links followed)


def _hash_ahead(study_dir: str | os.PathLike[str], cache_dir: str | os.PathLike[str] | None,
                halt: Any) -> None:
    """Hash the study's likely inputs into its memo, stopping after the file being hashed
    once *halt* is set; an error only leaves the rest to the analysis."""
    try:
        memo = HashMemo(cache_dir if cache_dir is not None else default_cache_dir(),
                        study_dir)
        for path in _likely_inputs(Path(study_dir)):
            if halt.is_set():
                break
            try:
                memo.sha256(path, halt=halt)
            except (OSError, UserInputError):  # gone, or not a regular file
                continue
            except Halted:
                break
        memo.save()
    except Exception as err:  # only a head start: the analysis hashes what is left
        log.debug("inputs of %s not hashed ahead: %s", study_dir, err)


def _hash_ahead_in_child(study_dir: str | os.PathLike[str],
                         cache_dir: str | os.PathLike[str] | None, halt: Any) -> None:
    """:func:`_hash_ahead` in a forked process: Ctrl-C is its parent's to handle."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _hash_ahead(study_dir, cache_dir, halt)


class _Prehash:
    """:func:`prehash`'s process (a thread where processes cannot be forked);
    :meth:`finish` stops it after the file it is hashing."""

    def __init__(self, study_dir: str | os.PathLike[str],
                 cache_dir: str | os.PathLike[str] | None) -> None:
        args: tuple[Any, ...]
        try:
            import multiprocessing

            ctx = multiprocessing.get_context("fork")
        except (ImportError, ValueError):  # no fork (Windows)
            self._halt: Any = threading.Event()
            args = (study_dir, cache_dir, self._halt)
            self._runner: Any = threading.Thread(target=_hash_ahead, args=args, daemon=True,
                                                 name="evtribo-prehash")
        else:
            self._halt = ctx.Event()
            args = (study_dir, cache_dir, self._halt)
            self._runner = ctx.Process(target=_hash_ahead_in_child, args=args, daemon=True,
                                       name="evtribo-prehash")

    def start(self) -> None:
        """Start hashing."""
        self._runner.start()

    def join(self, timeout: float | None = None) -> None:
        """Wait until every likely input is hashed (or *timeout*, s)."""
        self._runner.join(timeout)

    def is_alive(self) -> bool:
        """Whether it is still hashing."""
        return bool(self._runner.is_alive())

    def finish(self) -> None:
        """Stop hashing (within a block of the file being read), keep what was hashed, and
        return; a process that does not stop (a file system that does not answer) is
        ended."""
        self._halt.set()
        self.join(_FINISH_S)
        if self.is_alive() and hasattr(self._runner, "terminate"):
            self._runner.terminate()
            self.join(_FINISH_S)


def prehash(study_dir: str | os.PathLike[str], cache_dir: str | os.PathLike[str] | None
            ) -> _Prehash:
    """Start hashing a study's inputs into its memo, in a forked process: the command line
    does it while it imports the analysis, which leaves a core idle; the analysis then
    finds those hashed and hashes the rest on every core. A process, not a thread: a
    thread would wait for the interpreter's lock after each block while the imports hold
    it (and slow them down taking it), hashing at half speed. Where processes cannot be
    forked, a thread does it.

    Parameters
    ----------
    study_dir : path-like
        The study folder.
    cache_dir : path-like, optional
        The cache folder (default: :func:`default_cache_dir`).

    Returns
    -------
    _Prehash
        Started; call its ``finish()`` before the analysis reads the memo. Any error is
        left to the analysis, which hashes what was not.
    """
    ahead = _Prehash(study_dir, cache_dir)
    ahead.start()
    return ahead
