"""``analyze_study`` and ``evtribo analyze`` on simulated studies with known subjects."""

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest

from _checks import fel_ok
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study, simulate_trial
from evtribo.analysis.trial import TRIAL_COLUMNS, WINDOW_CSV_COLUMNS
from evtribo.canlog.io import write_candump
from evtribo.cli import main
from evtribo.errors import LogFormatError, OutputExistsError
from evtribo.results.aggregate import (
    BOOTSTRAP_COLUMNS,
    ELECTROSTATIC_COLUMNS,
    EXPONENT_COLUMNS,
    N_BOOTSTRAP_SAVED,
    summarize,
)
from evtribo.results.pipeline import BOOTSTRAP_FILE, OUTPUT_FILES, SINE_TRACE_FILE, analyze_study
from evtribo.store.owned import MANIFEST
from evtribo.study import write_sidecar, write_study_toml

AMPLITUDES = (60.0, 100.0, 140.0)
SUBJECTS = [SubjectParams(name="P01", mu=0.45, h_L=4e-6, normal_force_N=0.6),
            SubjectParams(name="P02", mu=0.3, h_L=7e-6, normal_force_N=1.2,
                          sliding_speed_m_s=0.03, reversal_s=0.1)]


def _truth_exponent(truths):
    u = np.array([t.config.amplitude_V for t in truths])
    f = np.array([t.electrostatic_force_N for t in truths])
    return np.polyfit(np.log(u), np.log(f), 1)[0]


@pytest.fixture(scope="module")
def default_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("study")
    cfg = TrialConfig(duration_s=10.0, drop_probability=0.01, fz_ppm=300, fx_ppm=-200,
                      jitter_s=2e-4, foreign_rate_Hz=20.0)
    truth = simulate_study(root, SUBJECTS, amplitudes=AMPLITUDES, config=cfg)
    out = tmp_path_factory.mktemp("out")
    res = analyze_study(root, out, jobs=2, cache_dir=tmp_path_factory.mktemp("cache"),
                        force=True)
    return root, truth, res



def test_a_trial_s_seconds_are_its_windows_and_what_was_left_out_by_reason(default_study):
    """trials.csv's seconds: the windows' own span analysed, the rest excluded by reason,
    all of it adding up to the trial's duration."""
    _, _, res = default_study
    trials = pd.read_csv(res.out_dir / "trials.csv")
    windows = pd.read_csv(res.out_dir / "windows.csv")
    parts = ["analysed_s", "excluded_switch_s", "excluded_lift_s", "excluded_unsteady_s",
             "excluded_other_s"]
    step = 2e-3  # a grid step per piece, at most
    assert (trials[parts].sum(axis=1) - trials["duration_s"]).abs().max() < step
    span = (windows.t_end_s - windows.t_start_s).groupby([windows.subject, windows.trial]).sum()
    own = trials.set_index(["subject", "trial"])["analysed_s"].loc[span.index]
    assert np.allclose(own.to_numpy(), span.to_numpy(), atol=1e-4)
    alternating = trials["condition"] == "alternating"
    assert (trials.loc[alternating, "excluded_switch_s"] > 0).all()  # the guard, each switch
    assert (trials.loc[~alternating, "excluded_switch_s"] == 0).all()
    assert (trials["excluded_unsteady_s"] > 0).all()  # the reversals

