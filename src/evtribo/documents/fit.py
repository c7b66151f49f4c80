"""``fit.json``: what one ``evtribo compare`` fitted and wrote.

Keys (in the order ``compare`` writes them, :data:`FIT_KEYS`): ``run_id`` (the analysis
fitted, from its ``summary.json``), ``software``, ``fit_version`` (:data:`FIT_VERSION`,
the document's shape), ``fit`` (the parameters fitted per subject),
``parameters_file`` (``{"path", "sha256"}`` or null), ``fixed_parameters``, ``subjects``
(per subject: ``parameters``, ``estimates``, ``correlation``, ``rmse_N``, ``r2``,
``chi2_reduced``, ``n_points``, ``mu_measured``, ``interval``), ``figures``, ``notes`` (the
texts of the warnings, for readers of version 1), ``warnings`` (what the comparison said,
in the order said, each a record as summary.json keeps the analysis's: ``kind``,
``effect``, ``text``, ``subject``, ``trial``... :meth:`WarningRecord.as_json
<evtribo.warning.record.WarningRecord.as_json>`), ``population`` (``n_subjects``,
``min_subjects``, ``notes``: the texts of what could not be estimated and why,
``outliers``: each ``{"subject", "quantity", "value", "low", "high", "unit"}``,
``checks``: the mixed model's per drive, by its label ``square 10000 Hz``, each ``{"ok",
"finite", "hessian_pd", "agree", "determined", "text", "waveform", "frequency_Hz"}``; an
older fit.json's is the text alone),
``compare_key`` (what the comparison was made from: the analysis, the options, the software;
:func:`evtribo.report.compare_cache.compare_key`) and ``output_sha256`` (every file compare wrote,
which ``evtribo report`` checks). Each figure's record (``kind``, ``title``, ``stem``,
``subject``, ``caption``) says where the report places it (``section``, ``per`` and, for a
kind shown as a grid with many subjects, ``grid``: its title and caption; the figure
registry's, :mod:`evtribo.figures.registry`, so that a report made where the kind is not
registered places it) and names the key and resolution its files were drawn from (``key``,
``dpi``). The document
is JSON with two-space indentation and a final newline; non-finite numbers are written as
null. A document without ``fit_version`` is of version 1 (no ``warnings``): its notes are
lifted into records when read (:func:`evtribo.warning.legacy_compare.lift_notes`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evtribo.documents.population_table import Checks, Drive
from evtribo.errors import ResultFolderError
from evtribo.store.files import atomic_write, read_regular
from evtribo.warning.legacy_compare import lift_notes
from evtribo.warning.record import WarningRecord

__all__ = ["FIT_JSON", "FIT_KEYS", "FIT_VERSION", "FitDocument", "fit_text", "read_fit",
           "write_fit"]

#: The file's name in a result folder.
FIT_JSON = "fit.json"
#: Version of the shape of the document, its ``fit_version`` (none: 1, notes as lines of
#: text only; 2: the warnings as records too).
FIT_VERSION = 2
#: The keys ``evtribo compare`` writes, in its order.
FIT_KEYS: tuple[str, ...] = ("run_id", "software", "fit_version", "fit", "parameters_file",
                             "fixed_parameters", "subjects", "figures", "notes", "warnings",
                             "population", "compare_key", "output_sha256")


@dataclass(frozen=True)
class FitDocument(Mapping[str, Any]):
    """``fit.json`` as read: a read-only mapping of its keys, and typed attributes.

    Attributes
    ----------
    data : dict
        The whole document.
    path : Path or None
        Where it was read from.
    """

    data: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.data)

    def __len__(self) -> int:
        return len(self.data)

    def _typed(self, key: str, kind: type, default: Any) -> Any:
        value = self.data.get(key)
        if value is None:
            return default
        if not isinstance(value, kind):
            raise ResultFolderError(f"key {key!r}: a {type(value).__name__} where evtribo "
                                    f"compare writes a {kind.__name__} (fit.json edited?)",
                                    path=self.path)
        return value

    @property
    def run_id(self) -> str | None:
        """The analysis fitted (None when it had no ``run_id``)."""
        value = self._typed("run_id", str, None)
        return None if value is None else str(value)

    @property
    def fit(self) -> list[str]:
        """The parameters fitted per subject."""
        return [str(n) for n in self._typed("fit", list, [])]

    @property
    def fixed_parameters(self) -> dict[str, Any]:
        """The model's parameters before the fit (SI units)."""
        return dict(self._typed("fixed_parameters", dict, {}))

    @property
    def subjects(self) -> dict[str, Any]:
        """Per subject: its parameters, estimates, quality of fit and intervals."""
        return dict(self._typed("subjects", dict, {}))

    @property
    def figures(self) -> list[dict[str, Any]]:
        """``{"kind", "title", "stem", "subject", "caption", "section", "per"...}`` of each
        figure written."""
        return [dict(f) for f in self._typed("figures", list, []) if isinstance(f, dict)]

    @property
    def version(self) -> int:
        """The shape's version (``fit_version``; 1 where the document has none)."""
        return int(self._typed("fit_version", int, 1))

    @property
    def notes(self) -> list[str]:
        """The texts of what the comparison said (how the intervals were obtained, a missing
        trace): :attr:`warnings`' texts."""
        return [str(n) for n in self._typed("notes", list, [])]

    @property
    def warnings(self) -> list[WarningRecord]:
        """What the comparison said, as records, in the order said (an earlier document's
        notes, its population's and its exclusion rule's lifted:
        :func:`~evtribo.warning.legacy_compare.lift_notes`).

        Raises
        ------
        ResultFolderError
            An item that is not a record (naming it).
        """
        items = self.data.get("warnings")
        if items is None:
            pop = self.population
            return lift_notes([*self.notes, *(pop.get("exclusion_rule") or []),
                               *(pop.get("notes") or [])])
        out = []
        for k, w in enumerate(self._typed("warnings", list, [])):
            try:
                out.append(WarningRecord.from_json(w))
            except ValueError as err:
                raise ResultFolderError(f"key 'warnings', item {k + 1}: {err} (fit.json "
                                        "edited?)", path=self.path) from None
        return out

    @property
    def population(self) -> dict[str, Any]:
        """What compare noted of the population's estimates: ``n_subjects``,
        ``min_subjects``, ``notes`` and ``outliers`` (empty for an older fit)."""
        return dict(self._typed("population", dict, {}))

    def population_checks(self) -> dict[Drive, Checks]:
        """The mixed model's checks of each drive, as fields (an older fit.json's text read
        by :meth:`~evtribo.documents.population_table.Checks.of_text`: failed unless it
        starts ``ok``).

        Returns
        -------
        dict of Drive to Checks
            Empty for a fit without a population.
        """
        found = self.population.get("checks")
        if not isinstance(found, Mapping):
            return {}
        out = {}
        for label, obj in found.items():
            drive = Drive.from_condition(str(label))
            if isinstance(obj, Mapping) and "waveform" in obj:
                drive = Drive.of(obj.get("waveform"), obj.get("frequency_Hz"))
            out[drive] = Checks.from_json(obj)
        return out

    @property
    def software(self) -> dict[str, Any]:
        """Versions of the software that compared."""
        return dict(self._typed("software", dict, {}))

    @property
    def parameters_file(self) -> dict[str, Any] | None:
        """``{"path", "sha256"}`` of the parameter file used, or None."""
        value = self._typed("parameters_file", dict, None)
        return None if value is None else dict(value)

    @property
    def output_sha256(self) -> dict[str, str]:
        """SHA-256 of every file compare wrote, by its path in the result folder."""
        return {str(k): str(v) for k, v in self._typed("output_sha256", dict, {}).items()}


