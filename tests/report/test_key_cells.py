"""Every number of the key results is the cell its table shows: over generated studies (one
or two waveforms at one to three frequencies, one to five amplitudes, primary, sensitivity
and meta-analysis rows in any order, drives of one amplitude, excluded subjects, each check
failing), each number with an interval in the sentence lies in the clause of its drive and
equals that drive's primary row of population.csv as the tables format it, and no number of a
quantity whose checks failed appears."""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.documents.population_table import (
    EXPONENT,
    FORCE,
    META,
    PREFACTOR,
    PRIMARY,
    Checks,
    Drive,
    PopulationTable,
    without,
)
from evtribo.documents.quantities import friction_increase_pct
from evtribo.report.lead.claims import INCREASE, key_claims, key_sentence
from evtribo.util.numbers import with_interval

WAVES = ("square", "sine")
FREQS = (10.0, 100.0, 10000.0)
AMPS = (60.0, 80.0, 100.0, 120.0, 140.0)
#: A number with its interval at an amplitude, and the exponent's.
AT = re.compile(r"(\S+ \[\S+, \S+\]) (mN|%) at (\S+) V")
N_IS = re.compile(r"n = (\S+ \[\S+, \S+\])")
#: Each unit's quantity and factor from SI.
UNITS = {"mN": (FORCE, 1e3), "%": (INCREASE, 1.0)}


def _interval(rng: np.random.Generator, low: float, high: float) -> dict[str, float]:
    est = float(rng.uniform(low, high))
    lo, hi = est - float(rng.uniform(0.05, 0.6)) * abs(est), est + float(
        rng.uniform(0.05, 2.0)) * abs(est)
    return {"estimate": est, "ci_low": lo, "ci_high": hi, "pi_low": lo - 1, "pi_high": hi + 1}


def _row(quantity: str, drive: Drive, amp: float | None, analysis: str, *, checks: str,
         values: dict[str, float]) -> dict:
    return {"quantity": quantity, "waveform": drive.waveform, "frequency_Hz": drive.frequency_Hz,
            "amplitude_V": math.nan if amp is None else amp, "analysis": analysis,
            **values, "n_subjects": 3, "method": "test", "checks": checks}


@st.composite
def studies(draw):
    """(population.csv as a frame, each drive's checks, electrostatic.csv, excluded)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    waves = draw(st.lists(st.sampled_from(WAVES), min_size=1, max_size=2, unique=True))
    drives = [Drive(w, f) for w in waves
              for f in draw(st.lists(st.sampled_from(FREQS), min_size=1, max_size=3,
                                     unique=True))]
    n_subjects = draw(st.integers(1, 5))
    rows, checks, cells = [], {}, []
    for drive in drives:
        amps = sorted(draw(st.lists(st.sampled_from(AMPS), min_size=1, max_size=5,
                                    unique=True)))
        fails = draw(st.lists(st.booleans(), min_size=4, max_size=4))
        checks[drive] = Checks(*(not f for f in fails), text="ok" if not any(fails)
                               else "the checks failed")
        text = checks[drive].text
        for amp in amps:
            for s in range(n_subjects):
                cells.append({"subject": f"S0{s + 1}", "waveform": drive.waveform,
                              "frequency_Hz": drive.frequency_Hz, "amplitude_V": amp,
                              "electrostatic_force_N": float(rng.uniform(-0.01, 0.4)),
                              "normal_force_on_N": float(rng.uniform(0.2, 1.5))})
            rows.append(_row(FORCE, drive, amp, META, checks="",
                             values=_interval(rng, 0.01, 0.5)))
            rows.append(_row(INCREASE, drive, amp, PRIMARY, checks="",
                             values=_interval(rng, -5, 80)))
            if len(amps) > 1:
                rows.append(_row(FORCE, drive, amp, PRIMARY, checks=text,
                             values=_interval(rng, 0.01, 0.5)))
                rows.append(_row(FORCE, drive, amp, without("S02"), checks=text,
                             values=_interval(rng, 0.01, 0.5)))
        if len(amps) > 1:
            rows.append(_row(EXPONENT, drive, None, PRIMARY, checks=text,
                             values=_interval(rng, 1, 3.5)))
            rows.append(_row(EXPONENT, drive, None, without("S02"), checks=text,
                             values=_interval(rng, 1, 3.5)))
            rows.append(_row(PREFACTOR, drive, None, PRIMARY, checks=text,
                             values=_interval(rng, 1e-6, 1e-4)))
    order = rng.permutation(len(rows))
    frame = pd.DataFrame([rows[i] for i in order])
    excluded = draw(st.lists(st.sampled_from(["S07", "S08"]), unique=True))
    return frame, checks, pd.DataFrame(cells), n_subjects, excluded


def _clauses(sentence: str, drives: list[Drive]) -> dict[Drive, tuple[int, int]]:
    """Where each drive's clause begins and ends in the sentence."""
    starts = {}
    for d in drives:
        found = [m.start() for m in re.finditer(re.escape(d.label()[1:]) + ":", sentence)]
        assert len(found) == 1, (d, sentence)
        starts[d] = found[0] - 1
    ends = sorted([*starts.values(), len(sentence)])
    return {d: (s, min(e for e in ends if e > s)) for d, s in starts.items()}


