"""No command deletes or changes a file it did not write, ``--force`` or not.

A property over every command that writes (analyze, compare, report, decode, plot, export,
model --figures, init, simulate): a user's files planted where the command writes (at its
outputs' names, at the names of outputs an earlier run of it may have left, and beside
them), each a regular file or a symbolic link to a file elsewhere. Whatever the command
does (it writes, or it refuses with exit 2), every planted file keeps its bytes, every link
its target and the target its bytes; and the command's own outputs are recorded in their
folder's manifest.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.cli import main
from evtribo.report.compare import compare
from evtribo.results.pipeline import analyze_study
from evtribo.store.owned import MANIFEST, read_manifest


@dataclass(frozen=True)
class World:
    """Where a command runs: a copy of the study and of its result folder, and a folder of
    the user's (``work``) for the other outputs."""

    root: Path

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


@dataclass(frozen=True)
class Command:
    """A command: its arguments in a world, the folder it writes into, and the names there a
    user's file may be planted at (its outputs', stale outputs', neighbours')."""

    argv: Callable[[World], list[str]]
    folder: Callable[[World], Path]
    names: tuple[str, ...]


_OUT_NAMES = ("trials.csv", "electrostatic.csv", "summary.json", "fit.csv", "fit.json",
              "models.csv", "figures/electrostatic_force_all.png", "figures/area_increase.png",
              "figures/mine.png", "report.html", "report_files/photo.png",
              "tables/fit.md", "tables/friction.tex", "notes.txt")

COMMANDS: dict[str, Command] = {
    "analyze": Command(lambda w: ["analyze", str(w.study), "--out", str(w.out), "--jobs", "1"],
                       lambda w: w.out, _OUT_NAMES),
    "compare": Command(lambda w: ["compare", str(w.out), "--dpi", "20", "--figure-format",
                                  "png", "--no-trial-checks"], lambda w: w.out, _OUT_NAMES),
    "report": Command(lambda w: ["report", str(w.out), "-o", str(w.work / "report.html"),
                                 "--tables", "md"], lambda w: w.work,
                      ("report.html", "tables/fit.md", "tables/electrostatic_force.md",
                       "tables/friction.tex", "report_files/photo.png",
                       "report_files/fig1.svg", "notes.txt")),
    "report-in-out": Command(lambda w: ["report", str(w.out)], lambda w: w.out, _OUT_NAMES),
    "decode": Command(lambda w: ["decode", str(w.log), "--dbc", str(w.dbc), "-o",
                                 str(w.work / "run-01.csv")], lambda w: w.work,
                      ("run-01.csv", "run-01.parquet", "notes.txt")),
    "decode-mf4": Command(lambda w: ["decode", str(w.log), "--dbc", str(w.dbc), "-o",
                                     str(w.work / "run-01.mf4")], lambda w: w.work,
                          ("run-01.mf4", "run-01.csv", "notes.txt")),
    "plot": Command(lambda w: ["plot", "trial", str(w.study), "P01", "run-01", "-o",
                               str(w.work / "check.png")], lambda w: w.work,
                    ("check.png", "check.svg", "notes.txt")),
    "export": Command(lambda w: ["export", str(w.study), "-o", str(w.work / "forces.mf4")],
                      lambda w: w.work, ("forces.mf4", "notes.txt")),
    "model": Command(lambda w: ["model", "--figures", str(w.work)], lambda w: w.work,
                     ("fig5_friction_time.png", "frequency.svg", "fig7_area_increase.png",
                      "notes.txt")),
    "init": Command(lambda w: ["init", str(w.work), "--dbc", str(w.dbc)], lambda w: w.work,
                    ("study.toml", "rig/default.dbc", "rig/notes.txt", "notes.txt")),
    "simulate": Command(lambda w: ["simulate", "--study", str(w.study), "--subject", "P01",
                                   "--trial", "run-01", "--duration", "1"],
                        lambda w: w.study / "P01",
                        ("run-01.log", "run-01.json", "run-01.log.part", "notes.txt")),
}


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    """A study of one subject (a square and a sine trial) and its analysis with a fit."""
    base = tmp_path_factory.mktemp("users-files")
    study = base / "study"
    for name, wave in (("run-01", "square"), ("run-02", "sine")):
        write_trial(study, name, SubjectParams(name="P01"),
                    TrialConfig(duration_s=3.0, waveform=wave, seed=len(name) + len(wave)))
    analyze_study(study, base / "out", jobs=1, cache_dir=base / "cache")
    compare(base / "out", dpi=20, formats=("png",), trial_checks=False)
    return base


