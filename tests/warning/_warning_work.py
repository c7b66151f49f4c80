"""Work a worker process does in the tests of evtribo.warning.collect: it says warnings."""

from __future__ import annotations

from evtribo.warning.collect import emitter

emit = emitter("evtribo.analysis.trial")


def analyse(trial: str, windows: int) -> str:
    """Say one warning per window short of five; fail on a trial of none."""
    for k in range(5 - windows):
        emit("offset", cell="normal", offset_mN=-k - 0.5, share_pct=11 + k, force_N=0.3)
    if windows == 0:
        raise RuntimeError(f"{trial}: no window")
    return trial
