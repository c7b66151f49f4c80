"""Each site says its warning as it did before its wording moved into the catalogue, byte
for byte: the site's records, said here, against the sentences its function said
(``_said_before.SAID``, taken from those functions), and each kind's wording, given the values
a site says it with, against the same sentence."""

from __future__ import annotations

import math

import cantools
import numpy as np
import pandas as pd
import pytest
from _said_before import SAID
from hypothesis import given
from hypothesis import strategies as st

from evtribo.analysis.forces.crosstalk import crosstalk_notes, pooled_over_trials
from evtribo.analysis.forces.pieces import describe_gap
from evtribo.analysis.friction.drift import (
    TrialDrift,
    clear_phase_s,
    drift_notes,
    phase_notes,
    stroke_notes,
)
from evtribo.analysis.friction.laws import SENSITIVITY_EXPONENT, FittedLaw, untold_note
from evtribo.analysis.friction.plausible import MAX_MU, MIN_MU, implausible_rows
from evtribo.analysis.tared_windows import _like_with_like
from evtribo.canlog import sequence
from evtribo.canlog.counters.law import counter_law
from evtribo.canlog.dropped import CLOCK_JUMP_S, _bursty, _outages_only, missing_frames_received
from evtribo.canlog.outages import outage_count
from evtribo.canlog.signal_codec import bad_samples
from evtribo.study import _cut_short
from evtribo.warning.catalogue import kind
from evtribo.warning.collect import collecting
from evtribo.warning.record import Scope


def said(kind_id: str, scope: Scope | None = None, **values) -> str:
    return kind(kind_id).record(scope, values).text


def texts(func, *args, **kwargs) -> list[str]:
    """What a site says, called here (quietly)."""
    with collecting(quiet=True) as records:
        func(*args, **kwargs)
    return [r.text for r in records]


def _gap_before(before, after, t0):
    """The pieces module's sentence on a pause, as it wrote it."""
    size = after[0] - before[1]
    size_text = (f"{size / 3600:.1f} h" if size >= 3600 else f"{size / 60:.1f} min"
                 if size >= 60 else f"{size:.1f} s")
    return (f"no frame of the load cells for {size_text} ({size:.3f} s) after "
            f"{before[1] - t0:.3f} s: a jump of the log's clock or a pause of the recording")


@given(gap=st.floats(0.5, 2e5), at=st.floats(0, 1e3))
def test_a_pause_is_said_as_the_pieces_module_said_it(gap, at):
    before, after = (0.0, at), (at + gap, at + gap + 1)
    assert texts(describe_gap, before, after, 0.0) == [_gap_before(before, after, 0.0)]
    assert said("pause", gap_s=after[0] - before[1], at_s=at) == _gap_before(before, after, 0.0)