def test_outputs_have_the_spec_columns(default_study):
    _, _, res = default_study
    expected = {"trials.csv": TRIAL_COLUMNS, "windows.csv": WINDOW_CSV_COLUMNS,
                "electrostatic.csv": ELECTROSTATIC_COLUMNS, "exponents.csv": EXPONENT_COLUMNS}
    for name, cols in expected.items():
        header = (res.out_dir / name).read_text(encoding="utf-8").splitlines()[0]
        assert header.split(",") == list(cols)
    # the study format's columns first, in its order; then evtribo's additions
    assert TRIAL_COLUMNS == ("subject", "trial", "waveform", "frequency_Hz", "amplitude_V",
                             "condition", "duration_s", "frames", "dropped_frames",
                             "skipped_lines", "friction_modulation_Hz", "normal_offset_N",
                             "tangential_offset_N", "tare", "mu_change_per_10s",
                             "crosstalk_normal", "crosstalk_normal_se",
                             "tangential_direction_share", "analysed_s", "excluded_switch_s",
                             "excluded_lift_s", "excluded_unsteady_s", "excluded_other_s",
                             "duplicate_frames")
    assert WINDOW_CSV_COLUMNS[:9] == ("subject", "trial", "condition", "amplitude_V",
                                      "waveform", "t_start_s", "t_end_s", "normal_force_N",
                                      "friction_force_N")
    summary = json.loads((res.out_dir / "summary.json").read_text(encoding="utf-8"))
    assert summary["trials"] == summary["trials_analysed"] == 8
    assert isinstance(summary["warnings"], list) and summary["summary_version"] == 2
    assert all({"kind", "effect", "text", "subject", "trial"} <= set(w)
               for w in summary["warnings"])
    # the study has sine trials: their traces are written for the model comparison
    assert sorted(p.name for p in res.out_dir.iterdir()) == sorted(
        [*OUTPUT_FILES, SINE_TRACE_FILE, MANIFEST])


def test_recovers_mu_electrostatic_force_exponent_and_modulation(default_study):
    _, truth, res = default_study
    el = pd.read_csv(res.out_dir / "electrostatic.csv")
    trials = pd.read_csv(res.out_dir / "trials.csv")
    assert len(el) == 2 * (len(AMPLITUDES) + 1)
    truth_inside = []
    for subject in SUBJECTS:
        runs = truth[subject.name]
        for _, t in runs.items():
            wave, amp = t.config.waveform, t.config.amplitude_V
            row = el[(el.subject == subject.name) & (el.waveform == wave)
                     & (el.amplitude_V == amp)].iloc[0]
            assert row.mu == pytest.approx(subject.mu, rel=0.02)
            assert fel_ok(row.electrostatic_force_N, t.electrostatic_force_N), (
                subject.name, wave, amp, row.electrostatic_force_N, t.electrostatic_force_N)
            assert row.electrostatic_force_ci_low_N < row.electrostatic_force_N
            assert row.electrostatic_force_N < row.electrostatic_force_ci_high_N
            truth_inside.append(row.electrostatic_force_ci_low_N <= t.electrostatic_force_N
                                <= row.electrostatic_force_ci_high_N)
            assert row.n_on >= 4 and row.n_off >= 4
        square = [t for t in runs.values() if t.config.waveform == "square"]
        ex = pd.read_csv(res.out_dir / "exponents.csv")
        ex = ex[(ex.subject == subject.name) & (ex.waveform == "square")].iloc[0]
        assert ex.exponent == pytest.approx(_truth_exponent(square), abs=0.05)
        assert ex.exponent == pytest.approx(2.0, abs=0.1)
        assert ex.exponent_ci_low < ex.exponent < ex.exponent_ci_high
        assert ex.exponent_ci_low <= _truth_exponent(square) <= ex.exponent_ci_high
    assert all(truth_inside), truth_inside
    sine = trials[trials.waveform == "sine"]
    square = trials[trials.waveform == "square"]
    np.testing.assert_allclose(sine.friction_modulation_Hz, 2 * sine.frequency_Hz, rtol=0.02)
    assert square.friction_modulation_Hz.isna().all()
    assert (trials.dropped_frames > 0).all() and (trials.skipped_lines == 0).all()
    assert (trials.duration_s.between(9.9, 10.0)).all()


