"""Each kind's wording, given the values a site says it with, is that site's sentence byte
for byte: the sentences are made here by the functions that say them today."""

from __future__ import annotations

import math

import cantools
import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.analysis.forces.crosstalk import crosstalk_notes, pooled_over_trials
from evtribo.analysis.forces.pieces import describe_gap
from evtribo.analysis.friction.drift import TrialDrift, drift_notes, phase_notes, stroke_notes
from evtribo.analysis.friction.laws import SENSITIVITY_EXPONENT, FittedLaw, untold_note
from evtribo.analysis.friction.plausible import MAX_MU, MIN_MU, implausible_rows
from evtribo.analysis.tared_windows import _like_with_like
from evtribo.analysis.trial_warnings import no_force
from evtribo.canlog import sequence
from evtribo.canlog.counters.law import counter_law
from evtribo.canlog.dropped import CLOCK_JUMP_S, _bursty, _outages_only, missing_frames_received
from evtribo.canlog.outages import outage_count
from evtribo.canlog.signal_codec import bad_samples
from evtribo.study import _cut_short
from evtribo.warning.catalogue import kind
from evtribo.warning.record import Scope


def said(kind_id: str, scope: Scope | None = None, **values) -> str:
    return kind(kind_id).record(scope, values).text


@given(gap=st.floats(0.5, 2e5), at=st.floats(0, 1e3))
def test_a_pause_is_said_as_the_pieces_module_says_it(gap, at):
    before, after = (0.0, at), (at + gap, at + gap + 1)
    assert said("pause", gap_s=after[0] - before[1], at_s=at) == describe_gap(before, after, 0.0)


@pytest.mark.parametrize(("step", "lost", "new"), [(-0.018, 1, 0), (2.5, 3, 45)])
def test_the_sequence_s_sentences_are_its_own(step, lost, new):
    seq = sequence.Sequenced(np.arange(3), np.arange(3.0), None, np.arange(3), duplicates=lost,
                             first_duplicate=11.0, stood=4, first_stood=12.5,
                             jumps=[sequence.CounterJump(5, 14.0, 17, new, lost)])
    text = sequence.said([(1, 2, step, 13.0)], [("FzCell", "FzCell.FzCounter", seq)], 1.0)
    how = "counter-restart" if new == 0 else "counter-jump"
    assert text == [
        said("clock-step", direction="back" if step < 0 else "ahead", step_s=abs(step),
             at_s=12.0),
        said(how, counter="FzCell.FzCounter", old=17, new=new, at_s=13.0, lost=lost),
        said("frames-twice", frames=lost, message="FzCell", at_s=10.0),
        said("counter-stood", counter="FzCell.FzCounter", frames=4, at_s=11.5)]


@pytest.mark.parametrize("se", [0.12, math.nan])
def test_the_untold_law_is_said_as_the_law_says_it(se):
    law = FittedLaw(estimate=math.nan if math.isnan(se) else 0.93, estimate_se=se, dof=12)
    low, high = law.interval
    found = (f"m = {law.estimate:.2f} [{low:.2f}, {high:.2f}]" if np.isfinite(low)
             else "no spread of the normal force to fit m to")
    assert untold_note("P02", law) == said("law-untold", Scope("P02"), found=found,
                                           sensitivity=SENSITIVITY_EXPONENT)


def test_drifts_strokes_and_phases_are_said_as_the_drift_module_says_them():
    drifts = {"run-01": TrialDrift(0.01, 0.12, 0.5, None), "run-02": TrialDrift(0.0, 0.01, 0.5,
                                                                                   None),
              "run-03": TrialDrift(0.02, -0.2, 0.5, None)}
    followed, unseen = drift_notes("P01", drifts, compared_in_trial=True,
                                   on_trials_alone=["run-04", "run-05"])
    common = {"changed": 2, "trials": 3, "change_pct": -20.0, "worst": "run-03",
              "direction": "falling", "same": 1}
    assert followed == said("drift-followed", Scope("P01"), **common)
    assert unseen == said("drift-unseen", Scope("P01"), **common, on_trials="run-04, run-05")
    assert stroke_notes("P01", {}, 0.084, None) == [said("mu-scatter", Scope("P01"),
                                                         scatter_pct=8.4)]

    class Paced:
        rate = 0.2

    assert stroke_notes("P01", {0: Paced()}, 0.0, -0.25) == [said(
        "pace", Scope("P01"), slower="; the ON strokes were 25 % slower than the OFF ones")]
    [phases] = phase_notes("P03", {"run-01": (9.0, 61.0), "run-02": (4.0, 59.0)})
    from evtribo.analysis.friction.drift import clear_phase_s

    assert phases == said("long-phases", Scope("P03"), trials="run-01, run-02", widening=3.0,
                          trial_s=60.0, phase_s=clear_phase_s(60.0))


