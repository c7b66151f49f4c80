"""A DBC file read as cantools reads it, refused by name when it is none, never echoed.

A study's ``[rig] dbc`` (or ``--dbc``) may name any path, inside the study or not. What is
read must be a regular file of at most :data:`MAX_DBC_BYTES` that begins as a DBC does (its
first word one of :data:`DBC_KEYWORDS`); anything else (``/etc/passwd``, a device, a log) is
refused naming the path and what it is not, and no error message quotes a line of the file:
cantools' parse errors, which do, are cut to the line and column.
"""

from __future__ import annotations

import os
import re

import cantools
import cantools.database
from cantools.database.can import Database

from evtribo.errors import RigConfigError
from evtribo.store.files import check_regular_file
from evtribo.warning.collect import emitter

emit = emitter(__name__)

__all__ = ["DBC_KEYWORDS", "MAX_DBC_BYTES", "parse_dbc"]

#: Largest DBC file read, bytes.
MAX_DBC_BYTES = 64 << 20
#: Words a DBC file may begin with (its sections; ``VERSION`` in nearly every one).
DBC_KEYWORDS = frozenset({
    "VERSION", "NS_", "BS_", "BS_:", "BU_", "BU_:", "VAL_TABLE_", "BO_", "BO_TX_BU_", "EV_",
    "ENVVAR_DATA_", "SGTYPE_", "CM_", "BA_DEF_", "BA_DEF_REL_", "BA_DEF_DEF_",
    "BA_DEF_DEF_REL_", "BA_", "BA_REL_", "VAL_", "SIG_GROUP_", "SIG_VALTYPE_", "SG_MUL_VAL_"})
_WHERE = re.compile(r"line \d+, column \d+")


def _named(path: str | os.PathLike[str], source: str | None) -> str:
    """*path* and a space for a message whose location is *source*; nothing when the
    location is the path itself."""
    return "" if source is not None and os.fspath(source) == os.fspath(path) else f"{path} "


def _text(path: str | os.PathLike[str], source: str | None, key: str | None) -> str:
    """The file's text (cantools' encoding for DBC, cp1252), once it is known to be a DBC."""
    name = _named(path, source)
    try:
        size = check_regular_file(path, RigConfigError, what="DBC file").st_size
    except RigConfigError as err:
        raise RigConfigError(f"{name}{err.message}", path=source, key=key) from err
    except OSError as err:
        raise RigConfigError(f"DBC file not found: {path}" if isinstance(
            err, FileNotFoundError) else f"cannot read {path}: {err.strerror}", path=source,
            key=key) from err
    if size > MAX_DBC_BYTES:
        raise RigConfigError(f"{name}is {size:,} bytes, too large for a DBC file (at most "
                             f"{MAX_DBC_BYTES:,})", path=source, key=key)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_DBC_BYTES + 1)
    except OSError as err:  # a regular file the user may not read (mode 000)
        raise RigConfigError(f"cannot read {name.strip()}".rstrip() + f": {err.strerror}",
                             path=source, key=key) from err
    head = data[:4096].removeprefix(b"\xef\xbb\xbf")
    while (head := head.lstrip()).startswith(b"//"):  # comment lines before the first word
        head = head.partition(b"\n")[2]
    words = head.split(None, 1)
    if not words or words[0].decode("latin-1") not in DBC_KEYWORDS or b"\0" in data:
        raise RigConfigError(f"{name}is not a DBC file: it does not begin as one (with "
                             "VERSION, NS_, BU_ or BO_...); its content is not shown",
                             path=source, key=key)
    try:
        return data.decode("cp1252")
    except UnicodeDecodeError as err:
        raise RigConfigError(f"cannot parse DBC {name}".rstrip() + f": byte {err.start} is "
                             "no cp1252 text "
                             "(DBC files are read as cp1252, as cantools reads them)",
                             path=source, key=key) from err


def _why(err: BaseException) -> str:
    """cantools' reason, without the text of the line it quotes: a syntax error is said by
    its line and column; another reason (a message's ID out of range...), which cantools
    gives only once the file has parsed as a DBC, as cantools says it."""
    text = str(err)
    where = _WHERE.search(text)
    if where is not None:
        return f"invalid syntax at {where.group(0)} (the line is not shown: open the file)"
    inner = re.fullmatch(r'DBC: "(.*)"', text, re.DOTALL)
    return inner.group(1) if inner else f"{type(err).__name__}: {text}"


def parse_dbc(path: str | os.PathLike[str], *, source: str | None = None,
              key: str | None = None) -> Database:
    """Parse a DBC file with cantools, strictly, else leniently with a warning.

    A DBC whose signals overlap or overrun their message (cantools' strict checks) is still
    loaded, with a warning: vendors' DBCs often have such quirks, and each signal is decoded
    on its own.

    Parameters
    ----------
    path : path-like
        The DBC.
    source, key : str, optional
        The file and key that named it, for messages (else the path itself).

    Returns
    -------
    cantools.database.can.Database

    Raises
    ------
    RigConfigError
        Not there, not a regular file, too large, not a DBC, or not parsing; the message
        names *path* (and *source* and *key*) and quotes nothing of the file.
    """
    text = _text(path, source, key)
    try:
        db = cantools.database.load_string(text, database_format="dbc", strict=True)
    except Exception as strict_err:  # ParseError, UnsupportedDatabaseFormatError, Error...
        try:
            db = cantools.database.load_string(text, database_format="dbc", strict=False)
        except Exception as err:
            raise RigConfigError(f"cannot parse DBC {_named(path, source)}".rstrip()
                                 + f": {_why(err)}", path=source,
                                 key=key) from None
        emit("dbc-lenient", dbc=str(path), why=_why(strict_err))
    if not isinstance(db, Database):
        raise RigConfigError(f"{_named(path, source)}is not a CAN database", path=source,
                             key=key)
    return db
