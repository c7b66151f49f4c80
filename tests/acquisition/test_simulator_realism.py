"""The simulated rig as a real one: load-cell offsets, drift, hum, cross-talk, a person's
strokes, dwells, lift-offs and the tare stretch; and what the truth record says of them."""

from __future__ import annotations

import dataclasses
import json

import cantools
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import (
    DEFAULT_DBC,
    SubjectParams,
    TrialConfig,
    simulate_trial,
)
from evtribo.acquisition.simulator.physics import CONTACT_RAMP_S, CellZero
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.cli import main
from evtribo.errors import ConfigError
from evtribo.study import read_sidecar

DB = cantools.database.load_file(str(DEFAULT_DBC))
FZ, FX = 0x0C1, 0x0C2


def cell(frames, frame_id, start):
    """Sample times (s from the trial's start) and forces of one cell, decoded by cantools."""
    msg = DB.get_message_by_frame_id(frame_id)
    sel = frames.arbitration_id == frame_id
    name = "Fz" if frame_id == FZ else "Fx"
    values = np.array([msg.decode(bytes(r[:8]), decode_choices=False)[name]
                       for r in frames.data[sel]])
    return frames.timestamp[sel] - start, values


def inside(t, spans, margin=0.0):
    mask = np.zeros(t.shape, bool)
    for a, b, *_ in spans:
        mask |= (t > a + margin) & (t < b - margin)
    return mask


def test_the_cells_read_their_drifting_zero_while_the_finger_is_lifted():
    cfg = TrialConfig(duration_s=8.0, tare_s=1.5, fz_offset_N=0.041, fx_offset_N=-0.033,
                      fz_drift_N_per_s=0.001, fx_drift_N_per_s=-0.0005, fz_thermal_N=0.004,
                      fx_thermal_N=0.002, thermal_time_s=20.0, noise_N=0.0005, seed=4)
    subject = SubjectParams(lifts_per_min=20.0, lift_s=0.6)
    frames, truth = simulate_trial(subject, cfg)
    assert truth.lifted[0] == pytest.approx((0.0, 1.5))
    assert len(truth.lifted) >= 2  # the tare stretch and at least one lift-off
    for frame_id, name in ((FZ, "normal"), (FX, "tangential")):
        t, f = cell(frames, frame_id, cfg.start_time + cfg.latency_s)
        zero = CellZero(**{k: truth.cells[name][k] for k in
                           ("offset_N", "drift_N_per_s", "thermal_N", "thermal_time_s")})
        for a, b in truth.lifted:
            sel = (t > a + 0.02) & (t < b - 0.02)
            assert np.mean(f[sel] - zero.offset(t[sel])) == pytest.approx(0.0, abs=2e-4)
        # the truth's mean zero over the trial is the zero's mean, as trials.csv reports it
        grid = np.linspace(0, cfg.duration_s, 100_001)
        assert truth.cells[name]["mean_offset_N"] == pytest.approx(
            float(np.mean(zero.offset(grid))), abs=1e-7)
    # while lifted, no electrostatic force and no friction
    assert truth.electrostatic_between(*truth.lifted[1]) == pytest.approx(0.0, abs=1e-12)


def test_mains_hum_at_its_frequency_and_amplitude_on_each_cell():
    for mains in (50.0, 60.0):
        cfg = TrialConfig(duration_s=4.0, condition="off", fz_hum_N=0.01, fx_hum_N=0.004,
                          mains_Hz=mains, noise_N=0.0, seed=1)
        frames, _ = simulate_trial(SubjectParams(force_drift=0.0, stroke_length_m=1.0), cfg)
        for frame_id, amp in ((FZ, 0.01), (FX, 0.004)):
            t, f = cell(frames, frame_id, cfg.start_time)
            # lock-in at the mains frequency (the forces themselves are slow here)
            basis = np.column_stack([np.sin(2 * np.pi * mains * t), np.cos(2 * np.pi * mains * t),
                                     np.ones_like(t), t, t**2])
            coef, *_ = np.linalg.lstsq(basis, f, rcond=None)
            assert np.hypot(coef[0], coef[1]) == pytest.approx(amp, rel=0.05)


