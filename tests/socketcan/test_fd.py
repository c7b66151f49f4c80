"""CAN FD end to end: a rig whose load cells send 64-byte FD frames (``tests/data/rigs/
fd.toml``), its trial simulated (on the host), played into a vcan interface whose MTU takes
FD frames, recorded by ``evtribo acquire --interface socketcan`` (``ID##...`` lines, as
``candump -L`` writes them), then decoded with the DBC's FD messages and analysed like the
trace it came from (on the host)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from _socketcan import (
    HANG_S,
    ROOT,
    Candump,
    evtribo,
    frames_of,
    kernel_drops,
    on_host,
    playing,
    stop_when_dumped,
    times_of,
    without_fdf,
)

pytestmark = pytest.mark.slow

RIG = ROOT / "tests" / "data" / "rigs" / "fd.toml"


def _simulate(exports: Path) -> None:
    """On the host: the trace, the FD rig's trial written by the simulator."""
    from evtribo.cli import main

    assert main(["simulate", "--study", str(exports / "trace"), "--rig", str(RIG),
                 "--duration", "12", "--seed", "4", "--amplitude", "140",
                 "--fx-rate", "1000"]) == 0


def _decoded_and_analysed(exports: Path) -> None:
    """On the host: the recorded log decoded with the DBC's FD messages as the trace is,
    and analysed like it."""
    import pandas as pd

    from evtribo.cli import main
    from evtribo.results.pipeline import compute_study

    trace = exports / "trace" / "P01" / "run-01.log"
    recorded = exports / "recorded" / "P01" / "run-01.log"
    tables = {}
    for log in (trace, recorded):
        out = exports / f"{log.parent.parent.name}.csv"
        assert main(["decode", str(log), "--dbc", str(RIG.with_suffix(".dbc")), "-o",
                     str(out)]) == 0
        tables[log] = pd.read_csv(out)
    for column in ("NormalCellFd.Force", "TangentialCellFd.Force", "NormalCellFd.Counter"):
        a, b = tables[trace][column].dropna(), tables[recorded][column].dropna()
        assert len(a) > 5_000 and a.tolist() == b.tolist()

    def fel(study: Path) -> float:
        el = compute_study(study, jobs=1, cache_dir=exports / f"cache-{study.name}")
        assert len(el.electrostatic) == 1, "no F_el: no steady-sliding window found"
        return float(el.electrostatic.electrostatic_force_N.iloc[0])

    assert fel(exports / "recorded") == pytest.approx(fel(exports / "trace"), rel=0.02)


@on_host(before=_simulate, after=_decoded_and_analysed)
def test_a_rig_on_can_fd_is_recorded_decoded_and_analysed(tmp_path, vcan, exports):
    trace = exports / "trace" / "P01" / "run-01.log"
    lines = trace.read_text().splitlines()
    assert sum("##" in line for line in lines) > 10_000  # the cells' 64-byte FD frames

    recorded = exports / "recorded"
    candump = Candump(vcan, tmp_path / "candump.log", count=len(lines))
    before = kernel_drops(vcan)
    proc = evtribo(["acquire", "--study", str(recorded), "--rig", str(RIG), "--subject", "P01",
                    "--trial", "run-01", "--interface", "socketcan", "--channel", vcan,
                    "--log-channel", "vcan0", "--tare-s", "0", "--duration", "600",
                    "--waveform", "square", "--frequency", "10000", "--amplitude", "140",
                    "--condition", "alternating"], tmp_path / "acquire.out",
                   setup=playing(trace, vcan))  # the trace starts as the recording does
    stop_when_dumped(candump, proc)  # Ctrl-C once every frame of the trace is on the bus
    assert proc.wait(HANG_S) == 0, proc.output()
    dumped = candump.stop()
    assert kernel_drops(vcan) == before  # none lost before a socket
    got = (recorded / "P01" / "run-01.log").read_text().splitlines()
    assert frames_of(got) == frames_of(dumped)           # as candump writes them,
    assert times_of(got) == times_of(dumped)             # at the kernel's times
    assert without_fdf(frames_of(got)) == frames_of(lines)   # the trace's frames, in order
    assert all("##4" in line for line in got if "##" in line)  # flagged FD by the kernel
    side = json.loads((recorded / "P01" / "run-01.json").read_text())
    assert side["queue_dropped_frames"] == 0 and side["dropped_frames"] == 0
