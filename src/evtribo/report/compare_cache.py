"""What ``evtribo compare`` can keep from its last run: each figure whose key is unchanged,
and the whole comparison when nothing it depends on changed.

A figure's key (:func:`figure_key`) is the SHA-256 of what it shows and how it is drawn:
the function that draws it and its arguments (:func:`digest`: tables by their values, a
model's parameters, a trial's sketch by its bytes), the figure width, and the software
(:func:`software`: evtribo's source files, the libraries' versions, matplotlib's). A file's
key (:func:`file_key`) adds its format and resolution. :class:`FigureStore` keeps every
figure drawn in the cache folder (``figures/<key>.<checksum>.<format>``).

Light on imports (the standard library), so that the command line can tell an
unchanged comparison before it loads matplotlib, scipy and pandas.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import struct
import sys
from collections.abc import Callable, Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any

from evtribo.documents.fit import FIT_JSON, FitDocument, read_fit
from evtribo.documents.summary import SUMMARY_FILE, read_summary
from evtribo.errors import ResultFolderError
from evtribo.results.outputs import FIGURES
from evtribo.store.files import read_entry, sha256_file, write_checksummed
from evtribo.store.memo import (
    HashMemo,
    default_cache_dir,
    installed_distributions,
    software_fingerprint,
)

log = logging.getLogger(__name__)

__all__ = ["KEY_VERSION", "FigureStore", "compare_key", "digest", "figure_key", "file_key",
           "last_fit", "options_text", "software", "unchanged"]

#: Bumped whenever what a figure's key covers changes.
KEY_VERSION = 1
#: The libraries a comparison's outputs depend on besides the analysis's.
_LIBRARIES = ("matplotlib", "statsmodels", "fonttools", "pillow")


def _update(h: Any, value: Any) -> None:
    """Feed *value* to *h* as bytes that tell it apart from any other value."""
    np = sys.modules.get("numpy")  # an array, a table: not imported, there is none
    pd = sys.modules.get("pandas")
    if np is not None and isinstance(value, np.generic):
        _update(h, value.item())
    elif value is None or isinstance(value, bool):
        h.update(f"{value};".encode())
    elif isinstance(value, (str, bytes)):
        data = value.encode("utf-8", "surrogateescape") if isinstance(value, str) else value
        h.update(f"{type(value).__name__}:{len(data)}:".encode())
        h.update(data)
    elif isinstance(value, int):
        h.update(f"int:{value};".encode())
    elif isinstance(value, float):
        h.update(b"float:" + struct.pack("<d", value))
    elif hasattr(value, "to_bytes") and callable(value.to_bytes) and not isinstance(value, int):
        _update(h, type(value).__qualname__)
        _update(h, value.to_bytes())
    elif np is not None and isinstance(value, np.ndarray):
        _update(h, (str(value.dtype), value.shape))
        h.update(np.ascontiguousarray(value).tobytes())
    elif pd is not None and isinstance(value, pd.DataFrame):
        _update(h, ([str(c) for c in value.columns], [str(t) for t in value.dtypes], len(value)))
        h.update(pd.util.hash_pandas_object(value, index=False).to_numpy().tobytes())
    elif pd is not None and isinstance(value, pd.Series):
        _update(h, value.to_frame())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        _update(h, (type(value).__qualname__, {f.name: getattr(value, f.name)
                                               for f in dataclasses.fields(value)}))
    elif isinstance(value, Mapping):
        h.update(f"map:{len(value)};".encode())
        for k in sorted(value, key=repr):
            _update(h, k)
            _update(h, value[k])
    elif isinstance(value, (set, frozenset)):  # its members in an order of their own
        h.update(f"set:{len(value)};".encode())
        for v in sorted(value, key=repr):
            _update(h, v)
    elif isinstance(value, (list, tuple)):
        h.update(f"seq:{len(value)};".encode())
        for v in value:
            _update(h, v)
    else:
        raise TypeError(f"a figure's key cannot hold a {type(value).__name__}")


def digest(value: Any) -> str:
    """The SHA-256 of a value by what it holds: numbers, text, arrays, tables (their
    values, not their row labels), dataclasses, mappings, sets and sequences of them, and
    objects with ``to_bytes()``.

    Parameters
    ----------
    value : object

    Returns
    -------
    str
        Hex digest.

    Raises
    ------
    TypeError
        A value of another kind.
    """
    h = hashlib.sha256()
    _update(h, value)
    return h.hexdigest()


@cache
def software() -> str:
    """What a figure is drawn with: evtribo's source files, the libraries the analysis and
    the fit run on, and matplotlib (their versions and where they are installed).

    Returns
    -------
    str
    """
    return f"{software_fingerprint()}\0{installed_distributions(_LIBRARIES)}"


def figure_key(func: Callable[..., Any], args: Sequence[Any], kwargs: Mapping[str, Any],
               width: str) -> str:
    """The key of a figure: what it shows and how it is drawn.

    Parameters
    ----------
    func : callable
        The function that draws it.
    args : sequence
        Its arguments.
    kwargs : mapping
        Its keyword arguments.
    width : str
        The journal width it is drawn at.

    Returns
    -------
    str
        Hex SHA-256 (40 digits).
    """
    name = f"{func.__module__}.{func.__qualname__}"
    return digest((KEY_VERSION, software(), name, width, tuple(args), dict(kwargs)))[:40]


def file_key(key: str, fmt: str, dpi: float) -> str:
    """The key of one file of a figure.

    Parameters
    ----------
    key : str
        The figure's (:func:`figure_key`).
    fmt : str
        Its format.
    dpi : float
        The resolution it is drawn at.

    Returns
    -------
    str
        Hex (40 digits).
    """
    return digest((key, fmt, float(dpi)))[:40]


class FigureStore:
    """The figures drawn, kept in the cache folder by their files' keys.

    Parameters
    ----------
    directory : path-like or None
        The cache folder (None: nothing kept).
    """

    def __init__(self, directory: str | os.PathLike[str] | None) -> None:
        self.directory = None if directory is None else Path(directory).expanduser() / FIGURES

    def get(self, key: str, fmt: str) -> bytes | None:
        """The bytes kept under *key*, or None (a damaged entry is removed)."""
        if self.directory is None:
            return None
        return read_entry(self.directory, key, f".{fmt}", bytes, what="kept figure",
                          then="it is drawn again")

    def put(self, key: str, fmt: str, data: bytes) -> None:
        """Keep a figure's bytes (a cache folder that cannot be written is not an error)."""
        if self.directory is None:
            return
        try:
            write_checksummed(self.directory, key, data, f".{fmt}")
        except OSError as err:
            log.debug("figure not kept under %s: %s", key, err)




