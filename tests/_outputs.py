"""A study, its analysis and its fit, copied for each run of a command that writes: the
worlds of the tests of what evtribo writes where (``test_output_names``,
``test_output_folders``)."""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.cli import main
from evtribo.report.compare import compare
from evtribo.results.pipeline import analyze_study
from evtribo.store.owned import MANIFEST


@dataclass(frozen=True)
class World:
    """A copy of the study and its result folder, the user's folder ``work`` and the
    template's cache of decoded trials."""

    root: Path
    cache: Path

    @property
    def study(self) -> Path:
        return self.root / "study"

    @property
    def out(self) -> Path:
        return self.root / "out"

    @property
    def work(self) -> Path:
        return self.root / "work"

    @property
    def log(self) -> Path:
        return self.study / "P01" / "run-01.log"

    @property
    def dbc(self) -> Path:
        return self.study / "rig" / "default.dbc"


def make_template(base: Path) -> Path:
    """A study of one subject (a square and a sine trial), its analysis and its fit."""
    study = base / "study"
    for name, wave in (("run-01", "square"), ("run-02", "sine")):
        write_trial(study, name, SubjectParams(name="P01"),
                    TrialConfig(duration_s=3.0, waveform=wave, seed=len(name) + len(wave)))
    analyze_study(study, base / "out", jobs=1, cache_dir=base / "cache")
    compare(base / "out", dpi=20, formats=("png",), trial_checks=False)
    return base


def world(template: Path, into: Path) -> World:
    """A copy of *template* in *into*."""
    shutil.copytree(template / "study", into / "study", symlinks=True)
    shutil.copytree(template / "out", into / "out", symlinks=True)
    (into / "work").mkdir()
    return World(into, template / "cache")


def tree(root: Path) -> dict[bytes, tuple[int, int, int]]:
    """Every name under *root* (as bytes), with its kind, size and modification time."""
    found = {}
    for folder, dirs, files in os.walk(os.fsencode(root)):
        for name in (*dirs, *files):
            st = os.lstat(os.path.join(folder, name))
            found[os.path.join(folder, name)] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return found


def run(argv: list[str]) -> int:
    """``evtribo *argv`` in this process; its exit code."""
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's own usage errors
        return int(exc.code or 0)


def working_files(folder: Path) -> list[str]:
    """evtribo's working files left in *folder* (a lock, a new folder, a temporary file)."""
    return [n for n in os.listdir(folder) if n.startswith(".") and ".evtribo-" in n
            and n != MANIFEST]
