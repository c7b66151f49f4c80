"""Simulated rig -> analysis -> model fit: the air gaps the simulator used come back."""

from __future__ import annotations

import pandas as pd

from evtribo.cli import main
from evtribo.report.compare import compare

GAPS = {"P01": 3e-6, "P02": 8e-6}


def test_simulated_study_air_gaps_recovered(tmp_path):
    study, out = tmp_path / "study", tmp_path / "out"
    for subject, gap in GAPS.items():
        for k, amp in enumerate((60, 100, 140), 1):
            assert main(["simulate", "--study", str(study), "--subject", subject,
                         "--trial", f"run-{k:02d}", "--amplitude", str(amp),
                         "--waveform", "square", "--frequency", "10000",
                         "--condition", "alternating", "--duration", "5",
                         "--air-gap", str(gap), "--seed", str(k)]) == 0
    assert main(["analyze", str(study), "--out", str(out)]) == 0
    result = compare(out, dpi=30, formats=("png",))
    fit = pd.read_csv(out / "fit.csv").set_index("subject")
    for f in result.fits:
        truth = GAPS[f.subject]
        est = f["h_L"]
        assert abs(est.value - truth) / truth < 0.10
        assert est.contains(truth), (f.subject, est, truth)
        assert fit.loc[f.subject, "value"] == est.value
