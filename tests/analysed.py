"""A result folder as ``evtribo analyze`` really writes it, of a simulated study with the
faults a report must show: a trial with dropped frames, one with a damaged log line, and a
sidecar note.

- ``P02/run-02``: three frames of the normal cell removed from its log (3 dropped frames);
- ``P01/run-03``: a damaged line inserted into its log (1 line skipped, and summary.json's
  warning "...: skipped damaged line: ...");
- ``P01/run-01``'s sidecar notes: *note*.
"""

from __future__ import annotations

import json
from pathlib import Path

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.results.pipeline import analyze_study

GAPS = {"P01": 3e-6, "P02": 8e-6}


def _drop_frames(log: Path, frame_id: str, n: int, *, after: int = 1000) -> None:
    """Remove *n* consecutive frames of *frame_id* from a candump log."""
    lines = log.read_text(encoding="ascii").splitlines(keepends=True)
    ours = [i for i, line in enumerate(lines) if f" {frame_id}#" in line]
    gone = set(ours[after:after + n])
    log.write_text("".join(line for i, line in enumerate(lines) if i not in gone),
                   encoding="ascii")


def _damage_line(log: Path, *, at: int = 100) -> None:
    """Insert a line whose payload is not hexadecimal."""
    lines = log.read_text(encoding="ascii").splitlines(keepends=True)
    lines.insert(at, "(1763700000.100000) vcan0 0C1#ZZ\n")
    log.write_text("".join(lines), encoding="ascii")


def set_notes(sidecar: Path, notes: str) -> None:
    """Write *notes* into a trial's sidecar."""
    doc = json.loads(sidecar.read_text(encoding="utf-8"))
    doc["notes"] = notes
    sidecar.write_text(json.dumps(doc, indent=2), encoding="utf-8")


def analysed_study(base: Path, *, note: str = "") -> tuple[Path, Path]:
    """Simulate, damage and analyse a two-subject study under *base*.

    Returns
    -------
    (study, out)
        The study folder and the result folder ``analyze_study`` wrote.
    """
    study, out = base / "study", base / "out"
    simulate_study(study, [SubjectParams(name=s, h_L=h) for s, h in GAPS.items()],
                   amplitudes=(80.0, 120.0, 160.0), config=TrialConfig(duration_s=6.0))
    _drop_frames(study / "P02" / "run-02.log", "0C1", 3)
    _damage_line(study / "P01" / "run-03.log")
    if note:
        set_notes(study / "P01" / "run-01.json", note)
    # a cold cache of its own: a decode read from the cache does not carry the reader's
    # line warnings into summary.json (see the report of this change)
    analyze_study(study, out, jobs=1, cache_dir=base / "cache")
    return study, out