def test_crosstalk_is_undone_by_the_calibration_matrix_of_the_truth():
    xt = ((1.0, 0.04), (-0.03, 1.0))
    cfg = TrialConfig(duration_s=4.0, noise_N=0.0, crosstalk=xt, fz_rate_Hz=2000.0,
                      fx_rate_Hz=2000.0, fz_ppm=0.0, fx_ppm=0.0, jitter_s=0.0, seed=2)
    subject = SubjectParams(force_drift=0.02)
    frames, truth = simulate_trial(subject, cfg)
    frames_ideal, _ = simulate_trial(subject,
                                     dataclasses.replace(cfg, crosstalk=((1, 0), (0, 1))))
    _, fn = cell(frames, FZ, cfg.start_time)
    _, ft = cell(frames, FX, cfg.start_time)
    _, fn0 = cell(frames_ideal, FZ, cfg.start_time)
    _, ft0 = cell(frames_ideal, FX, cfg.start_time)
    assert truth.crosstalk == [[1.0, 0.04], [-0.03, 1.0]]
    m = np.asarray(truth.calibration_matrix)
    np.testing.assert_allclose(m @ np.asarray(xt), np.eye(2), atol=1e-12)
    # the cells sample at the same instants here: the matrix gives the true forces back
    n = min(fn.size, ft.size, fn0.size, ft0.size)
    back = m @ np.vstack([fn[:n], ft[:n]])
    np.testing.assert_allclose(back[0], fn0[:n], atol=2e-5)  # the ADC's 10 uN steps
    np.testing.assert_allclose(back[1], ft0[:n], atol=2e-5)
    assert np.max(np.abs(fn[:n] - fn0[:n])) > 0.005  # and without it they differ


def test_a_persons_strokes_are_irregular_and_rest_at_the_reversals():
    person = human(SubjectParams(), seed=3)
    assert person.dwell_s > 0 and person.lifts_per_min > 0 and person.stroke_jitter >= 0.2
    frames, truth = simulate_trial(person, TrialConfig(duration_s=30.0, seed=3))
    slides = np.array([(a, b) for a, b, _ in truth.slides])[1:-1]  # whole slides only
    lengths = slides[:, 1] - slides[:, 0]
    assert lengths.std() / lengths.mean() > 0.08
    gaps = slides[1:, 0] - slides[:-1, 1]  # reversal + dwell
    assert gaps.min() >= person.reversal_s - 1e-9 and gaps.max() > person.reversal_s + 0.1
    assert gaps.std() > 0.02
    # the friction force rests near zero during a dwell (|F| < 15 % of sliding) while the
    # normal force stays on
    t, ft = cell(frames, FX, frames.timestamp[0] - (truth.first_frame_s or 0.0))
    longest = int(np.argmax(gaps))
    mid = 0.5 * (slides[longest, 1] + slides[longest + 1, 0])
    near = np.abs(t - mid) < 0.02
    sliding = inside(t, truth.steady, margin=0.05)
    assert np.median(np.abs(ft[near])) < 0.2 * np.median(np.abs(ft[sliding]))


def test_lift_offs_take_both_forces_to_zero_and_are_not_steady_sliding():
    person = SubjectParams(lifts_per_min=12.0, lift_s=0.5)
    cfg = TrialConfig(duration_s=20.0, noise_N=0.0, seed=8)
    frames, truth = simulate_trial(person, cfg)
    assert truth.lifted and truth.contact_lost
    t, fn = cell(frames, FZ, cfg.start_time + cfg.latency_s)
    lifted = inside(t, truth.lifted, margin=0.01)
    assert lifted.any() and np.abs(fn[lifted]).max() < 1e-4
    for a, b, _, _ in truth.steady:  # steady sliding never overlaps a lift-off
        for la, lb in truth.contact_lost:
            assert b <= la + 1e-9 or a >= lb - 1e-9
    for (la, lb), (ca, cb) in zip(truth.lifted, truth.contact_lost, strict=True):
        assert la == pytest.approx(ca + CONTACT_RAMP_S) and lb == pytest.approx(
            cb - CONTACT_RAMP_S)


@settings(deadline=None)
@given(seed=st.integers(0, 10_000), offset=st.floats(0.001, 0.2), drift=st.floats(0.0, 0.05),
       duration=st.floats(4.0, 60.0))
def test_realistic_rig_draws_within_its_ranges(seed, offset, drift, duration):
    cfg = realistic_rig(TrialConfig(duration_s=duration, seed=seed), offset_N=offset,
                        drift_N=drift)
    assert cfg.tare_s == pytest.approx(min(1.5, duration / 2))
    for p in ("fz", "fx"):
        zero = CellZero(getattr(cfg, f"{p}_offset_N"), getattr(cfg, f"{p}_drift_N_per_s"),
                        getattr(cfg, f"{p}_thermal_N"), cfg.thermal_time_s)
        assert abs(zero.offset_N) <= offset
        moved = float(zero.offset(duration) - zero.offset(0.0))
        assert abs(moved) <= drift + 1e-12
        assert getattr(cfg, f"{p}_hum_N") == 0.01
    assert cfg.crosstalk == ((1.0, 0.0), (0.0, 1.0))
    assert realistic_rig(TrialConfig(duration_s=duration, seed=seed), offset_N=offset,
                         drift_N=drift) == cfg  # the seed decides


