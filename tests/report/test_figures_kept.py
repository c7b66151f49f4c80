"""compare's figures are keyed by what they show: the same figure is the same bytes wherever
and however often it is drawn, a changed setting redraws only the figures it changes, and
with nothing changed no figure is drawn or written again."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from analysed import analysed_study
from evtribo.cli import main
from evtribo.figures.trial_plots import draw_trial_check
from evtribo.report import drawing
from evtribo.report.compare import compare


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """The analysed study's result folder and the cache folder its analysis used."""
    study, out = analysed_study(tmp_path_factory.mktemp("kept"))
    return out, study.parent / "cache"


def _copy(analysed, base: Path, name: str) -> tuple[Path, Path]:
    """A copy of the result folder and of the analysis's cache folder (its sketches)."""
    out, cache = analysed
    return (shutil.copytree(out, base / name / "out"),
            shutil.copytree(cache, base / name / "cache"))


def _figures(out: Path) -> dict[str, tuple[bytes, int, int]]:
    """Each figure file: its bytes, inode and modification time (ns)."""
    return {p.name: (p.read_bytes(), p.stat().st_ino, p.stat().st_mtime_ns)
            for p in sorted((out / "figures").iterdir())}


@pytest.fixture
def rendered(monkeypatch):
    """The drawings rendered in this process (compare with ``jobs=1`` renders here)."""
    calls: list[object] = []
    real = drawing.render

    def counting(job):
        calls.append(job[1])
        return real(job)

    monkeypatch.setattr(drawing, "render", counting)
    return calls


def _drawn_by(calls, func) -> int:
    return sum(isinstance(c, drawing.Drawing) and c.func is func for c in calls)


def test_the_same_figures_are_the_same_bytes_wherever_drawn(analysed, tmp_path):
    a, cache_a = _copy(analysed, tmp_path, "a")
    b, cache_b = _copy(analysed, tmp_path, "b")
    compare(a, dpi=40, jobs=1, cache_dir=cache_a)  # here
    compare(b, dpi=40, jobs=2, cache_dir=cache_b)  # in worker processes
    first, second = _figures(a), _figures(b)
    assert sorted(first) == sorted(second)
    assert [n for n in first if first[n][0] != second[n][0]] == []
    doc = json.loads((a / "fit.json").read_text(encoding="utf-8"))
    assert sum(f["kind"] == "trial" for f in doc["figures"]) == 8  # every trial's check
    assert {f"{f['stem']}.png" for f in doc["figures"]} <= set(first)


def test_a_changed_setting_redraws_only_the_figures_it_changes(analysed, tmp_path, rendered):
    out, cache = _copy(analysed, tmp_path, "c")
    compare(out, dpi=40, jobs=1, cache_dir=cache)
    checks = _drawn_by(rendered, draw_trial_check)
    assert checks == 8  # every trial's
    before = _figures(out)
    rendered.clear()
    result = compare(out, dpi=40, jobs=1, cache_dir=cache, force=True, fit="h_L,mu")
    after = _figures(out)
    assert _drawn_by(rendered, draw_trial_check) == 0  # a trial's check does not show the fit
    trial_files = {n for n in before if n.startswith("trial_")}
    assert len(trial_files) == checks
    for name in trial_files:  # left as they were: not written again
        assert after[name] == before[name], name
    assert {f"figures/{n}" for n in trial_files} <= set(result.kept)
    fitted = [n for n in after if n.startswith("electrostatic_force_P")]
    assert len(fitted) == 4 and all(after[n][0] != before[n][0] for n in fitted)

    rendered.clear()  # the comparison asked before: drawn from the cache folder, not again
    compare(out, dpi=40, jobs=1, cache_dir=cache, force=True)
    assert [c for c in rendered if isinstance(c, drawing.Drawing)] == []
    again = _figures(out)
    assert {n: v[0] for n, v in again.items()} == {n: v[0] for n, v in before.items()}


def test_with_nothing_changed_nothing_is_drawn_or_written(analysed, tmp_path, rendered,
                                                          capsys):
    out, cache = _copy(analysed, tmp_path, "d")
    compare(out, dpi=40, jobs=1, cache_dir=cache)
    before = _figures(out)
    fit_json = (out / "fit.json").read_bytes()
    rendered.clear()
    result = compare(out, dpi=40, jobs=1, cache_dir=cache, force=True)
    assert [c for c in rendered if isinstance(c, drawing.Drawing)] == []
    assert _figures(out) == before  # every file as it was, not written again
    assert sorted(result.kept) == sorted(f"figures/{n}" for n in before)
    capsys.readouterr()
    rendered.clear()
    argv = ["compare", str(out), "--force", "--dpi", "40", "--cache-dir", str(cache)]
    assert main(argv) == 0
    assert "nothing written" in capsys.readouterr().out
    assert rendered == [] and _figures(out) == before
    assert (out / "fit.json").read_bytes() == fit_json
    gone = sorted(before)[0]
    (out / "figures" / gone).unlink()  # a file compare wrote: compared again, it is back
    assert main(argv) == 0
    assert "nothing written" not in capsys.readouterr().out
    assert rendered == [] and {n: v[0] for n, v in _figures(out).items()} == \
        {n: v[0] for n, v in before.items()}  # from the cache folder, not drawn
