"""The report's first sentence on simulated studies, read back against population.csv: the
demo (a square drive at several voltages and a sine drive at one), a frequency sweep (one
amplitude at each of eight frequencies) and eight subjects. Each "X [lo, hi] mN|% at U V"
and "n = X [lo, hi]" is the primary row of the drive whose clause holds it; a drive of one
amplitude quotes no population F_el; an exponent whose checks failed is not quoted."""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import pandas as pd
import pytest

from evtribo.documents.population_table import Checks, Drive
from evtribo.report.study_report import build_report
from evtribo.util.numbers import with_interval

AT = re.compile(r"(\S+ \[\S+, \S+\]) (mN|%) at (\S+) V")
N_IS = re.compile(r"n = (\S+ \[\S+, \S+\])")
UNITS = {"mN": ("electrostatic_force_N", 1e3), "%": ("friction_increase_pct", 1.0)}


def _sentence(report: Path) -> str:
    found = re.search(r'<p class="lead">(.*?)</p>', report.read_text(encoding="utf-8"), re.S)
    assert found is not None
    return html.unescape(found[1]).replace("\u00a0", " ")


def _primary(pop: pd.DataFrame, quantity: str, drive: Drive, amp: float | None) -> pd.Series:
    rows = pop[(pop["quantity"] == quantity) & (pop["analysis"] == "primary")
               & (pop["waveform"] == drive.waveform)
               & ((pop["frequency_Hz"] - (drive.frequency_Hz or 0)).abs() < 1e-6)]
    rows = rows[rows["amplitude_V"].isna()] if amp is None else \
        rows[(rows["amplitude_V"] - amp).abs() < 1e-6]
    assert len(rows) == 1, (quantity, drive, amp)
    return rows.iloc[0]


def _clauses(sentence: str, drives: list[Drive]) -> dict[Drive, str]:
    starts = {}
    for d in drives:
        found = [m.start() - 1 for m in re.finditer(re.escape(d.label()[1:]) + ":", sentence)]
        assert len(found) == 1, (d.label(), sentence)
        starts[d] = found[0]
    ends = sorted([*starts.values(), len(sentence)])
    return {d: sentence[s:min(e for e in ends if e > s)] for d, s in starts.items()}


def check_sentence(out: Path, report: Path) -> tuple[str, dict[Drive, str]]:
    """The sentence and its clauses, each number checked against population.csv."""
    sentence = _sentence(report)
    pop = pd.read_csv(out / "population.csv")
    es = pd.read_csv(out / "electrostatic.csv")
    checks = {Drive.from_condition(k): Checks.from_json(v) for k, v in json.loads(
        (out / "fit.json").read_text(encoding="utf-8"))["population"]["checks"].items()}
    drives = sorted({Drive.of(w, f) for w, f in zip(es["waveform"], es["frequency_Hz"],
                                                    strict=True)})
    clauses = _clauses(sentence, drives)
    seen = 0
    for drive, clause in clauses.items():
        for m in AT.finditer(clause):
            quantity, factor = UNITS[m[2]]
            row = _primary(pop, quantity, drive, float(m[3]))
            assert m[1] == with_interval(factor * row["estimate"], factor * row["ci_low"],
                                         factor * row["ci_high"]), (m[0], clause)
            seen += 1
        for m in N_IS.finditer(clause):
            row = _primary(pop, "exponent", drive, None)
            assert checks[drive].holds("exponent"), clause
            assert m[1] == with_interval(row["estimate"], row["ci_low"], row["ci_high"])
            seen += 1
        if drive in checks and not checks[drive].holds("exponent"):
            assert "n = " not in clause and "undetermined" in clause, clause
    assert seen == len(AT.findall(sentence)) + len(N_IS.findall(sentence)) > 0, sentence
    return sentence, clauses


@pytest.mark.slow
def test_the_demo_s_sentence_quotes_the_square_drive_s_primary_force(tmp_path):
    from evtribo.demo import run_demo

    res = run_demo(tmp_path / "demo", subjects=3, amplitudes=(80.0, 110.0, 140.0),
                   trial_s=8.0, speed=8.0, jobs=1)
    out = res.report.parent / "results"
    sentence, clauses = check_sentence(out, res.report)
    square, sine = Drive("square", 10000.0), Drive("sine", 10.0)
    assert sentence.startswith("3 subjects, square 10 kHz: ")
    top = _primary(pd.read_csv(out / "population.csv"), "electrostatic_force_N", square, 140.0)
    shown = with_interval(1e3 * top["estimate"], 1e3 * top["ci_low"], 1e3 * top["ci_high"])
    assert f"the population's F_el was {shown} mN at 140 V" in clauses[square] \
        or "F_el is undetermined" in clauses[square]
    # the sine drive has one amplitude: its force is the meta-analysis's, never quoted
    assert "no population F_el (one amplitude" in clauses[sine]
    assert " mN at " not in clauses[sine]
    assert "relative friction increase F_el/F_n,ON was" in clauses[sine]


@pytest.mark.slow
def test_a_sweep_of_frequencies_has_a_clause_per_drive(tmp_path):
    from sweep_study import SWEEP_HZ, sweep_study

    out, _ = sweep_study(tmp_path, duration_s=8.0)
    report = build_report(out, tmp_path / "report.html")
    _, clauses = check_sentence(out, report)
    assert sorted(d.frequency_Hz for d in clauses) == sorted(SWEEP_HZ)
    for clause in clauses.values():  # one amplitude each: no power law, no population F_el
        assert "no population F_el (one amplitude" in clause and "n = " not in clause
        assert " % at 100 V" in clause


@pytest.mark.slow
def test_eight_subjects_quote_their_primary_rows(tmp_path):
    from eight_subjects import eight_subject_study

    out = eight_subject_study(tmp_path, models="paper")
    report = build_report(out, tmp_path / "report.html")
    sentence, clauses = check_sentence(out, report)
    assert sentence.startswith("8 subjects, square 10 kHz: the relative friction increase")
    (clause,) = clauses.values()
    assert " mN at 140 V" in clause or "F_el is undetermined" in clause
    assert not math.isnan(pd.read_csv(out / "population.csv")["estimate"].iloc[0])
