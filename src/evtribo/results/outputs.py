"""The files of a result folder: which of them ``analyze``, ``compare`` and ``report`` write.

``evtribo analyze --force`` replaces the files of all three commands in OUT, and no others
(a user's notes beside them stay): this module names them, so that an analysis removes the
model fit and the report of the results it replaces. Of the files named, only those OUT's
manifest shows evtribo wrote, with the bytes they have now, are ever replaced or removed
(:mod:`evtribo.store.owned`); a file of such a name that a user put there, or edited, is
left, and a command that would write over it is refused. :mod:`evtribo.store.resultdir`
writes the folder as one unit; :func:`check_out_dir` keeps it out of the study.
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from evtribo.documents.fit import FIT_JSON, read_fit
from evtribo.documents.summary import SUMMARY_FILE, read_summary, write_summary
from evtribo.documents.tables import (
    ANALYSIS_FILES,
    BOOTSTRAP_FILE,
    COMPARE_TABLES,
    FIT_CSV,
    MODELS_CSV,
    OUTPUT_FILES,
    POPULATION_CONTRASTS_CSV,
    POPULATION_CSV,
    POPULATION_SUBJECTS_CSV,
    SINE_TRACE_FILE,
)
from evtribo.errors import OutputExistsError, ResultFolderError, UserInputError
from evtribo.store.names import check_new_path, companion
from evtribo.store.owned import (
    MANIFEST,
    Entry,
    check_writable,
    file_sha256,
    output_name,
    plain_path,
    read_manifest,
    refuse_foreign,
)
from evtribo.store.resultdir import Staging, inside

__all__ = ["ANALYSIS_FILES", "BOOTSTRAP_FILE", "COMPARE_TABLES", "FIGURES", "FIT_CSV", "FIT_JSON",
           "MODELS_CSV", "OUTPUT_FILES", "POPULATION_CONTRASTS_CSV", "POPULATION_CSV",
           "POPULATION_SUBJECTS_CSV", "REPORT_TABLES", "SINE_TRACE_FILE", "SUMMARY_FILE", "TABLES",
           "WRITERS", "check_compare", "check_out_dir", "check_overwrite", "compare_files",
           "earlier_results", "report_files", "write_analysis"]

#: The folder of compare's figures. (The result tables' file names are
#: :mod:`evtribo.documents.tables`'.)
FIGURES = "figures"
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
#: The commands that write into a result folder (as its manifest names them): analyze
#: replaces the files of all three.
WRITERS = ("analyze", "compare", "report")
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
    found = [name for name in COMPARE_TABLES if (out / name).is_file()]
    listed: set[str] = set()
    try:
        doc = read_fit(out / FIT_JSON, missing_ok=True)
        listed.update(doc.output_sha256)
        figures = doc.figures
    except (OSError, ResultFolderError):
        figures = []
    for fig in figures:
        if isinstance(fig.get("stem"), str):
            listed.update(f"{FIGURES}/{fig['stem']}.{ext}" for ext in _FIGURE_FORMATS)
    if (out / FIGURES).is_dir():
        listed.update(f"{FIGURES}/{p.name}" for p in (out / FIGURES).iterdir()
                      if _FIGURE.match(p.name))
    listed.update(rel for rel, e in read_manifest(out).items() if e.by == "compare")
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
            figures = out / companion(page.stem, "_files")
            if figures.is_dir():
                found += sorted(f"{figures.name}/{p.name}" for p in figures.iterdir()
                                if p.is_file() and p.suffix.lower() in (".png", ".svg"))
    if found and (out / TABLES).is_dir():
        found += sorted(f"{TABLES}/{p.name}" for p in (out / TABLES).iterdir()
                        if p.is_file() and _TABLE.match(p.name))
    found += sorted(rel for rel, e in read_manifest(out).items()
                    if e.by == "report" and rel not in found and (out / rel).is_file())
    return found


def _compare_name(rel: str) -> bool:
    folder, _, name = rel.rpartition("/")
    return rel in COMPARE_TABLES or (folder == FIGURES and _FIGURE.match(name) is not None)


def _vouched(out: Path, document: str, by: str,
             names: Callable[[str], bool]) -> dict[str, Entry]:
    """The files of the command's own *names* that a document evtribo wrote lists with
    their SHA-256 (``output_sha256``) and that still have those bytes, and the document
    itself when all of them do."""
    try:
        doc = (read_fit(out / document, follow=False) if document == FIT_JSON
               else read_summary(out / document, follow=False))
        listed = dict(doc.output_sha256 or {})
    except (OSError, UserInputError):
        return {}
    found = {rel: Entry(digest, by) for rel, digest in listed.items()
             if isinstance(rel, str) and output_name(rel) and names(rel)
             and isinstance(digest, str)
             and (p := plain_path(out, rel)) is not None and file_sha256(p) == digest}
    if found and len(found) == len(listed):
        digest_doc = file_sha256(out / document)
        if digest_doc is not None:
            found[document] = Entry(digest_doc, by)
    return found


def earlier_results(out: Path) -> dict[str, Entry]:
    """In a result folder an older evtribo wrote (no manifest yet), the files it can be
    shown to have written: those of analyze's names that summary.json lists, and those of
    compare's names that fit.json lists, with the SHA-256 they still have, and each of the
    two documents when every file it lists is so (a name of neither is never adopted).
    ``analyze --force`` and ``compare --force`` replace these as their own.

    Parameters
    ----------
    out : Path
        The result folder.

    Returns
    -------
    dict of str to Entry
        Empty when the folder has a manifest (it says what is evtribo's).
    """
    if not out.is_dir() or os.path.lexists(out / MANIFEST):
        return {}
    return {**_vouched(out, SUMMARY_FILE, "analyze", ANALYSIS_FILES.__contains__),
            **_vouched(out, FIT_JSON, "compare", _compare_name)}


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
    UserInputError
        A name evtribo does not write (:func:`~evtribo.store.names.check_new_path`).
    OutputExistsError
        Naming the first such file; or, *force* or not, a file of analyze's names that
        evtribo did not write (:func:`~evtribo.store.owned.refuse_foreign`).
    """
    check_new_path(out, key="--out", folder=True)  # first: a name evtribo writes
    if out.is_dir():
        refuse_foreign(out, ANALYSIS_FILES, WRITERS, key="--out", also=earlier_results(out))
    if force:  # the stale files it removes: in folders it can write (before the analysis)
        check_writable(out, [*compare_files(out), *report_files(out)] if out.is_dir() else [])
        return
    taken = [out / n for n in ANALYSIS_FILES if os.path.lexists(out / n)]
    if out.is_dir():
        taken += [out / rel for rel in (*compare_files(out), *report_files(out))]
    if taken:
        raise OutputExistsError("already exists; give --force to overwrite the results",
                                path=taken[0])


def check_compare(out: Path, force: bool, figures: Iterable[str] = ()) -> list[str]:
    """Refuse what compare may not write over in *out*; its earlier files.

    Parameters
    ----------
    out : Path
        The result folder.
    force : bool
        Replace an earlier comparison.
    figures : iterable of str
        The figures compare will write (relative names), as far as known.

    Returns
    -------
    list of str
        compare's earlier files in *out* (:func:`compare_files`).

    Raises
    ------
    OutputExistsError
        A file of compare's names that evtribo did not write (*force* or not), or an
        earlier comparison without *force*.
    """
    refuse_foreign(out, [*COMPARE_TABLES, *figures], {"compare"}, also=earlier_results(out))
    existing = compare_files(out)
    if existing and not force:
        raise OutputExistsError(f"{len(existing)} output file(s) of a previous comparison "
                                "exist; use {force} to overwrite them", path=out / existing[0])
    return existing


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
    inside = [study, Path(os.path.abspath(study_root))]
    spelt = [Path(out).resolve(), Path(os.path.abspath(out))]  # a linked subject: the study's
    if any(w == s or s in w.parents for w in spelt for s in inside):
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
    with Staging(out, by="analyze", replaces=WRITERS, also=earlier_results(out)) as stage:
        for name, write in writers.items():
            summary["output_sha256"][name] = write(stage.path(name))
        summary["elapsed_s"] = round(elapsed + time.perf_counter() - started, 3)
        write_summary(stage.path(SUMMARY_FILE), summary)
        stage.commit(remove=stale, last=[SUMMARY_FILE])
