"""Example values for the catalogue's wordings, and each kind's text said where its scope
says (the tests of evtribo.warning share them)."""

from __future__ import annotations

import string
from typing import Any

from evtribo.warning.kind import Kind
from evtribo.warning.record import Scope

#: A value for each field name the builtin wordings use, as the analysis says it.
FIELDS: dict[str, Any] = {
    "part": "study/P01/run-03.log.part", "complete": "run-03.log",
    "stage": "study/P01/.run-03.evtribo-new-1a2b", "trial": "run-03",
    "path": "study/P01/run-03.json.old", "sidecar": "study/P01/run-03.json",
    "key": "amplitud_V", "suggestion": " (did you mean 'amplitude_V'?)",
    "log": "study/P01/run-03.log", "ended": "interrupted (Ctrl-C or SIGTERM)",
    "after": " after 3.2 s of the 10 s asked", "besides": " (run-03.txt: not a log format)",
    "folder": "study/P04", "target": "/data/elsewhere/P04", "subject": "P04",
    "file": "P01/run-03.log", "then": "0123456789ab", "now": "ba9876543210",
    "study_dir": "study", "files": 2, "error": "no samples", "sha256": "0123456789ab",
    "where": "study/P01/run-03.log:12", "reason": "bad data bytes 'zz'", "lines": 3,
    "listed": 100, "deltas": 4096, "unit": "µs", "lost": 2, "cache": "/tmp/cache",
    "dbc": "rig.dbc", "why": "it stays at 5", "frames": 12, "message": "FzCell",
    "frame_id": 0x1A0, "length": 8, "first": 17, "id_seen": "extended (29-bit) ID 0x1A0",
    "id_declared": "standard (11-bit) ID 0x1A0", "kind_seen": "CAN FD",
    "kind_declared": "classic CAN", "id_text": "standard (11-bit) ID 0x1A0",
    "counts": "from 0 to 99", "shared": ", FzCell on more than one", "channel": "can0",
    "chosen": " (the channel carrying most of them)", "counter": "FzCell.FzCounter",
    "signal": "Excitation.Waveform", "codes": "0 sine, 1 square", "share": 0.42,
    "range": "[0, 50] N", "samples": 7, "at_s": 4.25, "value": 1e9, "direction": "back",
    "step_s": 0.018, "old": 17, "new": 45, "period": 100, "width": "from 0 to 255",
    "bits": 8, "rate_Hz": 5000.0, "cell": "normal", "counted": 55848, "span_s": 12.0,
    "held": 12, "bursts": "frames received in bursts, ", "coherence": 0.55,
    "jumped": "jumped back", "jump_s": 1.0,
    "how": "counted by the counter alone (whole counter periods lost there cannot be seen)",
    "pauses": "1.2 s at 3.400 s", "more": 4, "normal_crossings": 3.1,
    "normal_positive_pct": 52.0, "tangential_crossings": 0.1,
    "tangential_positive_pct": 99.0, "sidecar_value": 80.0, "signals": 100.0,
    "tare_s": 2.0, "left": 3, "on": 9, "way": "forwards", "change_pct": 2.1,
    "normal_N": 0.48, "offset_mN": -44.9, "share_pct": 18.0, "force_N": 0.254,
    "drift_mN": -7.3, "first_s": 0.8, "last_s": 13.9, "noise_mN": 0.29,
    "frequency_Hz": 10.0, "gap_s": 86400.0, "pieces": 2, "start_s": 12.5, "end_s": 20.0,
    "windows": 40, "off": 4, "min_windows": 5, "found": "m = 0.93 [0.51, 1.36]",
    "sensitivity": 0.75, "changed": 3, "trials": 5, "worst": "run-04", "same": 3,
    "on_trials": "run-05", "slower": "; the ON strokes were 12 % slower than the OFF ones",
    "scatter_pct": 8.0, "widening": 2.4, "trial_s": 60.0, "phase_s": 5.0, "mu": 1.62,
    "mu_low": 0.1, "mu_high": 1.5, "amplitudes": "60 V, 80 V", "cells": 40,
    "alpha_pct": 5.0, "share_se_pct": 0.4, "matrix_b": -0.0123, "same_log":
    "study/P01/run-02.log", "differ": "", "parameter": "h_L", "second": "r_g",
    "r": 0.998, "points": 2, "low_mN": -12.3, "high_mN": 48.1, "parameters": "h_L",
    "sigma_N": 0.0123, "model": "hertz", "text": "something said",
}
# fields whose name two wordings use for different things
FIELDS_OF: dict[str, dict[str, Any]] = {
    "sidecar-signals": {"key": "amplitude_V", "sidecar": 80.0},
    "frames-lost-periods": {"frames": 310},
    "counter-idle": {"why": "its values do not step from frame to frame"},
    "frames-lost-clock": {"counted": "cannot be counted"},
    "no-force": {"error": "its windows have no amplitude"},
    "drift-followed": {"direction": "rising"},
    "drift-unseen": {"direction": "falling"},
    "long-phases": {"trials": "run-01, run-02"},
    "parameters-correlated": {"first": "h_L"},
    "dbc-lenient": {"why": "invalid syntax at line 3 (the line is not shown: open the file)"},
    "channels-several": {"counts": "can0: 1200 frames, can1: 35 frames"},
    "candump-deltas": {"lost": ""},
    "refits-failed": {"converged": 12, "refits": 200},
}

#: Where each level of kind is said in the examples.
SCOPES = {"study": Scope(), "subject": Scope("P01"), "drive": Scope("P01", None, "square", 1e4),
          "cell": Scope("P01", None, "square", 1e4, 60.0), "trial": Scope("P01", "run-03")}
SUBJECTS = ("P01", "P02", "P03")
TRIALS = tuple((s, f"run-{k:02d}") for s in SUBJECTS for k in range(1, 6))


def _by_spec(spec: str) -> Any:
    if spec in ("plural",) or spec.endswith(("d", "X", "x")):
        return 3
    return 75.0 if spec == "duration" else 1.5


def example_values(kind: Kind) -> dict[str, Any]:
    """A value for each field of *kind*'s wording."""
    out: dict[str, Any] = {}
    own = FIELDS_OF.get(kind.id, {})
    for _, name, spec, _ in string.Formatter().parse(kind.wording):
        if name is None or name in out:
            continue
        out[name] = own.get(name, FIELDS.get(name, _by_spec(spec or "")))
    return out


def example(kind: Kind):
    """*kind*'s record said where its scope says, with :func:`example_values`."""
    return kind.record(SCOPES[kind.scope], example_values(kind), "evtribo.tests")