def _drive_at(spans: dict[Drive, tuple[int, int]], pos: int) -> Drive:
    inside = [d for d, (s, e) in spans.items() if s <= pos < e]
    assert inside, f"a number outside every drive's clause at {pos}"
    return inside[0]


@given(studies())
def test_every_number_of_the_key_results_is_its_drive_s_primary_cell(study):
    frame, checks, cells, n_subjects, excluded = study
    table = PopulationTable(frame, checks=checks) if n_subjects >= 3 else None
    claims = key_claims(table, cells)
    for c in claims:
        if c.state == "quoted":
            assert table is not None
            assert c.row is table.row(c.quantity, c.drive, c.amplitude_V, PRIMARY)
            assert c.row is not None and c.row.analysis == PRIMARY
    sentence = key_sentence(claims, n_subjects=n_subjects, excluded=excluded)
    plain = sentence.replace("\u00a0", " ")
    assert plain.startswith(f"{n_subjects} subject")
    assert all(s in plain for s in excluded)
    drives = sorted({Drive.of(w, f) for w, f in zip(cells["waveform"], cells["frequency_Hz"],
                                                    strict=True)})
    spans = _clauses(plain, drives)
    for m in AT.finditer(plain):
        assert table is not None, "an interval quoted without a population"
        drive = _drive_at(spans, m.start())
        quantity, factor = UNITS[m[2]]
        row = table.row(quantity, drive, float(m[3]), PRIMARY)
        assert row is not None, m[0]
        assert checks[drive].holds(quantity) or quantity == INCREASE
        assert m[1] == with_interval(factor * row.estimate, factor * row.ci_low,
                                     factor * row.ci_high)
    for m in N_IS.finditer(plain):
        assert table is not None
        drive = _drive_at(spans, m.start())
        row = table.row(EXPONENT, drive)
        assert row is not None and checks[drive].holds(EXPONENT)
        assert m[1] == with_interval(row.estimate, row.ci_low, row.ci_high)
    for drive, (s, e) in spans.items():
        clause = plain[s:e]
        if table is None:
            continue
        top = table.rows(FORCE, drive)
        if top and checks[drive].holds(FORCE):  # quoted: the highest amplitude's
            shown = with_interval(1e3 * top[-1].estimate, 1e3 * top[-1].ci_low,
                                  1e3 * top[-1].ci_high)
            assert f"{shown} mN at" in clause
        if top and not checks[drive].holds(FORCE):
            assert " mN at " not in clause and "undetermined" in clause
        if not top:  # one amplitude: no population F_el, the meta-analysis not quoted
            assert " mN at " not in clause and "no population F_el" in clause
        if table.row(EXPONENT, drive) is not None and not checks[drive].holds(EXPONENT):
            assert "n = " not in clause and "undetermined" in clause


@pytest.mark.parametrize("fn", [0.0, -0.1, math.nan])
def test_the_relative_friction_increase_has_no_value_without_a_press(fn):
    assert math.isnan(friction_increase_pct(0.05, fn))


@given(st.floats(-1, 1), st.floats(1e-3, 10))
def test_the_relative_friction_increase_is_100_f_el_over_f_n_on(force, fn):
    assert friction_increase_pct(force, fn) == (100.0 / fn) * force
    assert friction_increase_pct(np.array([force]), np.array([fn]))[0] == (100.0 / fn) * force
