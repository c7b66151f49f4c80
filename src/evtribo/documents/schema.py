"""A result table's schema (:class:`TableSchema`: its file, its columns with their kind, unit
and meaning, its key, the columns a reader needs, those older folders lack) and the one
typing, reader and writer every table shares; the tables themselves are declared in
:mod:`evtribo.documents.tables`.

The one typing (:meth:`TableSchema.typed`), whether a table was computed or read back:
names (``text``) as Python strings in object columns, NaN where missing; counts (``count``)
as nullable integers (``Int64``); yes/no (``flag``) as nullable booleans; the rest as
float64. A table is read (:meth:`TableSchema.read`) with only empty cells missing (a subject
named ``NA`` stays ``NA``) and every float to the last bit; written
(:meth:`TableSchema.text`) in its schema's column order, without the index. pandas is
imported only then: the command line names the files without loading it.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from evtribo.errors import ResultFolderError, UserInputError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Column", "Kind", "TableSchema", "column", "csv_exact"]

#: What a column holds: names, counts, yes/no, or numbers.
Kind = Literal["text", "count", "flag", "float"]


@dataclass(frozen=True)
class Column:
    """One column of a result table: its header, its kind (``text``, ``count``, ``flag`` or
    ``float``: how it is typed), its unit (``N``, ``V``, ``Hz``, ``s``, ``%``; ``""`` for
    names, counts and numbers without one) and what it holds."""

    name: str
    kind: Kind
    unit: str
    doc: str


def column(name: str, spec: str, doc: str) -> Column:
    """A column, declared in a line.

    Parameters
    ----------
    name : str
        Its header.
    spec : str
        Its kind (``text``, ``count``, ``flag``), else the unit of a float (``N``, ``V``,
        ``Hz``, ``s``, ``%``, or ``""``).
    doc : str
        What it holds.

    Returns
    -------
    Column
    """
    if spec in ("text", "count", "flag"):
        return Column(name, spec, "", doc)  # type: ignore[arg-type]
    return Column(name, "float", spec, doc)


@dataclass(frozen=True)
class TableSchema:
    """A result table: its file, columns, key, the columns a reader needs, and those that
    results of an older evtribo lack.

    Attributes
    ----------
    file : str
        Its file name in a result folder.
    columns : tuple of Column
        Its columns, in the order written.
    key : tuple of str
        The columns that tell its rows apart (each key once in a table evtribo wrote).
    required : tuple of str
        The columns a reader needs (``compare`` reads a table holding these, extra columns
        ignored); empty: every column.
    newer : frozenset of str
        Columns an older evtribo did not write: read as empty when absent.
    either : tuple of tuple of str
        Groups of columns of which a reader needs one whole group (sine_trace.csv: the
        voltage, or the drive's amplitude and frequency); empty: none.
    """

    file: str
    columns: tuple[Column, ...]
    key: tuple[str, ...]
    required: tuple[str, ...]
    newer: frozenset[str] = frozenset()
    either: tuple[tuple[str, ...], ...] = ()
    _kinds: dict[str, Kind] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_kinds", {c.name: c.kind for c in self.columns})

    def names(self) -> tuple[str, ...]:
        """The column names, in the order written.

        Returns
        -------
        tuple of str
        """
        return tuple(c.name for c in self.columns)

    def typed(self, df: pd.DataFrame) -> pd.DataFrame:
        """*df* with the one typing (see the module's notes).

        Parameters
        ----------
        df : pandas.DataFrame
            The table as computed, or as read from its file.

        Returns
        -------
        pandas.DataFrame
            A new table: the same columns and rows (a fresh index).
        """
        return _typed(df, self._kinds)

    def empty(self, columns: tuple[str, ...] | None = None) -> pd.DataFrame:
        """A typed table of no rows with the schema's columns (or *columns*).

        Parameters
        ----------
        columns : tuple of str, optional

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        return self.typed(pd.DataFrame(columns=list(columns or self.names())))

    def read(self, path: str | os.PathLike[str], *, complete: bool = False,
             error: type[UserInputError] = UserInputError, again: str = "") -> pd.DataFrame:
        """The table in *path*, typed (:meth:`typed`); the columns :attr:`newer` names, when
        absent, added empty.

        Parameters
        ----------
        path : path-like
            The CSV file.
        complete : bool
            Require every column but the newer ones (a table evtribo wrote); else only
            :attr:`required` (and one group of :attr:`either`).
        error : type
            The error raised for a file that cannot be read or lacks a column.
        again : str
            What mends it, appended to the message (``"; run ..."``).

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        UserInputError (or *error*)
            The file cannot be parsed, or lacks a column (naming it as the key).
        ResultFolderError
            The user may not read the file.
        """
        import pandas as pd

        text = [n for n, k in self._kinds.items() if k == "text"]
        try:
            raw = pd.read_csv(path, dtype=dict.fromkeys(text, str), keep_default_na=False,
                              na_values=[""], **csv_exact())
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
            raise error(f"cannot read this CSV table: {err}{again}", path=path) from err
        except PermissionError as err:
            raise ResultFolderError(f"cannot read: {err.strerror}", path=path) from None
        for c in sorted(self.newer - set(raw.columns)):  # a table of an earlier evtribo
            raw[c] = pd.NA
        need = ([n for n in self.names() if n not in self.newer]
                if complete or not self.required else list(self.required))
        if not complete and self.either and not any(set(g) <= set(raw.columns)
                                                    for g in self.either):
            need += [c for c in self.either[-1] if c not in need]
        missing = [c for c in need if c not in raw.columns]
        if missing:
            raise error(f"missing column(s) {', '.join(missing)}; the file has: "
                        f"{', '.join(map(str, raw.columns))}{again}", path=path,
                        key=missing[0])
        try:
            return self.typed(raw)
        except ValueError as err:
            raise error(f"{err.args[-1]}{again}", path=path, key=err.args[0]) from None

    def rows(self, folder: str | os.PathLike[str]) -> list[dict[str, str]]:
        """The table's rows in *folder* as text, read with the standard library (for the
        console, which loads no pandas); none where the file is missing or unreadable.

        Parameters
        ----------
        folder : path-like
            The result folder.

        Returns
        -------
        list of dict of str to str
        """
        try:
            with open(os.path.join(folder, self.file), newline="", encoding="utf-8") as fh:
                return list(csv.DictReader(fh))
        except (OSError, UnicodeDecodeError, csv.Error):
            return []

    def text(self, df: pd.DataFrame) -> str:
        """The CSV text of a table: the schema's columns in order (a column *df* lacks
        empty), no index.

        Parameters
        ----------
        df : pandas.DataFrame

        Returns
        -------
        str
        """
        return str(df.reindex(columns=list(self.names())).to_csv(index=False))


def _typed(df: pd.DataFrame, kinds: dict[str, Kind]) -> pd.DataFrame:
    import pandas as pd

    columns = {}
    for i, c in enumerate(df.columns):
        try:
            columns[i] = _typed_column(df.iloc[:, i].reset_index(drop=True),
                                       kinds.get(c, "float"))
        except ValueError as err:
            raise ValueError(str(c), str(err)) from None
    out = pd.DataFrame(columns, index=pd.RangeIndex(len(df)))
    out.columns = pd.Index(list(df.columns), dtype=object)
    return out


def _typed_column(col: pd.Series, kind: Kind) -> pd.Series:
    import numpy as np
    import pandas as pd

    if kind == "text":
        values = col.to_numpy(dtype=object, na_value=np.nan, copy=True)
        na = pd.isna(values)
        if not isinstance(col.dtype, pd.StringDtype):  # read as text: strings already
            for i in np.flatnonzero(~na):
                if not isinstance(values[i], str):
                    values[i] = str(values[i])
        values[na] = np.nan
        return pd.Series(values, dtype=object)
    if kind == "count":
        number = pd.to_numeric(col, errors="coerce")
        if len(part := number[number.notna() & (number % 1 != 0)]):
            raise ValueError(f"a count that is not a whole number: {float(part.iloc[0]):g}")
        return number.astype("Int64")
    if kind == "flag":
        words = {"true": True, "false": False, "1": True, "0": False, "yes": True, "no": False}
        return pd.Series([pd.NA if pd.isna(v) else words.get(str(v).strip().lower(), pd.NA)
                          if isinstance(v, str) else bool(v) for v in col.astype(object)],
                         dtype="boolean")
    if col.dtype == np.float64:
        return col.copy()
    if pd.api.types.is_numeric_dtype(col) and not pd.api.types.is_bool_dtype(col) \
            and not isinstance(col.dtype, pd.api.extensions.ExtensionDtype):
        return col.astype("float64")
    return pd.to_numeric(col.astype(object), errors="coerce").astype("float64")


def csv_exact() -> dict[str, Any]:
    """read_csv's options that read back every float to_csv wrote, bit for bit (pandas 3's
    default parser does; pandas 2's needs its round-trip parser).

    Returns
    -------
    dict
        Keyword arguments for :func:`pandas.read_csv`.
    """
    import pandas as pd

    return {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
