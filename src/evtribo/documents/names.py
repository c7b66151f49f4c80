"""Subject and trial names: plain names, as the study folder and the sidecars use them."""

from __future__ import annotations

import os
import re

from evtribo.errors import SidecarError, StudyError

__all__ = ["MAX_NAME_BYTES", "NAME_PATTERN", "validate_name"]

#: Plain names: subjects and trials (no path separators, no ``..``).
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_-]+$")
#: Longest subject or trial name, bytes (the file system allows 255 for a whole file name,
#: which adds suffixes such as ``.log.part``).
MAX_NAME_BYTES = 100


def validate_name(value: object, *, what: str, path: str | os.PathLike[str] | None = None,
                  key: str | None = None, error: type[StudyError] | type[SidecarError] = StudyError
                  ) -> str:
    """Return *value* if it is a plain name (letters, digits, ``-``, ``_``), else raise.

    Parameters
    ----------
    value : object
        The proposed subject or trial name.
    what : str
        What the name is for, used in the message (``"subject"``, ``"trial"``).
    path, key : optional
        Where the name came from, for the message.
    error : type
        The error class to raise.

    Returns
    -------
    str
        *value*.
    """
    if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
        raise error(
            f"{what} name {value!r} is not allowed: use letters, digits, '-' and '_' only "
            "(no paths, no spaces)",
            path=path, key=key,
        )
    if len(value.encode()) > MAX_NAME_BYTES:
        raise error(f"{what} name {value[:20]}... is {len(value)} characters long; at most "
                    f"{MAX_NAME_BYTES} are allowed (file names have a length limit)",
                    path=path, key=key)
    return value
