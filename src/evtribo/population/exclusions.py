"""Study.toml's ``[population]`` rule: the subjects excluded from the population's estimates
by a rule written beforehand, and the population model of the primary rows.

A paper's primary analysis has every subject; a subject may be left out only by a rule
declared before the data were analysed (a protocol deviation, a recalibrated load cell), not
because its numbers came out far from the others'. The rule is study.toml's::

    [population]
    exclude = [
      {subject = "P03", reason = "load cell recalibrated during the session"},
    ]
    model = "mixed"

``model`` names the population model of the primary rows (:mod:`evtribo.population.models`:
``mixed``, the default, ``meta-analysis``, or a plug-in's), decided, as the exclusions are,
before the analysis.

``evtribo compare`` reads it from the study folder the analysis names (``summary.json``'s
``study_dir``); when study.toml changed since the analysis (its SHA-256 differs from the one
``analyze`` recorded) and holds a ``[population]`` table, the rule cannot be told from one
written after looking at the results, and compare refuses (run the analysis again). The
excluded subjects and their reasons are named in the notes, in fit.json and in the report's
methods; their own results stay in the per-subject tables.
"""

from __future__ import annotations

import logging
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evtribo.documents.names import validate_name
from evtribo.errors import StudyError
from evtribo.fit.tables import ResultTables
from evtribo.population.models import DEFAULT_MODEL, MODELS
from evtribo.store.files import sha256_file
from evtribo.study import STUDY_FILE, read_study_toml
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["POPULATION_KEYS", "PopulationRule", "parse_exclusions", "parse_population",
           "population_rule"]

#: The keys of study.toml's ``[population]`` table.
POPULATION_KEYS = ("exclude", "model")
#: The keys of one exclusion.
_EXCLUSION_KEYS = ("subject", "reason")


def _one(item: Any, i: int, path: Path, subjects: Collection[str]) -> tuple[str, str]:
    key = f"population.exclude[{i}]"
    if not isinstance(item, Mapping):
        raise StudyError(f"expected a table {{subject = \"P03\", reason = \"...\"}}, got "
                         f"{item!r}", path=path, key=key)
    unknown = sorted(set(item) - set(_EXCLUSION_KEYS))
    if unknown:
        raise StudyError(f"unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
                         f"{', '.join(_EXCLUSION_KEYS)}", path=path, key=key)
    for name in _EXCLUSION_KEYS:
        value = item.get(name)
        if not isinstance(value, str) or not value.strip():
            what = "missing" if value is None else f"got {value!r}"
            raise StudyError(f"{what}: each exclusion needs its {name} as text"
                             + (" (why, decided before the analysis)" if name == "reason"
                                else ""), path=path, key=f"{key}.{name}")
    subject = str(item["subject"])
    validate_name(subject, what="subject", path=path, key=f"{key}.subject")
    if subjects and subject not in subjects:
        known = ", ".join(sorted(subjects)[:12])
        raise StudyError(f"{subject!r} is not a subject of these results ({known})",
                         path=path, key=f"{key}.subject")
    return subject, str(item["reason"]).strip()


def parse_exclusions(table: Any, path: Path, subjects: Collection[str] = ()
                     ) -> dict[str, str]:
    """study.toml's ``[population]`` table, checked: the excluded subjects and why.

    Parameters
    ----------
    table : object
        The table as read (None when study.toml has none).
    path : Path
        The study.toml (for messages).
    subjects : collection of str
        The subjects of the results (an exclusion must name one); empty: not checked.

    Returns
    -------
    dict of str to str
        Subject to reason, in the order given.

    Raises
    ------
    StudyError
        A key that is not known, an exclusion without its subject or reason, a subject
        that is not in the results or is given twice (exit code 2).
    """
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise StudyError(f"expected a table, got {table!r}", path=path, key="population")
    unknown = sorted(set(table) - set(POPULATION_KEYS))
    if unknown:
        raise StudyError(f"unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
                         f"{', '.join(POPULATION_KEYS)}", path=path,
                         key=f"population.{unknown[0]}")
    items = table.get("exclude", [])
    if not isinstance(items, list):
        raise StudyError(f"expected a list of tables {{subject = \"P03\", reason = "
                         f"\"...\"}}, got {items!r}", path=path, key="population.exclude")
    out: dict[str, str] = {}
    for i, item in enumerate(items):
        subject, reason = _one(item, i, path, subjects)
        if subject in out:
            raise StudyError(f"{subject!r} is excluded twice", path=path,
                             key=f"population.exclude[{i}].subject")
        out[subject] = reason
    return out


@dataclass(frozen=True)
class PopulationRule:
    """What study.toml's ``[population]`` table says, and what was said of it.

    Attributes
    ----------
    exclude : dict of str to str
        The subjects excluded beforehand, with the reason, in the order given.
    notes : list of WarningRecord
        What was said of the rule (its study.toml not read): made, not said (compare
        says them with the population's).
    model : str
        The population model of the primary rows (``mixed`` when it names none).
    """

    exclude: dict[str, str] = field(default_factory=dict)
    notes: list[WarningRecord] = field(default_factory=list)
    model: str = DEFAULT_MODEL


def parse_population(table: Any, path: Path, subjects: Collection[str] = ()
                     ) -> PopulationRule:
    """study.toml's ``[population]`` table, checked: the exclusions and the model.

    Parameters
    ----------
    table : object
        The table as read (None when study.toml has none).
    path : Path
        The study.toml (for messages).
    subjects : collection of str
        The subjects of the results (an exclusion must name one); empty: not checked.

    Returns
    -------
    PopulationRule

    Raises
    ------
    StudyError
        As :func:`parse_exclusions`; a model that is not one of
        :data:`~evtribo.population.models.MODELS` (exit code 2).
    """
    exclude = parse_exclusions(table, path, subjects)
    model = DEFAULT_MODEL if table is None else table.get("model", DEFAULT_MODEL)
    if not isinstance(model, str) or model not in MODELS:
        raise StudyError(f"{model!r} is not allowed: choose one of {', '.join(MODELS)}",
                         path=path, key="population.model")
    return PopulationRule(exclude, [], model)


def population_rule(tables: ResultTables) -> PopulationRule:
    """The ``[population]`` rule of the study the results are of, and notes for the user.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (``summary.json`` names the study folder and the hash
        of its study.toml).

    Returns
    -------
    PopulationRule
        No exclusion and the default model, with a note, when the study folder is not
        found (no rule read).

    Raises
    ------
    StudyError
        A bad ``[population]`` table, or one in a study.toml changed since the analysis
        (exit code 2).
    """
    study_dir = tables.summary.study_dir
    path = Path(study_dir) / STUDY_FILE if study_dir else None
    if path is None or not path.is_file():
        return PopulationRule(notes=[emit.record("population-rule-unread",
                                                 study_dir=study_dir or "(not recorded)")])
    config = read_study_toml(path)
    if "population" not in config:
        return PopulationRule()
    recorded = [r.sha256 for r in tables.summary.inputs if r.role == "study"]
    if recorded and sha256_file(path) != recorded[0]:
        raise StudyError("changed since the analysis (its SHA-256 differs from the one in "
                         "summary.json), and it has a [population] rule: an exclusion counts "
                         "only when written before the analysis; run `evtribo analyze` "
                         "again", path=path, key="population")
    subjects = {str(s) for s in tables.all_subjects}
    return parse_population(config["population"], path, subjects)