def test_bootstrap_replicates_are_written_for_compare(default_study):
    _, _, res = default_study
    el = pd.read_csv(res.out_dir / "electrostatic.csv")
    boot = pd.read_csv(res.out_dir / BOOTSTRAP_FILE)
    assert list(boot.columns) == list(BOOTSTRAP_COLUMNS)
    assert len(boot) == len(el) * N_BOOTSTRAP_SAVED
    for row in el.itertuples():
        reps = boot[(boot.subject == row.subject) & (boot.waveform == row.waveform)
                    & (boot.amplitude_V == row.amplitude_V)]
        assert list(reps.replicate) == list(range(N_BOOTSTRAP_SAVED))
        lo, hi = np.quantile(reps.electrostatic_force_N, [0.025, 0.975])
        width = row.electrostatic_force_ci_high_N - row.electrostatic_force_ci_low_N
        # the replicates the interval was taken from (200 of them: a noisy percentile)
        assert abs(lo - row.electrostatic_force_ci_low_N) < 0.35 * width
        assert abs(hi - row.electrostatic_force_ci_high_N) < 0.35 * width


def test_points_sharing_an_off_reference_share_its_resampling():
    # a whole-OFF trial serves both waveforms' ON trials; noise-free ON windows, so every
    # replicate's error is the OFF reference's mu: common to all the subject's points
    rng = np.random.default_rng(4)
    rows = []
    for _ in range(12):
        fn = 0.5 + 0.02 * rng.standard_normal()
        rows.append(("S", "off-1", "off", 0.0, "square", fn,
                     0.4 * fn * (1 + 0.03 * rng.standard_normal())))
    for trial, wave, amp in (("sq-60", "square", 60.0), ("sq-140", "square", 140.0),
                             ("si-140", "sine", 140.0)):
        for _ in range(6):
            fn = 0.5 + 0.02 * rng.standard_normal()
            rows.append(("S", trial, "on", amp, wave, fn, 0.4 * (fn + 1e-5 * amp**2)))
    windows = pd.DataFrame(rows, columns=["subject", "trial", "condition", "amplitude_V",
                                          "waveform", "normal_force_N", "friction_force_N"])
    trials = pd.DataFrame({"subject": "S", "trial": ["off-1", "sq-60", "sq-140", "si-140"],
                           "condition": ["off", "on", "on", "on"]})
    el, ex, boot, _ = summarize(windows, trials, n_boot=300, n_saved=100)
    assert list(zip(el.waveform, el.amplitude_V, strict=True)) == [
        ("sine", 140.0), ("square", 60.0), ("square", 140.0)]
    assert len(ex) == 1 and ex.waveform.iloc[0] == "square"
    wide = boot.pivot(index="replicate", columns=["waveform", "amplitude_V"],
                      values="electrostatic_force_N")
    assert wide.shape == (100, 3)
    assert np.corrcoef(wide.to_numpy().T).min() > 0.95


def test_windows_lie_inside_the_true_slides_and_phases(default_study):
    _, truth, res = default_study
    w = pd.read_csv(res.out_dir / "windows.csv")
    for (subject, trial), ws in w.groupby(["subject", "trial"]):
        t = truth[subject][trial]
        for row in ws.itertuples():
            # allow the trial-start estimate's error (first frame ~1 ms after the start)
            a, b = row.t_start_s + 2e-3, row.t_end_s - 2e-3
            assert any(s <= a and b <= e for s, e, _ in t.slides), (subject, trial, a, b)
            on = row.condition == "on"
            assert any(s <= a and b <= e and o == on for s, e, o in t.schedule)
            assert row.amplitude_V == (t.config.amplitude_V if on else 0.0)


def test_parallel_and_serial_runs_agree(default_study, tmp_path):
    root, _, res = default_study
    serial = analyze_study(root, tmp_path / "out", jobs=1, cache_dir=tmp_path / "cache")
    for name in ("trials.csv", "windows.csv", "electrostatic.csv", "exponents.csv"):
        assert (serial.out_dir / name).read_bytes() == (res.out_dir / name).read_bytes()


