"""What no command writes over: a study's inputs and raw CAN logs, ``--force`` included.

A study's inputs are its ``study.toml``, its DBC, its trials' logs and sidecars and its
subjects' session records; a raw CAN log is any file that reads as one (candump, ASC, BLF,
TRC, python-can CSV, MF4, SQLite...), in a study or not, whatever precedes its frames (a
log after a power cut begins with NUL bytes or a junk line: what a reader reads frames from
is a log); a DBC or a TOML file is an input
wherever it is (evtribo writes neither as an output). Every command that writes a file a
user names (``report -o``, ``report --tables``, ``compare``, ``decode -o``, ``plot -o``,
``model --figures``) asks :func:`refuse_input` first, before anything is written, and is
refused with exit code 2 naming the file. Symbolic links are followed: a link to a log is
the log. A path through a study's subject folder that is a link to a folder elsewhere
(supported, with a warning) is the study's, whether it is judged as spelt or as it
resolves: what the study holds through the link is protected as the study's.

A new file is refused where a study would read it as one of its inputs: a log or a ``.json``
in a subject folder (``evtribo analyze`` would take it for a trial), ``study.toml`` at a
study's root. A folder that holds a trial (a sidecar ``NAME.json`` that describes a trial
and a log ``NAME.*``, or a sidecar and a file that reads as a CAN log) is a subject folder
however it is reached (by its own path, not the study's): a log or a ``.json`` written there
is refused the same way.
"""

from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path

from evtribo.documents.session import SESSION_FILE
from evtribo.errors import FORCE, OutputExistsError, UserInputError
from evtribo.store.files import MF4_PROGRAM_ID, read_limited
from evtribo.store.names import check_new_path
from evtribo.study import NOT_SUBJECTS, STUDY_FILE, log_stem

__all__ = ["LOG_KINDS", "refuse_cache_in_study", "refuse_in_study", "refuse_input", "study_root",
           "what_input"]

#: What :func:`~evtribo.canlog.io.sniff.sniff` calls the raw CAN logs.
LOG_KINDS = frozenset({"candump-L", "candump-text", "candump-plain", "asc", "trc",
                       "python-can-csv", "savvycan", "blf", "mf4", "mdf", "sqlite"})
#: Bytes of a file looked at for a DBC's first keyword.
_DBC_HEAD = 4096
#: The keys of a sidecar that describe its trial (one of them makes a JSON a sidecar).
_DESCRIBES = frozenset({"subject", "waveform", "frequency_Hz", "amplitude_V", "condition"})
#: Pairs of a JSON and a log of the same name looked at for a trial, in a folder.
_PAIRS_LOOKED_AT = 32


def _written_by_evtribo(path: Path) -> bool:
    """Whether an MF4 names evtribo as the program that wrote it (its bytes 16-24)."""
    with open(path, "rb") as fh:
        return fh.read(24)[16:24] == MF4_PROGRAM_ID


def _spellings(path: str | os.PathLike[str]) -> list[Path]:
    """*path* as written (made absolute, no link resolved) and with its links resolved: a
    study's subject folder may be a link to a folder elsewhere, and what the study holds
    through it is the study's."""
    lexical = Path(os.path.abspath(path))
    real = Path(os.path.realpath(path))
    return [real] if lexical == real else [real, lexical]


def _root_above(here: Path) -> Path | None:
    for folder in (here, *here.parents):
        if (folder / STUDY_FILE).is_file():
            return folder
    return None


def study_root(path: str | os.PathLike[str]) -> Path | None:
    """The study folder *path* is in: with its links resolved, or as it is spelt (a path
    through a study's subject folder that is a link to a folder elsewhere is in the study).

    Parameters
    ----------
    path : path-like
        A file or folder, there or not.

    Returns
    -------
    Path or None
        The nearest folder at or above *path* holding a ``study.toml`` (its real path when
        the resolved path is in it); None outside any study.
    """
    for here in _spellings(path):
        root = _root_above(here)
        if root is not None:
            return root
    return None


def _study_dbc(root: Path) -> Path | None:
    """The DBC a study's ``study.toml`` names (None when it names none or cannot be read)."""
    try:
        with open(root / STUDY_FILE, "rb") as fh:
            rig = tomllib.load(fh).get("rig", {})
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError, RecursionError):
        return None
    dbc = rig.get("dbc") if isinstance(rig, dict) else None
    return Path(os.path.realpath(root / dbc)) if isinstance(dbc, str) else None


