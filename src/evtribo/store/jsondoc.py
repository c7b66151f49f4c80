"""JSON documents read strictly: a key given twice is an error (JSON parsers keep the last
one, silently), and an integer too long for any float is read as ``inf`` (for the reader's
range check to name its key) instead of failing inside the parser."""

from __future__ import annotations

import json
import re
from typing import Any

__all__ = ["DuplicateKeyError", "loads_json_unique"]


class DuplicateKeyError(ValueError):
    """A JSON object with a key given twice (JSON parsers keep the last one, silently)."""

    def __init__(self, key: str, line: int | None) -> None:
        self.key, self.line = key, line
        super().__init__(f"key {key!r} given twice")


def loads_json_unique(text: str) -> Any:
    """:func:`json.loads`, refusing an object that gives a key twice; an integer of more
    than 300 digits is read as a float (``inf``), for the reader's range check to name.

    Parameters
    ----------
    text : str
        The JSON document.

    Returns
    -------
    object

    Raises
    ------
    DuplicateKeyError
        Naming the key and the line of its second occurrence.
    json.JSONDecodeError
        Not JSON.
    """
    def unique(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in pairs:
            if key in out:
                found = list(re.finditer(re.escape(json.dumps(key)) + r"\s*:", text))
                line = text.count("\n", 0, found[1].start()) + 1 if len(found) > 1 else None
                raise DuplicateKeyError(key, line)
            out[key] = value
        return out

    return json.loads(text, object_pairs_hook=unique, parse_int=_json_int)


#: Digits of the longest JSON integer read as an integer; a longer one (beyond any float,
#: or Python's limit of 4,300 digits) is read as a float, ±inf: each reader's range check
#: then names its key.
_INT_DIGITS = 300


def _json_int(text: str) -> int | float:
    return int(text) if len(text.lstrip("-")) <= _INT_DIGITS else float(text)