def _world(template: Path, into: Path) -> World:
    shutil.copytree(template / "study", into / "study", symlinks=True)
    shutil.copytree(template / "out", into / "out", symlinks=True)
    (into / "work").mkdir()
    return World(into)


def _plant(world: World, folder: Path, plants: list[tuple[str, bool]]) -> dict[Path, object]:
    """The user's files: each a file of its own bytes, or a link to one outside."""
    victims = world.root / "victims"
    victims.mkdir(exist_ok=True)
    kept: dict[Path, object] = {}
    for i, (rel, link) in enumerate(plants):
        path = folder / rel
        data = f"the user's {rel} ({i})\n".encode()
        if path.is_symlink() or path.exists():
            path.unlink()
        path.parent.mkdir(parents=True, exist_ok=True)
        if link:
            victim = victims / f"{i}-{path.name}"
            victim.write_bytes(data)
            path.symlink_to(victim)
            kept[path] = ("link", os.readlink(path))
            kept[victim] = data
        else:
            path.write_bytes(data)
            kept[path] = data
    return kept


def _check(kept: dict[Path, object]) -> None:
    for path, was in kept.items():
        if isinstance(was, tuple):
            assert path.is_symlink() and os.readlink(path) == was[1], f"{path} changed"
        else:
            assert not path.is_symlink() and path.is_file(), f"{path} deleted"
            assert path.read_bytes() == was, f"{path} changed"


def _run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)


def _written(folder: Path, kept: dict[Path, object]) -> None:
    """What the command wrote into *folder* (new names) its manifest lists."""
    listed = read_manifest(folder)
    for path in folder.rglob("*"):
        rel = path.relative_to(folder).as_posix()
        if path.is_file() and not path.is_symlink() and path not in kept and \
                not any(part.startswith(".") for part in rel.split("/")) and \
                rel not in listed and path.suffix not in (".log", ".json", ".toml", ".dbc"):
            pytest.fail(f"{path} written but not in {folder / MANIFEST}")


@settings(max_examples=int(os.environ.get("EVTRIBO_USERS_FILES_EXAMPLES", "20")),
          deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_no_command_touches_a_users_file(template, tmp_path_factory, data):
    name = data.draw(st.sampled_from(sorted(COMMANDS)), label="command")
    command = COMMANDS[name]
    force = data.draw(st.booleans(), label="force")
    chosen = data.draw(st.lists(st.sampled_from(command.names), unique=True, max_size=4),
                       label="planted")
    plants = [(rel, data.draw(st.booleans(), label=f"{rel} is a link")) for rel in chosen]
    world = _world(template, tmp_path_factory.mktemp(name))
    folder = command.folder(world)
    kept = _plant(world, folder, plants)
    code = _run([*command.argv(world), *(["--force"] if force else [])])
    assert code in (0, 2), (name, code)
    _check(kept)
    if code == 0:
        _written(folder, kept)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "model"
                                  else n for n in sorted(COMMANDS)])  # model: 20 s a run
def test_a_command_run_again_with_force_replaces_its_own_outputs_only(template, tmp_path,
                                                                      name):
    """Each command twice, the second time with --force, a user's file beside its outputs
    and one at a stale output's name: the second run succeeds and leaves them."""
    command = COMMANDS[name]
    world = _world(template, tmp_path)
    folder = command.folder(world)
    argv = command.argv(world)
    if name == "simulate":  # the study's run-01 is a simulated trial: replaced with --force
        argv = [*argv[:-4], "--trial", "run-03", *argv[-2:]]
    assert _run(argv) in (0, 2)
    kept = _plant(world, folder, [("notes.txt", False), ("beside/notes.txt", True)])
    assert _run([*argv, "--force"]) == 0, name
    _check(kept)
    _written(folder, kept)