def test_refuses_to_overwrite_without_force(default_study, tmp_path):
    root, _, _ = default_study
    out = tmp_path / "out"
    out.mkdir()
    (out / "exponents.csv").write_text("mine\n", encoding="utf-8")
    with pytest.raises(OutputExistsError, match=r"exponents\.csv"):
        analyze_study(root, out, jobs=1, cache_dir=tmp_path / "cache")
    assert (out / "exponents.csv").read_text(encoding="utf-8") == "mine\n"
    assert main(["analyze", str(root), "--out", str(out), "--jobs", "1",
                 "--cache-dir", str(tmp_path / "cache")]) == 2
    # the user's file, not evtribo's: --force does not replace it either
    assert main(["analyze", str(root), "--out", str(out), "--jobs", "1", "--force",
                 "--cache-dir", str(tmp_path / "cache")]) == 2
    assert (out / "exponents.csv").read_text(encoding="utf-8") == "mine\n"
    (out / "exponents.csv").unlink()
    assert main(["analyze", str(root), "--out", str(out), "--jobs", "1",
                 "--cache-dir", str(tmp_path / "cache")]) == 0
    assert main(["analyze", str(root), "--out", str(out), "--jobs", "1",
                 "--cache-dir", str(tmp_path / "cache")]) == 2  # its own results: --force
    assert main(["analyze", str(root), "--out", str(out), "--jobs", "1", "--force",
                 "--cache-dir", str(tmp_path / "cache")]) == 0
    assert (out / "exponents.csv").read_text(encoding="utf-8").startswith("subject,")


# --- a rig with another DBC, whole-trial conditions from sidecars, damaged lines -----------

MOTOROLA_DBC = """VERSION "other-rig"

NS_ :

BS_:

BU_: FzNode FxNode HvAmp Logger

BO_ 2566848528 FzCell: 8 FzNode
 SG_ Fz : 7|24@0- (2e-05,0.1) [-167|167] "N" Logger
 SG_ FzStatus : 31|8@0+ (1,0) [0|255] "" Logger
 SG_ FzTemp : 39|16@0- (0.01,0) [-327.68|327.67] "degC" Logger
 SG_ FzCounter : 63|8@0+ (1,0) [0|255] "" Logger

BO_ 1313 FxCell: 8 FxNode
 SG_ Fx : 7|24@0- (5e-06,-0.05) [-41|41] "N" Logger
 SG_ FxStatus : 31|8@0+ (1,0) [0|255] "" Logger
 SG_ FxTemp : 39|16@0- (0.01,0) [-327.68|327.67] "degC" Logger
 SG_ FxCounter : 63|8@0+ (1,0) [0|255] "" Logger

BO_ 1600 HvStatus: 8 HvAmp
 SG_ HvOn : 0|1@1+ (1,0) [0|1] "" Logger
 SG_ HvWave : 1|2@1+ (1,0) [0|3] "" Logger
 SG_ HvCounter : 4|4@1+ (1,0) [0|15] "" Logger
 SG_ HvAmp : 8|16@1+ (0.01,0) [0|655.35] "V" Logger
 SG_ HvFreq : 24|24@1+ (0.01,0) [0|167772.15] "Hz" Logger
 SG_ HvCurrent : 48|16@1+ (0.001,0) [0|65.535] "uA" Logger

VAL_ 1600 HvWave 0 "sine" 1 "square" 2 "triangle" 3 "dc" ;
"""