def test_bad_imperfections_name_their_key():
    with pytest.raises(ConfigError, match="crosstalk"):
        TrialConfig(crosstalk=((1.0, 1.0), (1.0, 1.0)))
    with pytest.raises(ConfigError, match="tare_s"):
        TrialConfig(duration_s=2.0, tare_s=2.0)
    with pytest.raises(ConfigError, match="fz_offset_N"):
        TrialConfig(fz_offset_N=float("nan"))
    with pytest.raises(ConfigError, match="lifts_per_min"):
        SubjectParams(lifts_per_min=-1.0)


def test_cli_simulates_a_real_rig_by_default_and_an_ideal_one_on_request(tmp_path):
    study = tmp_path / "st"
    assert main(["simulate", "--study", str(study), "--trial", "real", "--duration", "6",
                 "--seed", "5"]) == 0
    assert main(["simulate", "--study", str(study), "--trial", "ideal", "--duration", "6",
                 "--ideal"]) == 0
    assert main(["simulate", "--study", str(study), "--trial", "set", "--duration", "6",
                 "--offsets", "0.02", "-0.01", "--hum", "0", "--tare-s", "2",
                 "--crosstalk", "0.01", "0.02", "--lifts-per-min", "0"]) == 0
    real = read_sidecar(study / "P01" / "real.json", default_subject="P01")
    ideal = read_sidecar(study / "P01" / "ideal.json", default_subject="P01")
    given = read_sidecar(study / "P01" / "set.json", default_subject="P01")
    sim = real.extra["simulation"]
    assert real.extra["tare_s"] == 1.5 and sim["lifted"][0] == [0.0, 1.5]
    assert 0 < abs(sim["cells"]["normal"]["offset_N"]) <= 0.05
    assert sim["cells"]["tangential"]["hum_N"] == 0.01
    assert sim["subject"]["dwell_s"] > 0
    sim = ideal.extra["simulation"]
    assert ideal.extra["tare_s"] == 0.0 and sim["lifted"] == []
    assert all(v == 0 for c in sim["cells"].values()
               for k, v in c.items() if k.endswith("_N") or k.endswith("_per_s"))
    sim = given.extra["simulation"]
    assert sim["cells"]["normal"]["offset_N"] == 0.02
    assert sim["cells"]["tangential"]["offset_N"] == -0.01
    assert sim["cells"]["normal"]["hum_N"] == 0.0 and given.extra["tare_s"] == 2.0
    assert sim["crosstalk"] == [[1.0, 0.01], [0.02, 1.0]]
    json.dumps(sim)  # the truth is plain JSON


def test_cli_sets_the_subjects_model_and_the_force_follows_the_drive_frequency(tmp_path):
    """--set r_g=... (any model parameter): a leaky gap loses the force at low frequency,
    as the model under that drive says."""
    from evtribo import model

    study = tmp_path / "st"
    for trial, freq in (("f20", "20"), ("f10k", "10000")):
        assert main(["simulate", "--study", str(study), "--trial", trial, "--duration", "6",
                     "--ideal", "--condition", "on", "--amplitude", "100", "--frequency",
                     freq, "--set", "r_g=80", "--set", "E_star=50e3"]) == 0
    sims = {t: read_sidecar(study / "P01" / f"{t}.json", default_subject="P01")
            .extra["simulation"] for t in ("f20", "f10k")}
    assert sims["f20"]["subject"]["model"] == {"r_g": 80.0, "E_star": 50e3}
    params = model.TABLE_1.with_values(r_g=80.0, E_star=50e3)
    for trial, freq in (("f20", 20.0), ("f10k", 1e4)):
        sim = sims[trial]
        assert sim["electrostatic_force_mean_N"] == pytest.approx(float(
            model.electrostatic_force_drive(sim["normal_force_on_N"], 100.0, freq,
                                            "square", params)), rel=0.02)
    assert sims["f20"]["electrostatic_force_mean_N"] < 0.2 * sims["f10k"][
        "electrostatic_force_mean_N"]
    assert main(["simulate", "--study", str(study), "--trial", "bad", "--set", "r_q=1"]) == 2