def fit_text(doc: Mapping[str, Any]) -> str:
    """The text of ``fit.json`` holding *doc*.

    Parameters
    ----------
    doc : mapping
        The document (keys as in :data:`FIT_KEYS`).

    Returns
    -------
    str
        Two-space-indented JSON with a final newline; infinite and NaN numbers (an
        infinite resistance, an undetermined interval) as null.
    """
    return json.dumps(_finite(doc), indent=2, allow_nan=False) + "\n"


def _finite(value: Any) -> Any:
    """*value* with every non-finite float replaced by None (JSON has no infinity)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def write_fit(path: str | os.PathLike[str], doc: Mapping[str, Any]) -> Path:
    """Write *doc* to *path*, whole or not at all.

    Parameters
    ----------
    path : path-like
        The file (``<out>/fit.json``, or its place in a staging folder).
    doc : mapping
        The document (see :func:`fit_text`).

    Returns
    -------
    Path
        The file written.
    """
    return atomic_write(path, fit_text(doc))


def read_fit(path: str | os.PathLike[str], *, again: str = "", missing_ok: bool = False,
             follow: bool = True) -> FitDocument:
    """Read ``fit.json``.

    Parameters
    ----------
    path : path-like
        The file.
    again : str
        What mends a damaged file, appended to the message (``"; run ..."``).
    missing_ok : bool
        An absent file is an empty document (no comparison yet), not an error.
    follow : bool
        Follow a symbolic link (False: a link is refused).

    Returns
    -------
    FitDocument

    Raises
    ------
    ResultFolderError
        The file is missing (unless *missing_ok*), cannot be read, is not a regular file,
        not valid JSON, or not a JSON object.
    """
    file = Path(path)
    try:
        doc = json.loads(read_regular(file, ResultFolderError, what="fit.json",
                                      follow=follow).decode("utf-8"))
    except FileNotFoundError as err:
        if missing_ok:
            return FitDocument()
        raise ResultFolderError(f"missing{again}", path=file) from err
    except PermissionError as err:
        raise ResultFolderError(f"cannot read: {err.strerror}", path=file) from None
    except (ValueError, UnicodeDecodeError) as err:
        raise ResultFolderError(f"not valid JSON ({err}){again}", path=file) from err
    if not isinstance(doc, dict):
        raise ResultFolderError(f"not a model fit written by evtribo compare{again}",
                                path=file)
    return FitDocument(doc, file)
