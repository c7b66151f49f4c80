"""Files the user may not read (mode 000, another user's) in a study or a result folder:
named, never a traceback; whatever can go on goes on and says what it could not read.
The checks run in a forked process held to the files' modes (:func:`_forked.modes_apply`:
the tests run as root, whom modes do not stop). docs/errors.md's rows (``*-unreadable``)
are the commands' refusals; these are the paths past them."""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path

import pytest

import _forked
from evtribo.cli import main


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {os.fspath(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in root.rglob("*")}


@pytest.fixture(scope="module")
def analysed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two subjects of one trial each, analysed and compared."""
    base = tmp_path_factory.mktemp("unreadable")
    study, out = base / "study", base / "out"
    for subject in ("P01", "P02"):
        assert main(["simulate", "--study", str(study), "--subject", subject, "--trial",
                     "run-01", "--duration", "8"]) == 0
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1"]) == 0
    assert main(["compare", str(out), "--dpi", "40", "--no-trial-checks"]) == 0
    return study, out


@pytest.fixture
def unreadable(analysed):
    """P02's log of mode 000 for the test, its mode restored after."""
    log = analysed[0] / "P02" / "run-01.log"
    log.chmod(0)
    yield log
    log.chmod(0o644)


def _loaded_readable() -> None:
    """As a user; the study's logs taken as readable when it is loaded (the log made
    unreadable after that, while the command runs)."""
    import evtribo.study

    _forked.modes_apply()
    evtribo.study._readable = lambda log_path: None  # type: ignore[attr-defined]


@pytest.mark.parametrize("argv", [["analyze", "STUDY", "--out", "TMP/again", "--jobs", "1"],
                                  ["plot", "trial", "STUDY", "P02", "run-01", "-o",
                                   "TMP/check.png"]])
def test_a_log_made_unreadable_after_the_study_was_loaded_is_named(argv, analysed,
                                                                    unreadable, tmp_path):
    study, _ = analysed
    argv = [a.replace("STUDY", str(study)).replace("TMP", str(tmp_path)) for a in argv]
    before = _tree(study.parent)
    code, said = _forked.run(argv, tmp_path.parent / f"{tmp_path.name}.said",
                             _loaded_readable)
    assert code == 2, said
    assert f"{unreadable}: cannot read: Permission denied" in said
    assert "Traceback" not in said and "failed" not in said
    assert _tree(study.parent) == before
    assert not list(tmp_path.iterdir())


def test_report_says_an_input_it_cannot_read_now_and_is_written(analysed, unreadable,
                                                                tmp_path):
    _, out = analysed
    page = tmp_path / "report.html"
    code, said = _forked.run(["report", str(out), "-o", str(page)],
                             tmp_path.parent / f"{tmp_path.name}.said", _forked.modes_apply)
    assert code == 0, said
    text = re.sub(r"\s+", " ", page.read_text(encoding="utf-8"))
    assert ("P02/run-01.log: cannot read it now (Permission denied): whether it changed "
            "since the analysis is not known") in text


def _check(study: Path) -> tuple[object, list[str]]:
    from evtribo.session.check import check_recorded

    heard: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            heard.append(record.getMessage())

    logging.getLogger("evtribo").addHandler(Keep())
    return check_recorded(study, "P01", "run-01", "alternating"), heard


def test_the_session_s_check_beside_an_unreadable_log_is_not_made_and_says_why(
        analysed, unreadable):
    """A session records P01's trial into a study where P02's log cannot be read: the check
    (an analysis of the study's trial) is not made, said, and the session goes on."""
    how, got = _forked.call(_check, analysed[0], setup=_forked.modes_apply)
    assert how == "returned", got
    result, heard = got
    assert result is None
    assert any(m.startswith("P01/run-01: not checked: the study cannot be read as a whole ("
                            f"{unreadable}: cannot read: Permission denied)") for m in heard)