@pytest.mark.parametrize(("step", "lost", "new"), [(-0.018, 1, 0), (2.5, 3, 45)])
def test_the_sequence_s_sentences_are_its_own(step, lost, new):
    seq = sequence.Sequenced(np.arange(3), np.arange(3.0), None, np.arange(3), duplicates=lost,
                             first_duplicate=11.0, stood=4, first_stood=12.5,
                             jumps=[sequence.CounterJump(5, 14.0, 17, new, lost)])
    got = texts(sequence.say, [(1, 2, step, 13.0)], [("FzCell", "FzCell.FzCounter", seq)], 1.0)
    assert got == SAID[f"seq{step}"]
    how = "counter-restart" if new == 0 else "counter-jump"
    assert got == [
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
    assert texts(untold_note, "P02", law) == [SAID[f"law{se}"]] == [
        said("law-untold", Scope("P02"), found=found, sensitivity=SENSITIVITY_EXPONENT)]


def test_drifts_strokes_and_phases_are_said_as_the_drift_module_said_them():
    drifts = {"run-01": TrialDrift(0.01, 0.12, 0.5, None), "run-02": TrialDrift(0.0, 0.01, 0.5,
                                                                                   None),
              "run-03": TrialDrift(0.02, -0.2, 0.5, None)}
    got = texts(drift_notes, "P01", drifts, compared_in_trial=True,
                on_trials_alone=["run-04", "run-05"])
    common = {"changed": 2, "trials": 3, "change_pct": -20.0, "worst": "run-03",
              "direction": "falling", "same": 1}
    assert got == SAID["drift"] == [
        said("drift-followed", Scope("P01"), **common),
        said("drift-unseen", Scope("P01"), **common, on_trials="run-04, run-05")]
    assert texts(stroke_notes, "P01", {}, 0.084, None) == SAID["scatter"] == [
        said("mu-scatter", Scope("P01"), scatter_pct=8.4)]

    class Paced:
        rate = 0.2

    assert texts(stroke_notes, "P01", {0: Paced()}, 0.0, -0.25) == SAID["pace"] == [said(
        "pace", Scope("P01"), slower="; the ON strokes were 25 % slower than the OFF ones")]
    got = texts(phase_notes, "P03", {"run-01": (9.0, 61.0), "run-02": (4.0, 59.0)})
    assert got == SAID["phases"] == [
        said("long-phases", Scope("P03"), trials="run-01, run-02", widening=3.0, trial_s=60.0,
             phase_s=clear_phase_s(60.0))]


def test_what_no_finger_gives_and_the_cross_talk_are_said_as_their_modules_said_them():
    rows = pd.DataFrame({"subject": ["P01", "P01"], "mu": [2.3, 2.3], "amplitude_V": [60., 80.],
                         "electrostatic_force_N": [0.1, 0.2],
                         "electrostatic_force_ci_low_N": [0.05, 0.1],
                         "electrostatic_force_ci_high_N": [0.15, 0.3]})
    assert texts(implausible_rows, rows) == SAID["implausible"] == [
        said("mu-implausible", Scope("P01"), mu=2.3, mu_low=MIN_MU, mu_high=MAX_MU)]
    below = rows.assign(mu=[0.5, 0.5], electrostatic_force_N=[-0.3, -0.2],
                        electrostatic_force_ci_low_N=[-0.35, -0.25],
                        electrostatic_force_ci_high_N=[-0.25, -0.15])
    assert texts(implausible_rows, below) == SAID["negative"]
    trials = pd.DataFrame({"crosstalk_normal": [0.05, 0.052, 0.049, 0.051],
                           "crosstalk_normal_se": [0.002] * 4,
                           "tangential_direction_share": [0.031, 0.03, 0.029, 0.030]})
    got = texts(crosstalk_notes, trials)
    pooled, pooled_se, _ = pooled_over_trials(trials.crosstalk_normal.to_numpy(float),
                                              trials.crosstalk_normal_se.to_numpy(float))
    mean, _, _ = pooled_over_trials(trials.tangential_direction_share.to_numpy(float))
    assert got == SAID["crosstalk"] == [
        said("crosstalk-normal", share_pct=100 * pooled, share_se_pct=100 * pooled_se,
             trials=4, matrix_b=-pooled),
        said("crosstalk-tangential", share_pct=100 * mean, trials=4)]


def test_no_force_anywhere_is_said_as_the_analysis_said_it():
    assert [said("no-on-window", windows=40), said("no-force-anywhere")] == SAID["noforce"]


def test_on_windows_left_out_for_their_direction_are_said_as_the_taring_said_them():
    w = pd.DataFrame({"condition": ["off"] * 3 + ["on"] * 4, "direction": [1] * 3 + [-1] * 4})
    assert texts(_like_with_like, w, np.zeros(len(w))) == SAID["like"] == [
        said("directions-confounded", left=4, on=4, way="forwards")]


def test_frames_lost_where_the_clock_jumped_are_said_as_the_count_said_them():
    t = np.r_[np.arange(100) * 0.01, 5 + np.arange(100) * 0.01]
    [note] = missing_frames_received(t).notes
    values = {"jumped": "jumped ahead or paused", "jump_s": CLOCK_JUMP_S,
              "counted": "cannot be counted"}
    assert (note.kind, note.mapping) == ("frames-lost-clock", values)
    assert said(note.kind, cell="normal", **note.mapping) == f"normal force: {SAID['clock']}"
    period = 0.01
    t = np.sort(np.r_[np.arange(0, 2, period), np.arange(0, 2, period) + 0.001])
    _, seen = outage_count(t)
    [note] = _outages_only(t, period, 0.42).notes
    assert note.mapping == {"coherence": 0.42, "frames": max(int(np.ceil(seen)), 2),
                            "bursts": "frames received in bursts, " if _bursty(t, period)
                            else ""}
    assert said(note.kind, cell="tangential", **note.mapping) == \
        f"tangential force: {SAID['outages']}"


def test_a_counter_that_does_not_count_is_said_as_its_law_said_it():
    t = np.arange(500) * 0.001
    note = counter_law(t, np.full(500, 5), 8, name="FzCell.FzCounter").note
    assert note is not None and note.mapping == {"counter": "FzCell.FzCounter",
                                                 "why": "it stays at 5"}
    assert said(note.kind, **note.mapping) == SAID["idle"]


def test_bad_samples_are_said_as_the_codec_said_them():
    signal = cantools.database.can.Signal("Fz", 0, 16, minimum=0, maximum=50, unit="N")
    values = np.r_[np.full(998, 10.0), np.inf, 60.0]
    t = np.arange(1000) * 0.01
    assert texts(bad_samples, t, values, signal, 0.0, "FzCell.Fz") == [SAID["bad"]] == [
        said("samples-bad", samples=2, signal="FzCell.Fz", range="[0, 50] N", at_s=9.98,
             value=np.inf)]
    assert texts(bad_samples, t, np.full(1000, 60.0), signal, 0.0, "FzCell.Fz") == [
        SAID["range"]] == [said("samples-range-wrong", share=1.0, signal="FzCell.Fz",
                                range="[0, 50] N")]


def test_a_recording_cut_short_is_said_as_the_study_said_it():
    cut = _cut_short({"ended": "interrupted", "requested_duration_s": 10, "duration_s": 3.25})
    assert cut == {"ended": "interrupted (Ctrl-C or SIGTERM)",
                   "after": " after 3.2 s of the 10 s asked"}
    assert said("cut-short", Scope("P01", "run-03"), log="s/P01/run-03.log", **cut) == (
        "s/P01/run-03.log: the recording was interrupted (Ctrl-C or SIGTERM) after 3.2 s of "
        "the 10 s asked; analysing what was recorded")


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


def test_each_note_of_a_cell_s_lost_frames_is_a_warning_of_its_own_each_sentence_once():
    """A stream whose timestamps cannot show single lost frames, with a jump of its clock:
    it was one warning, its notes joined by '; ', now one per note (the two pieces' notes
    that say the same, once)."""
    from evtribo.canlog.decode import say_lost

    rng = np.random.default_rng(1)
    t = np.sort(np.arange(0, 5, 0.01) + rng.uniform(0, 0.03, 500))
    notes = missing_frames_received(np.r_[t, t + 10]).notes
    assert [n.kind for n in notes] == ["frames-lost-outages", "frames-lost-outages",
                                       "frames-lost-clock"]
    assert texts(say_lost, "normal", notes) == [
        "normal force: timestamps too irregular (coherence 0.11) to see single lost frames "
        "without a counter: only outages of 2 or more frames in a row, away from the trial's "
        "ends, are counted",
        "normal force: the clock jumped ahead or paused by more than 1 s; frames missing "
        "across it cannot be counted"]
