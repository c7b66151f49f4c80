"""The ``[rig.calibration]`` table of study.toml: the load cells' own calibration (known
zero offsets and the cross-talk matrix), checked and read."""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evtribo.errors import RigConfigError, toml_key_line

__all__ = ["CALIBRATION_KEYS", "MAX_ENTRY", "MAX_OFFSET_N", "Calibration"]

#: Keys of the rig's ``calibration`` table.
CALIBRATION_KEYS = ("normal_offset_N", "tangential_offset_N", "matrix")

Matrix2 = tuple[tuple[float, float], tuple[float, float]]

#: Largest magnitude of a zero offset, N.
MAX_OFFSET_N = 1000.0
#: Largest magnitude of an entry of the cross-talk matrix.
MAX_ENTRY = 100.0


@dataclass(frozen=True)
class Calibration:
    """The load cells' own calibration, applied after DBC scaling (``[rig.calibration]``).

    ``[Fn, Ft]_true = matrix @ ([Fn, Ft]_measured - [normal_offset_N, tangential_offset_N])``

    Attributes
    ----------
    normal_offset_N, tangential_offset_N : float or None, N
        Known zero offsets of the cells (None: not known; the analysis tares them).
    matrix : ((float, float), (float, float)) or None
        Cross-talk correction (None: the identity).
    """

    normal_offset_N: float | None = None
    tangential_offset_N: float | None = None
    matrix: Matrix2 | None = None

    @property
    def empty(self) -> bool:
        """Whether the calibration says nothing."""
        return (self.normal_offset_N is None and self.tangential_offset_N is None
                and self.matrix is None)

    def to_dict(self) -> dict[str, Any]:
        """The keys given, JSON-ready."""
        out: dict[str, Any] = {}
        for k in CALIBRATION_KEYS:
            v = getattr(self, k)
            if v is not None:
                out[k] = [list(r) for r in v] if k == "matrix" else v
        return out

    @classmethod
    def from_mapping(cls, mapping: object, *, source: str | None = None,
                     key: str = "rig.calibration") -> Calibration:
        """Check and read a calibration table.

        Raises
        ------
        RigConfigError
            Not a table, an unknown key (with the closest), a value that is not a finite
            number, a matrix that is not 2x2 or is singular; naming the file, line and key.
        """
        text = _read_text(source)

        def fail(message: str, k: str | None = None) -> RigConfigError:
            line = toml_key_line(text, key, k) if text and k else None
            return RigConfigError(message, path=source, line=line,
                                  key=f"{key}.{k}" if k else key)

        if not isinstance(mapping, Mapping):
            raise fail(f"must be a table, got {mapping!r}")
        for k in mapping:
            if k not in CALIBRATION_KEYS:
                close = difflib.get_close_matches(k, CALIBRATION_KEYS, n=1, cutoff=0.5)
                raise fail("unknown key" + (f" (did you mean {close[0]!r}?)" if close else "")
                           + f"; allowed: {', '.join(CALIBRATION_KEYS)}", k)
        values: dict[str, Any] = {}
        for k in ("normal_offset_N", "tangential_offset_N"):
            if k in mapping:
                v = mapping[k]
                if isinstance(v, bool) or not isinstance(v, int | float) \
                        or not math.isfinite(v):
                    raise fail(f"expected a finite number (N), got {v!r}", k)
                if abs(v) > MAX_OFFSET_N:
                    raise fail(f"{v!r} N is not allowed: a load cell's zero offset lies within "
                               f"±{MAX_OFFSET_N:g} N (beyond the range of any cell a finger "
                               "presses)", k)
                values[k] = float(v)
        if "matrix" in mapping:
            m = mapping["matrix"]
            ok = (isinstance(m, list) and len(m) == 2
                  and all(isinstance(r, list) and len(r) == 2 for r in m)
                  and all(isinstance(x, int | float) and not isinstance(x, bool)
                          and math.isfinite(x) for r in m for x in r))
            if not ok:
                raise fail(f"expected a 2x2 matrix of finite numbers such as "
                           f"[[1.0, 0.0], [0.0, 1.0]], got {m!r}", "matrix")
            big = [x for r in m for x in r if abs(x) > MAX_ENTRY]
            if big:
                raise fail(f"the entry {big[0]!r} is not allowed: a cross-talk correction's "
                           f"entries lie within ±{MAX_ENTRY:g} (a load cell its DBC scales to "
                           "newtons needs gains near 1)", "matrix")
            det = m[0][0] * m[1][1] - m[0][1] * m[1][0]
            if abs(det) < 1e-6:
                raise fail(f"the matrix {m!r} is singular (determinant {det:g})", "matrix")
            values["matrix"] = ((float(m[0][0]), float(m[0][1])),
                                (float(m[1][0]), float(m[1][1])))
        return cls(**values)


def _read_text(source: str | None) -> str | None:
    """The text of a configuration file, to find a key's line in (None if unreadable)."""
    if source is None:
        return None
    try:
        return Path(source).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
