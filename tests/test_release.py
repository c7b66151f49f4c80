"""The release: `python -m build` makes an sdist and a wheel that `twine check` accepts, and
the wheel, installed into a fresh environment, runs `evtribo demo` and `evtribo analyze` on
its own (the default rig, the report's template and the data files inside it).

Offline: the sdist and the wheel are built without an isolated build environment (the build
system's requirements, setuptools and wheel, are in the test extra), and the fresh
environment gets the dependencies the test environment already has, never from an index:
its site-packages points at a folder of links to this environment's packages, evtribo's own
left out, and pip installs the wheel with ``--no-index``, so a dependency the wheel declares
that is not satisfied here fails the install instead of being downloaded.
"""

from __future__ import annotations

import email.parser
import fcntl
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

import pytest

import evtribo
from evtribo.citation import PAPER, SOFTWARE, text

ROOT = Path(__file__).parents[1]
STUDY = ROOT / "data" / "reference-study"
VERSION = evtribo.__version__

pytestmark = pytest.mark.slow


def _run(args: list[str | Path], **kwargs) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run([str(a) for a in args], capture_output=True, text=True,
                          check=False, **kwargs)
    assert proc.returncode == 0, f"{args}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    """``python -m build`` of this tree: the sdist, then the wheel built from the sdist.

    Built once for the whole run, whichever worker asks first: the build writes ``build/``
    and the egg-info in the tree, which two builds at once would share (the others wait on
    a lock file beside the workers' temporary folders, then use what it built)."""
    base = tmp_path_factory.getbasetemp()  # a worker's is inside this run's folder
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    out = shared / "release-dist"
    with open(shared / "release-dist.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (shared / "release-dist.built").is_file():
            shutil.rmtree(out, ignore_errors=True)
            out.mkdir()
            _run([sys.executable, "-m", "build", "--no-isolation", "--outdir", out, ROOT],
                 cwd=ROOT)
            (shared / "release-dist.built").touch()
    return out


def _environment(home: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PIP_INDEX_URL",
                        "PIP_EXTRA_INDEX_URL", "PIP_FIND_LINKS")}
    env.update(HOME=str(home), MPLBACKEND="Agg", EVTRIBO_CACHE_DIR=str(home / "cache"),
               PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PIP_NO_CACHE_DIR="1")
    return env


@pytest.fixture(scope="module")
def installed(dist, tmp_path_factory) -> tuple[Path, dict[str, str]]:
    """A fresh virtual environment with the wheel installed: its bin folder and the
    environment to run it in."""
    root = tmp_path_factory.mktemp("fresh")
    venv = root / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv])
    site = Path(_run([venv / "bin" / "python", "-c",
                      "import sysconfig; print(sysconfig.get_paths()['purelib'])"]
                     ).stdout.strip())
    # this environment's packages, but for evtribo (its metadata and the editable finder)
    deps = root / "deps"
    deps.mkdir()
    ours = Path(sysconfig.get_paths()["purelib"])
    for entry in ours.iterdir():
        if "evtribo" not in entry.name.lower() and entry.suffix != ".pth":
            (deps / entry.name).symlink_to(entry)
    (site / "test-environment-packages.pth").write_text(f"{deps}\n", encoding="utf-8")
    env = _environment(root)
    (wheel,) = dist.glob("*.whl")
    _run([venv / "bin" / "python", "-m", "pip", "install", "--no-index", wheel], env=env,
         cwd=root)
    return venv / "bin", env


def test_build_makes_an_sdist_and_a_wheel_twine_accepts(dist):
    assert sorted(p.name for p in dist.iterdir()) == [
        f"evtribo-{VERSION}-py3-none-any.whl", f"evtribo-{VERSION}.tar.gz"]
    checked = _run([Path(sys.executable).parent / "twine", "check", "--strict",
                    *sorted(dist.iterdir())]).stdout
    assert checked.count("PASSED") == 2, checked


