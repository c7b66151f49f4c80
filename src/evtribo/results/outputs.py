"""The files of a result folder: which of them ``analyze``, ``compare`` and ``report`` write.

``evtribo analyze --force`` replaces the files of all three commands in OUT, and no others
(a user's notes beside them stay): this module names them, so that an analysis removes the
model fit and the report of the results it replaces. :mod:`evtribo.store.resultdir` writes the
folder as one unit; :func:`check_out_dir` keeps it out of the study.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from evtribo.documents.fit import FIT_JSON
from evtribo.documents.summary import SUMMARY_FILE, write_summary
from evtribo.errors import OutputExistsError, UserInputError
from evtribo.store.resultdir import Staging, inside

__all__ = ["ANALYSIS_FILES", "BOOTSTRAP_FILE", "FIGURES", "FIT_CSV", "FIT_JSON",
           "MODELS_CSV", "OUTPUT_FILES", "POPULATION_CONTRASTS_CSV", "POPULATION_CSV",
           "POPULATION_SUBJECTS_CSV",
           "REPORT_TABLES", "SINE_TRACE_FILE", "SUMMARY_FILE", "TABLES", "check_out_dir",
           "check_overwrite", "compare_files", "report_files", "write_analysis"]

#: The files ``analyze_study`` writes into its output folder.
OUTPUT_FILES = ("trials.csv", "windows.csv", "electrostatic.csv", "exponents.csv",
                SUMMARY_FILE, "electrostatic_bootstrap.csv")
#: The bootstrap replicates of electrostatic.csv (an addition to the study format).
BOOTSTRAP_FILE = "electrostatic_bootstrap.csv"
#: Written too when the study has sine trials: a stretch of each one's forces around a
#: switch from OFF to ON, for the model comparison (columns in evtribo.fit.tables).
SINE_TRACE_FILE = "sine_trace.csv"
#: Every file of analyze's.
ANALYSIS_FILES = (*OUTPUT_FILES, SINE_TRACE_FILE)
#: compare's files, and the folder of its figures.
FIT_CSV, FIGURES = "fit.csv", "figures"
#: compare's comparison of the candidate models (``compare --models``).
MODELS_CSV = "models.csv"
#: compare's estimates of the population (study format §10).
POPULATION_CSV, POPULATION_CONTRASTS_CSV = "population.csv", "population_contrasts.csv"
#: Each subject's relative friction increase and test of F_el > 0 (compare's population).
POPULATION_SUBJECTS_CSV = "population_subjects.csv"
#: The formats of compare's figures.
_FIGURE_FORMATS = ("png", "svg", "pdf")
#: The stems of compare's figures (``electrostatic_force_all.png``,
#: ``electrostatic_force_P01.svg``, ``trial_P01_run-01.pdf``...).
_FIGURE = re.compile(r"^(friction_time|area_increase|electrostatic_force_.+|"
                     r"friction_normal_force_.+|trial_.+|frequency_response_.+|population_.+)"
                     r"\.(png|svg|pdf)$")
#: The folder beside a report of its exported tables (``report --tables md,tex``), and their
#: stems (``tables/electrostatic_force.md``, ``tables/fit.tex``).
TABLES, REPORT_TABLES = "tables", ("electrostatic_force", "fit", "population", "friction")
_TABLE = re.compile(r"^(" + "|".join(REPORT_TABLES) + r")\.(md|tex)$")
#: What the first bytes of a report written by ``evtribo report`` hold.
_REPORT_MARK = b'<meta name="generator" content="evtribo'


def compare_files(out: Path) -> list[str]:
    """compare's files in *out* (relative): fit.csv, fit.json, models.csv, population.csv,
    population_contrasts.csv, and its figures (those fit.json lists, and those named as
    compare names them).

    Parameters
    ----------
    out : Path
        The output folder.

    Returns
    -------
    list of str
        Names relative to *out*.
    """
    found = [name for name in (FIT_CSV, FIT_JSON, MODELS_CSV, POPULATION_CSV,
                               POPULATION_CONTRASTS_CSV, POPULATION_SUBJECTS_CSV)
             if (out / name).is_file()]
    listed: set[str] = set()
    try:
        doc = json.loads((out / FIT_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        doc = {}
    if isinstance(doc, dict):
        listed.update(str(k) for k in (doc.get("output_sha256") or {}))
        for fig in doc.get("figures") or []:
            if isinstance(fig, dict) and isinstance(fig.get("stem"), str):
                listed.update(f"{FIGURES}/{fig['stem']}.{ext}" for ext in _FIGURE_FORMATS)
    if (out / FIGURES).is_dir():
        listed.update(f"{FIGURES}/{p.name}" for p in (out / FIGURES).iterdir()
                      if _FIGURE.match(p.name))
    found += sorted(rel for rel in listed - set(found)
                    if (p := inside(out, rel)) is not None and p.is_file())
    return found


def _is_report(path: Path) -> bool:
    try:
        with path.open("rb") as fh:
            return _REPORT_MARK in fh.read(4096)
    except OSError:
        return False


def report_files(out: Path) -> list[str]:
    """The files of reports ``evtribo report`` wrote into *out* (relative): each HTML page
    that says evtribo generated it, the PNG and SVG figures of its ``<name>_files/``, and
    the exported tables in ``tables/`` beside it.

    Parameters
    ----------
    out : Path
        The output folder.

    Returns
    -------
    list of str
        Names relative to *out*.
    """
    if not out.is_dir():
        return []
    found = []
    for page in sorted(out.glob("*.html")):
        if page.is_file() and _is_report(page):
            found.append(page.name)
            figures = out / f"{page.stem}_files"
            if figures.is_dir():
                found += sorted(f"{figures.name}/{p.name}" for p in figures.iterdir()
                                if p.is_file() and p.suffix.lower() in (".png", ".svg"))
    if found and (out / TABLES).is_dir():
        found += sorted(f"{TABLES}/{p.name}" for p in (out / TABLES).iterdir()
                        if p.is_file() and _TABLE.match(p.name))
    return found


def check_overwrite(out: Path, force: bool) -> None:
    """Refuse (unless *force*) an output folder that holds results of analyze, compare or
    report.

    Parameters
    ----------
    out : Path
        The output folder.
    force : bool
        Replace the results it holds.

    Raises
    ------
    OutputExistsError
        Naming the first such file.
    """
    if force:
        return
    taken = [out / n for n in ANALYSIS_FILES if (out / n).exists()]
    if out.is_dir():
        taken += [out / rel for rel in (*compare_files(out), *report_files(out))]
    if taken:
        raise OutputExistsError("already exists; give --force to overwrite the results",
                                path=taken[0])


def check_out_dir(out: Path, study_root: Path) -> None:
    """Refuse an output folder inside the study (the next analysis would read its tables as
    part of the study) or one that is a file.

    Parameters
    ----------
    out : Path
        The output folder.
    study_root : Path
        The study folder.

    Raises
    ------
    UserInputError
        Naming the output folder and the study.
    """
    study = Path(study_root).resolve()
    where = Path(out).resolve()
    if where == study or study in where.parents:
        raise UserInputError(
            f"the output folder is inside the study folder {study_root}: the next analysis "
            "would read the results as part of the study; choose a folder outside it, e.g. "
            f"{Path(study_root).parent / (study.name + '-results')}", path=out, key="--out")
    if Path(out).exists() and not Path(out).is_dir():
        raise UserInputError("is a file, not a folder for the results", path=out, key="--out")


def write_analysis(out: Path, writers: Mapping[str, Callable[[Path], str]],
                   summary: dict[str, Any], elapsed: float) -> None:
    """analyze's tables and summary.json written into *out* as one unit, replacing analyze's
    files there and compare's and report's of them (call it holding *out*'s lock).

    Parameters
    ----------
    out : Path
        The result folder.
    writers : mapping
        For each table's name, a function that writes it at the path it is given and
        returns the SHA-256 of what it wrote (recorded in ``output_sha256``).
    summary : dict
        summary.json's content; ``output_sha256`` and ``elapsed_s`` are filled in.
    elapsed : float
        Seconds spent before the writing, s.
    """
    started = time.perf_counter()
    stale = [n for n in ANALYSIS_FILES if (out / n).is_file()]
    stale += [*compare_files(out), *report_files(out)] if out.is_dir() else []
    with Staging(out) as stage:
        for name, write in writers.items():
            summary["output_sha256"][name] = write(stage.path(name))
        summary["elapsed_s"] = round(elapsed + time.perf_counter() - started, 3)
        write_summary(stage.path(SUMMARY_FILE), summary)
        stage.commit(remove=stale, last=[SUMMARY_FILE])