def _looks_like_dbc(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            head = fh.read(_DBC_HEAD).decode("latin-1")
    except OSError:
        return False
    words = head.lstrip("\ufeff\r\n\t ").split(None, 1)
    return bool(words) and words[0] in ("VERSION", "NS_", "BS_:", "BU_:")


def _in_study(path: Path) -> str | None:
    """What *path* (absolute, resolved or as spelt, there or not) is to the study it is in,
    if anything."""
    root = _root_above(path.parent)
    if root is None:
        return None
    real = Path(os.path.realpath(path))
    named = {Path(os.path.realpath(root / STUDY_FILE)): f"the study's {STUDY_FILE}",
             _study_dbc(root): "the study's DBC"}
    if real in named:
        return named[real]
    parts = path.relative_to(root).parts
    if len(parts) != 2 or parts[0].startswith(".") or parts[0] in NOT_SUBJECTS:
        return None
    where = f"({path.name} in a study's subject folder)"
    return ("a subject's session record" if path.name == SESSION_FILE
            else f"a trial's log {where}" if log_stem(path) is not None
            else f"a trial's sidecar {where}" if path.suffix.lower() == ".json" else None)


def _is_trial(folder: Path, sidecar: str, log: str) -> bool:
    """Whether *sidecar* and *log* in *folder* are a trial's: the sidecar describes a trial
    (a JSON object with a key of the trial's description) or the log reads as a CAN log (a
    result folder's ``fit.json`` and ``fit.csv`` are neither)."""
    from evtribo.canlog.io.sniff import sniff  # python-can: imported on use

    try:
        doc = json.loads(read_limited(folder / sidecar, UserInputError, what="sidecar"))
    except (OSError, UserInputError, ValueError, UnicodeDecodeError, RecursionError):
        doc = None
    if isinstance(doc, dict) and not _DESCRIBES.isdisjoint(doc):
        return True
    try:
        found = sniff(folder / log)
    except OSError:
        return False
    return found is not None and found.kind.removeprefix("gzip:") in LOG_KINDS


def _trial_beside(path: Path) -> str | None:
    """The name of a trial whose sidecar and log are in the folder of *path* (absolute,
    there or not), if any: that folder is a trial's folder however it is reached (through a
    study's subject folder, by its own path, through another link)."""
    try:
        names = sorted(os.listdir(path.parent))
    except OSError:
        return None
    sidecars = {n[: -len(".json")] for n in names if n.endswith(".json") and n != SESSION_FILE}
    pairs = [(f"{split[0]}.json", name) for name in names
             if (split := log_stem(Path(name))) is not None and split[0] in sidecars]
    for sidecar, log in pairs[:_PAIRS_LOOKED_AT]:
        if _is_trial(path.parent, sidecar, log):
            return sidecar[: -len(".json")]
    return None


def _in_trials_folder(path: Path) -> str | None:
    """What *path* would be read as in a folder that holds a trial (its sidecar and its
    log), wherever that folder is, if anything."""
    if path.name != SESSION_FILE and log_stem(path) is None and path.suffix.lower() != ".json":
        return None
    trial = _trial_beside(path)
    if trial is None:
        return None
    where = f"({path.name} beside the trial {trial}'s sidecar and log)"
    return ("a subject's session record" if path.name == SESSION_FILE
            else f"a trial's log {where}" if log_stem(path) is not None
            else f"a trial's sidecar {where}")


def what_input(path: str | os.PathLike[str]) -> str | None:
    """What study input or raw CAN log *path* is (or, for a file not yet there, would be
    read as), in words; None for a file a command may write.

    Parameters
    ----------
    path : path-like
        An output a command is about to write.

    Returns
    -------
    str or None
        ``"a CAN log (a candump -L log)"``, ``"the study's DBC"``... or None.
    """
    from evtribo.canlog.io.sniff import frame_line, sniff  # python-can: imported on use

    real = Path(os.path.realpath(path))
    inside = next((w for w in (*map(_in_study, _spellings(path)),
                               *map(_in_trials_folder, _spellings(path))) if w is not None),
                  None)
    if inside is not None or not real.is_file():
        return inside
    found = sniff(real)
    if found is not None and found.kind == "mf4" and _written_by_evtribo(real):
        return None  # decoded signals evtribo wrote (decode, export): --force replaces them
    if found is None or found.kind in ("unknown", "binary", "csv"):
        # a log after a power cut: NULs or a junk line first; the readers skip them
        found = frame_line(real) or found
    if found is not None and found.kind.removeprefix("gzip:") in LOG_KINDS:
        return f"a CAN log ({found.description})"
    if real.suffix.lower() == ".dbc" or _looks_like_dbc(real):
        return "a CAN database (DBC)"
    if real.suffix.lower() == ".toml":
        return "a TOML configuration (a study's or a rig's)"
    return None


def refuse_input(path: str | os.PathLike[str], *, command: str,
                 source: str | os.PathLike[str] | None = None, source_is: str = "the file read",
                 key: str | None = None) -> None:
    """Refuse to write *path* when it is a study input or a raw CAN log (see the module's
    docstring); ``--force`` does not change this.

    Parameters
    ----------
    path : path-like
        The output about to be written.
    command : str
        The command writing it (``"evtribo report"``), for the message.
    source : path-like, optional
        The file the command reads (``decode``'s log): writing over it is refused in so many
        words.
    source_is : str
        What *source* is, for the message (``"the log being decoded"``).
    key : str, optional
        The option that named *path* (``"-o"``).

    Raises
    ------
    OutputExistsError
        *path* is an input or a raw log (exit code 2).
    UserInputError
        *path* is a folder where a file is to be written, or a name evtribo does not write
        (:func:`~evtribo.store.names.check_new_path`).
    """
    check_new_path(path, key=key)  # a name evtribo writes and records, or refused first
    never = (f"{command} never writes over a study's input or a raw CAN log, {FORCE} "
             "included; choose another output")
    if os.path.isdir(path):
        raise UserInputError("is a folder, not a file to write", path=path, key=key)
    if source is not None and os.path.exists(path) and os.path.exists(source) \
            and os.path.samefile(path, source):
        raise OutputExistsError(f"is {source_is}: {never}", path=path, key=key)
    what = what_input(path)
    if what is None:
        return
    if os.path.exists(path):
        raise OutputExistsError(f"is {what}: {never}", path=path, key=key)
    folder = "study folder" if study_root(path) is not None else "trial's folder"
    raise OutputExistsError(f"would be read as {what} by evtribo analyze: write it outside the "
                            f"{folder}", path=path, key=key)


def refuse_in_study(folder: str | os.PathLike[str], *, command: str) -> None:
    """Refuse a result folder inside a study folder (``evtribo analyze`` never writes one
    there: it would read the results as part of the study) before *command* writes into it.

    Parameters
    ----------
    folder : path-like
        The result folder.
    command : str
        The command about to write into it.

    Raises
    ------
    UserInputError
        Naming the folder and the study.
    """
    root = study_root(folder)
    if root is not None:
        raise UserInputError(
            f"is inside the study folder {root}: {command} writes nothing into a study (the "
            "next analysis would read it as part of the study); move the result folder out "
            "of the study", path=folder)


def refuse_cache_in_study(cache_dir: str | os.PathLike[str] | None,
                          study: str | os.PathLike[str]) -> None:
    """Refuse a cache folder inside the study folder, as an output folder there is refused:
    the next analysis would read its files as part of the study.

    Parameters
    ----------
    cache_dir : path-like or None
        The cache folder given (None: the default one, outside any study).
    study : path-like
        The study folder (or its ``study.toml``).

    Raises
    ------
    UserInputError
        Naming the cache folder (key ``--cache-dir``) and the study.
    """
    if cache_dir is None:
        return
    root = Path(os.path.realpath(study))
    root = root.parent if root.name == STUDY_FILE else root
    if any(w == root or root in w.parents or study_root(w) == root
           for w in _spellings(cache_dir)):
        raise UserInputError(
            f"the cache folder is inside the study folder {study}: the next analysis would "
            "read its files as part of the study; choose a folder outside it, e.g. "
            f"{root.parent / (root.name + '-cache')}", path=cache_dir, key="--cache-dir")