def options_text(**options: Any) -> dict[str, Any]:
    """compare's options as its key holds them: text split at commas and stripped, a
    parameter file by its path and SHA-256, numbers as floats.

    Parameters
    ----------
    **options
        ``fit``, ``params``, ``formats``, ``dpi``, ``width``, ``models``, ``trial_checks``
        as :func:`~evtribo.report.compare.compare` takes them.

    Returns
    -------
    dict
    """
    def words(value: Any) -> Any:
        if value is None or isinstance(value, bool):
            return value
        parts = value.split(",") if isinstance(value, str) else list(value)
        return [str(p).strip().lower() for p in parts if str(p).strip()]

    out: dict[str, Any] = {}
    for name, value in sorted(options.items()):
        if name == "params" and value is not None:
            path = Path(value)
            try:
                out[name] = [os.path.abspath(path), sha256_file(path)]
            except OSError:
                out[name] = [os.path.abspath(path), None]
        elif name == "dpi" and value is not None:
            out[name] = float(value)
        else:
            out[name] = words(value)
    return out


def compare_key(summary: Mapping[str, Any], options: Mapping[str, Any]) -> str:
    """The key of a comparison: the analysis it compares (its tables' and inputs' SHA-256,
    its settings), its options (:func:`options_text`) and the software (:func:`software`).

    Parameters
    ----------
    summary : mapping
        The analysis's ``summary.json``.
    options : mapping
        :func:`options_text` of the comparison's options.

    Returns
    -------
    str
        Hex SHA-256.
    """
    return digest((KEY_VERSION, software(), dict(summary.get("output_sha256") or {}),
                   list(summary.get("inputs") or []), dict(summary.get("settings") or {}),
                   summary.get("strict"), summary.get("study_dir"), dict(options)))


def last_fit(folder: str | os.PathLike[str]) -> FitDocument:
    """The fit.json the last comparison of *folder* wrote (empty when none, or unreadable).

    Parameters
    ----------
    folder : path-like
        The result folder.

    Returns
    -------
    FitDocument
    """
    try:
        return read_fit(Path(folder) / FIT_JSON, missing_ok=True)
    except (OSError, ResultFolderError):
        return FitDocument()


def _same_bytes(folder: Path, hashes: Mapping[str, Any]) -> bool:
    """Whether every file named holds the bytes of its SHA-256."""
    for rel, sha in hashes.items():
        try:
            if sha256_file(folder / rel) != sha:
                return False
        except OSError:
            return False
    return True


def _inputs_as_analysed(summary: Mapping[str, Any], cache_dir: Path | None) -> bool:
    """Whether the study's files are those the analysis read (their hashes remembered in
    the cache folder when unchanged since)."""
    root = Path(str(summary.get("study_dir") or ""))
    if not root.is_dir():
        return False
    memo = HashMemo(cache_dir if cache_dir is not None else default_cache_dir(), root)
    try:
        for rec in summary.get("inputs") or []:
            path = Path(rec["file"])
            digest_, _ = memo.sha256(path if path.is_absolute() else root / path)
            if digest_ != rec["sha256"]:
                return False
    except (OSError, KeyError, TypeError):
        return False
    finally:
        memo.save()
    return True


def unchanged(folder: str | os.PathLike[str], options: Mapping[str, Any], *,
              cache_dir: str | os.PathLike[str] | None = None) -> FitDocument | None:
    """The fit.json of the last comparison of *folder*, when a comparison with these
    options would write what it wrote: the same key (:func:`compare_key`), the same
    analysis (``run_id``), every file compare wrote holding the bytes fit.json records, the
    analysis's tables and the study's files those it analysed. Call it holding the
    folder's lock.

    Parameters
    ----------
    folder : path-like
        The result folder.
    options : mapping
        :func:`options_text` of the comparison's options.
    cache_dir : path-like, optional
        The cache folder (the study's files' remembered hashes).

    Returns
    -------
    FitDocument or None
        fit.json; None when anything differs (the comparison is then run).
    """
    root = Path(folder)
    try:
        summary = read_summary(root / SUMMARY_FILE)
        fit = last_fit(root)
        if not fit or fit.get("compare_key") != compare_key(summary, options) or \
                fit.get("run_id") != summary.get("run_id"):
            return None
        written = fit.output_sha256, summary.output_sha256 or {}
    except (OSError, ResultFolderError):
        return None
    if not (_same_bytes(root, written[0]) and _same_bytes(root, written[1])
            and _inputs_as_analysed(summary, None if cache_dir is None else Path(cache_dir))):
        return None
    return fit