def test_what_no_finger_gives_and_the_cross_talk_are_said_as_their_modules_say_them():
    rows = pd.DataFrame({"subject": ["P01", "P01"], "mu": [2.3, 2.3], "amplitude_V": [60., 80.],
                         "electrostatic_force_N": [0.1, 0.2],
                         "electrostatic_force_ci_low_N": [0.05, 0.1],
                         "electrostatic_force_ci_high_N": [0.15, 0.3]})
    assert implausible_rows(rows) == [said("mu-implausible", Scope("P01"), mu=2.3,
                                           mu_low=MIN_MU, mu_high=MAX_MU)]
    trials = pd.DataFrame({"crosstalk_normal": [0.05, 0.052, 0.049, 0.051],
                           "crosstalk_normal_se": [0.002] * 4,
                           "tangential_direction_share": [0.031, 0.03, 0.029, 0.030]})
    normal, tangential = crosstalk_notes(trials)
    pooled, pooled_se, _ = pooled_over_trials(trials.crosstalk_normal.to_numpy(float),
                                              trials.crosstalk_normal_se.to_numpy(float))
    assert normal == said("crosstalk-normal", share_pct=100 * pooled,
                          share_se_pct=100 * pooled_se, trials=4, matrix_b=-pooled)
    mean, _, _ = pooled_over_trials(trials.tangential_direction_share.to_numpy(float))
    assert tangential == said("crosstalk-tangential", share_pct=100 * mean, trials=4)


def test_no_force_anywhere_is_said_as_the_analysis_says_it():
    assert no_force(0, 40) == said("no-on-window", windows=40)
    assert no_force(3, 40) == said("no-force-anywhere")


def test_on_windows_left_out_for_their_direction_are_said_as_the_taring_says_them():
    w = pd.DataFrame({"condition": ["off"] * 3 + ["on"] * 4, "direction": [1] * 3 + [-1] * 4})
    out: list[str] = []
    _like_with_like(w, np.zeros(len(w)), out.append)
    assert out == [said("directions-confounded", left=4, on=4, way="forwards")]


def test_frames_lost_where_the_clock_jumped_are_said_as_the_count_says_them():
    t = np.r_[np.arange(100) * 0.01, 5 + np.arange(100) * 0.01]
    note = missing_frames_received(t).note
    assert f"normal force: {note}" == said("frames-lost-clock", cell="normal",
                                           jumped="jumped ahead or paused",
                                           jump_s=CLOCK_JUMP_S, counted="cannot be counted")
    period = 0.01
    t = np.sort(np.r_[np.arange(0, 2, period), np.arange(0, 2, period) + 0.001])
    coherence = 0.42
    _, seen = outage_count(t)
    assert f"tangential force: {_outages_only(t, period, coherence).note}" == said(
        "frames-lost-outages", cell="tangential", coherence=coherence,
        bursts="frames received in bursts, " if _bursty(t, period) else "",
        frames=max(int(np.ceil(seen)), 2))


def test_a_counter_that_does_not_count_is_said_as_its_law_says_it():
    t = np.arange(500) * 0.001
    law = counter_law(t, np.full(500, 5), 8, name="FzCell.FzCounter")
    assert law.note == said("counter-idle", counter="FzCell.FzCounter", why="it stays at 5")


def test_bad_samples_are_said_as_the_codec_says_them():
    signal = cantools.database.can.Signal("Fz", 0, 16, minimum=0, maximum=50, unit="N")
    values = np.r_[np.full(998, 10.0), np.inf, 60.0]
    t = np.arange(1000) * 0.01
    _, text = bad_samples(t, values, signal, 0.0, "FzCell.Fz")
    assert text == said("samples-bad", samples=2, signal="FzCell.Fz", range="[0, 50] N",
                        at_s=9.98, value=np.inf)
    _, text = bad_samples(t, np.full(1000, 60.0), signal, 0.0, "FzCell.Fz")
    assert text == said("samples-range-wrong", share=1.0, signal="FzCell.Fz", range="[0, 50] N")


def test_a_recording_cut_short_is_said_as_the_study_says_it():
    cut = _cut_short({"ended": "interrupted", "requested_duration_s": 10, "duration_s": 3.25})
    assert f"s/P01/run-03.log: {cut}; analysing what was recorded" == said(
        "cut-short", Scope("P01", "run-03"), log="s/P01/run-03.log",
        ended="interrupted (Ctrl-C or SIGTERM)", after=" after 3.2 s of the 10 s asked")


def test_the_sentences_the_report_s_tests_hold_are_the_catalogue_s():
    """The lines tests/report/test_warning_kinds.py writes as the analysis says them."""
    zero = ("P01/run-02: the normal cell's zero is unknown (no finger-lifted stretch and no "
            "[rig.calibration] normal_offset_N): an offset of 10 mN would change F_el by 2.1 % "
            "(offset / F_n, at this trial's 0.48 N); record a tare stretch (evtribo acquire "
            "--tare-s) or give [rig.calibration] normal_offset_N")
    assert said("normal-zero", Scope("P01", "run-02"), change_pct=2.08, normal_N=0.48) == zero
    few = ("P02 (square, 10000 Hz) at 80 V: only 3 ON and 4 OFF windows (fewer than 5); the "
           "interval is calibrated for small counts but rests on few windows")
    assert said("few-windows", Scope("P02", None, "square", 10000.0, 80.0), on=3, off=4,
                min_windows=5) == few
    offset = ("P01/run-01: the tangential cell's zero offset was -44.9 mN, 18 % of the "
              "tangential force measured (0.254 N); removed, but tare the load cells before "
              "recording")
    assert said("offset", Scope("P01", "run-01"), cell="tangential", offset_mN=-44.93,
                share_pct=17.7, force_N=0.254) == offset
    drift = ("P01/run-01: the tangential cell's zero drifted by -7.3 mN between the "
             "finger-lifted stretches at 0.8 s and 13.9 s (noise 0.29 mN); interpolated "
             "between them")  # the demo's summary.json
    assert said("zero-drift", Scope("P01", "run-01"), cell="tangential", drift_mN=-7.26,
                first_s=0.81, last_s=13.93, noise_mN=0.291) == drift