def test_the_wheel_holds_the_data_the_licence_and_the_metadata(dist):
    (wheel,) = dist.glob("*.whl")
    with zipfile.ZipFile(wheel) as whl:
        names = set(whl.namelist())
        info = f"evtribo-{VERSION}.dist-info"
        metadata = email.parser.Parser().parsestr(
            whl.read(f"{info}/METADATA").decode("utf-8"))
        licence = whl.read(f"{info}/licenses/LICENSE")
    for name in ("evtribo/data/rigs/default.dbc", "evtribo/data/rigs/default.toml",
                 "evtribo/data/liveview.html", "evtribo/report/templates/report.html.j2",
                 "evtribo/py.typed", "evtribo/citation.py",
                 "evtribo/data/protocols/meyer2013.toml",
                 "evtribo/data/protocols/frequency-sweep.toml"):
        assert name in names
    assert not [n for n in names if n.startswith(("tests/", "docs/", "data/"))]
    assert metadata["Version"] == VERSION
    assert metadata["License-Expression"] == "BSD-3-Clause"
    assert metadata["License-File"] == "LICENSE"
    assert licence == (ROOT / "LICENSE").read_bytes()
    with tarfile.open(dist / f"evtribo-{VERSION}.tar.gz") as sdist:
        inside = {Path(n).relative_to(f"evtribo-{VERSION}").as_posix()
                  for n in sdist.getnames() if n != f"evtribo-{VERSION}"}
    for name in ("LICENSE", "CITATION.cff", "CHANGELOG.md", "README.md", "pyproject.toml",
                 "src/evtribo/data/rigs/default.dbc",
                 # the examples the README's commands name, at the paths it gives
                 "acquisition/protocols/meyer2013.toml",
                 "acquisition/protocols/frequency-sweep.toml",
                 "acquisition/rigs/default.toml", "acquisition/rigs/default.dbc",
                 "src/evtribo/data/protocols/meyer2013.toml"):
        assert name in inside


def test_the_installed_wheel_is_evtribo_on_its_own(installed):
    bin_dir, env = installed
    where = _run([bin_dir / "python", "-c", "import evtribo; print(evtribo.__file__)"],
                 env=env, cwd=bin_dir).stdout.strip()
    assert Path(where).is_relative_to(bin_dir.parent)  # the wheel's, not this tree's
    assert _run([bin_dir / "evtribo", "--version"], env=env).stdout == f"evtribo {VERSION}\n"
    cite = _run([bin_dir / "evtribo", "cite"], env=env).stdout
    assert text(SOFTWARE) in cite and text(PAPER) in cite
    # python-can finds the bulk slcan interface through the wheel's entry point
    interfaces = _run([bin_dir / "python", "-c",
                       "from importlib.metadata import entry_points as e; "
                       "print([p.value for p in e(group='can.interface')])"], env=env).stdout
    assert "evtribo.acquisition.buses.slcan:BulkSlcanBus" in interfaces


def test_the_installed_wheel_runs_the_demo(installed, tmp_path):
    bin_dir, env = installed
    _run([bin_dir / "evtribo", "demo", "--out", tmp_path / "demo", "--subjects", "1",
          "--trial-duration", "8", "--jobs", "1"], env=env, cwd=tmp_path)
    demo = tmp_path / "demo"
    # the default rig, copied into the study from inside the wheel
    assert (demo / "study" / "rig" / "default.dbc").read_bytes() == \
        (ROOT / "src" / "evtribo" / "data" / "rigs" / "default.dbc").read_bytes()
    for name in ("trials.csv", "electrostatic.csv", "fit.csv", "summary.json"):
        assert (demo / "results" / name).stat().st_size > 0
    report = (demo / "report.html").read_text(encoding="utf-8")
    assert "Provenance and settings" in report and f"(version {VERSION})" in report


def test_the_installed_wheel_analyses_as_this_tree_does(installed, tmp_path):
    """``evtribo analyze`` of the recorded study from the wheel gives this tree's tables,
    byte for byte (each run with a cold cache of its own)."""
    bin_dir, env = installed
    study = tmp_path / "study"
    shutil.copytree(STUDY, study)
    _run([bin_dir / "evtribo", "analyze", study, "--out", tmp_path / "wheel", "--jobs", "1"],
         env=env, cwd=tmp_path)
    here = dict(env, EVTRIBO_CACHE_DIR=str(tmp_path / "cache-here"))
    _run([sys.executable, "-m", "evtribo", "analyze", study, "--out", tmp_path / "tree",
          "--jobs", "1"], env=here, cwd=tmp_path)
    tables = sorted(p.name for p in (tmp_path / "tree").glob("*.csv"))
    assert "electrostatic.csv" in tables and "trials.csv" in tables
    for name in tables:
        assert (tmp_path / "wheel" / name).read_bytes() == \
            (tmp_path / "tree" / name).read_bytes(), name