def _other_rig_study(root, damage=True):
    dbc = root / "rig" / "other.dbc"
    dbc.parent.mkdir(parents=True)
    dbc.write_text(MOTOROLA_DBC, encoding="utf-8")
    write_study_toml(root, name="other rig", rig={
        "dbc": "rig/other.dbc", "normal_force": "FzCell.Fz", "tangential_force": "FxCell.Fx",
        "normal_force_counter": "FzCell.FzCounter",
        "tangential_force_counter": "FxCell.FxCounter"})
    subject = SubjectParams(name="S1", mu=0.62, h_L=3e-6, normal_force_N=0.8)
    base = TrialConfig(duration_s=10.0, fz_rate_Hz=500.0, fx_rate_Hz=1200.0, fz_ppm=-500,
                       fx_ppm=700, drop_probability=0.005)
    truths = {}
    plan = [("off-1", "off", 0.0), ("on-80", "on", 80.0), ("on-120", "on", 120.0),
            ("off-2", "off", 0.0)]
    for k, (name, condition, amp) in enumerate(plan):
        cfg = dataclasses.replace(base, condition=condition, amplitude_V=amp or 120.0,
                                  seed=40 + k, start_time=base.start_time + 60 * k)
        frames, truth = simulate_trial(subject, cfg, dbc=dbc)
        log_path = root / "S1" / f"{name}.log"
        log_path.parent.mkdir(exist_ok=True)
        write_candump(log_path, frames)
        if damage and k == 1:
            lines = log_path.read_text(encoding="ascii").splitlines(keepends=True)
            lines[100] = "(17637xx.000) vcan0 zz#1\n"
            lines[5000] = lines[5000][:12] + "\n"
            log_path.write_text("".join(lines), encoding="ascii")
        write_sidecar(log_path.with_suffix(".json"), {
            "waveform": "square", "frequency_Hz": 10000, "amplitude_V": amp,
            "condition": condition})
        truths[name] = truth
    return subject, truths


def test_other_dbc_and_sidecar_conditions(tmp_path):
    subject, truths = _other_rig_study(tmp_path / "study")
    res = analyze_study(tmp_path / "study", tmp_path / "out", jobs=1,
                        cache_dir=tmp_path / "cache")
    trials = res.trials.set_index("trial")
    assert trials.loc["on-80", "skipped_lines"] == 2
    assert (trials.skipped_lines.drop("on-80") == 0).all()
    assert any(w["kind"] == "damaged-lines" and w["trial"] == "on-80"
               for w in res.summary["warnings"])
    assert trials.loc["off-1", "dropped_frames"] > 0
    el = res.electrostatic.set_index("amplitude_V")
    assert list(el.index) == [80.0, 120.0]
    for amp, name in ((80.0, "on-80"), (120.0, "on-120")):
        assert el.loc[amp, "mu"] == pytest.approx(subject.mu, rel=0.02)
        assert el.loc[amp, "n_off"] == (res.windows.condition == "off").sum()
        assert fel_ok(el.loc[amp, "electrostatic_force_N"],
                       truths[name].electrostatic_force_N)
    ex = res.exponents.iloc[0]
    assert ex.exponent == pytest.approx(
        _truth_exponent([truths["on-80"], truths["on-120"]]), abs=0.05)
    assert not math.isnan(ex.exponent_ci_low)  # from the bootstrap with two amplitudes

    with pytest.raises(LogFormatError, match=r"on-80\.log"):
        analyze_study(tmp_path / "study", tmp_path / "strict", jobs=1, strict=True,
                      cache_dir=tmp_path / "cache")
    assert main(["analyze", str(tmp_path / "study"), "--out", str(tmp_path / "strict2"),
                 "--jobs", "1", "--strict", "--cache-dir", str(tmp_path / "cache")]) == 2


def test_a_trial_that_cannot_be_analysed_is_reported(tmp_path):
    root = tmp_path / "study"
    _other_rig_study(root, damage=False)
    side = root / "S1" / "on-120.json"
    data = json.loads(side.read_text(encoding="utf-8"))
    data["condition"] = "alternating"  # no excitation signals in this rig
    side.write_text(json.dumps(data), encoding="utf-8")
    res = analyze_study(root, tmp_path / "out", jobs=1, cache_dir=tmp_path / "cache")
    assert res.summary["trials_analysed"] == 3
    assert res.summary["failed_trials"][0]["trial"] == "S1/on-120"
    assert "excitation" in res.summary["failed_trials"][0]["error"]
    assert list(res.electrostatic.amplitude_V) == [80.0]
    row = res.trials.set_index("trial").loc["on-120"]
    assert row.condition == "alternating" and pd.isna(row.duration_s)

