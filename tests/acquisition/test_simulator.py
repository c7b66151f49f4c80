"""The simulated rig: frames, clocks, physics against the model, streaming, study folders."""

from __future__ import annotations

import dataclasses
import json
import re
import threading
import time

import can
import cantools
import numpy as np
import pytest

from evtribo.acquisition.simulator import (
    DEFAULT_DBC,
    Simulator,
    SubjectParams,
    TrialConfig,
    simulate_study,
    simulate_trial,
)
from evtribo.acquisition.simulator.encode import pack_signals
from evtribo.acquisition.simulator.study import write_trial
from evtribo.canlog.io import read_frames
from evtribo.cli import main
from evtribo.errors import ConfigError, OutputExistsError
from evtribo.model import TABLE_1, electrostatic_force
from evtribo.study import discover_trials, read_sidecar, read_study_toml

DB = cantools.database.load_file(str(DEFAULT_DBC))
FZ, FX, HV = 0x0C1, 0x0C2, 0x1A0


def decode(frames, frame_id, names):
    """Signals of every frame with *frame_id*, decoded by cantools (not by our packer)."""
    msg = DB.get_message_by_frame_id(frame_id)
    rows = frames.data[frames.arbitration_id == frame_id]
    decoded = [msg.decode(bytes(r[: msg.length]), decode_choices=False) for r in rows]
    ts = frames.timestamp[frames.arbitration_id == frame_id]
    return ts, {n: np.array([d[n] for d in decoded], dtype=float) for n in names}


def short(**kw):
    base = {"duration_s": 6.0, "fz_rate_Hz": 500.0, "fx_rate_Hz": 1000.0}
    base.update(kw)
    return TrialConfig(**base)


def test_same_seed_same_frames_other_seed_other_frames():
    a, ta = simulate_trial(config=short(seed=3))
    b, tb = simulate_trial(config=short(seed=3))
    c, _ = simulate_trial(config=short(seed=4))
    np.testing.assert_array_equal(a.timestamp, b.timestamp)
    np.testing.assert_array_equal(a.data, b.data)
    np.testing.assert_array_equal(a.arbitration_id, b.arbitration_id)
    assert ta.to_dict() == tb.to_dict()
    assert not np.array_equal(a.data[:100], c.data[:100])


def test_thirty_seconds_at_two_kilohertz_per_cell():
    # Its speed (about 0.05 s for these 121,500 frames) is measured by benchmarks/analyze.py.
    cfg = TrialConfig(duration_s=30.0, fz_rate_Hz=2000.0, fx_rate_Hz=2000.0, hv_rate_Hz=50.0)
    frames, _ = simulate_trial(config=cfg)
    assert len(frames) == pytest.approx(30 * (2000 + 2000 + 50), rel=1e-3)


def test_frames_are_in_reception_order_with_the_rig_ids():
    frames, truth = simulate_trial(config=short())
    assert np.all(np.diff(frames.timestamp) >= 0)
    ids, counts = np.unique(frames.arbitration_id, return_counts=True)
    assert list(ids) == [FZ, FX, HV]
    assert dict(zip(ids.tolist(), counts.tolist(), strict=True)) == {
        FZ: truth.nodes["FzCell"]["frames"], FX: truth.nodes["FxCell"]["frames"],
        HV: truth.nodes["HvStatus"]["frames"]}
    assert frames.channel == "vcan0"
    assert not frames.is_extended.any() and (frames.dlc == 8).all()


def test_cantools_decodes_what_the_packer_encodes_including_motorola_and_offsets():
    rng = np.random.default_rng(0)
    msg = DB.get_message_by_name("FzCell")
    fz = rng.uniform(-80, 80, 500)
    temp = rng.uniform(-300, 300, 500)
    data = pack_signals(msg, {"Fz": fz, "FzTemp": temp, "FzCounter_raw": np.arange(500) % 256},
                        500)
    for i in range(500):
        d = msg.decode(bytes(data[i]))
        assert d["Fz"] == pytest.approx(fz[i], abs=0.5e-5 + 1e-12)
        assert d["FzTemp"] == pytest.approx(temp[i], abs=0.005 + 1e-9)
        assert d["FzCounter"] == i % 256
    dbc = """VERSION ""
BO_ 2566844926 Mixed: 8 Node
 SG_ A : 7|12@0- (0.5,-10) [-1034|1013.5] "" Node
 SG_ B : 11|20@0+ (0.001,2) [2|1050.575] "" Node
 SG_ C : 48|10@1- (1,0) [-512|511] "" Node
 SG_ D : 63|6@0+ (1,0) [0|63] "" Node
"""
    mixed = cantools.database.load_string(dbc, database_format="dbc").get_message_by_name("Mixed")
    vals = {"A": rng.uniform(-1000, 1000, 200), "B": rng.uniform(2, 1000, 200),
            "C": rng.integers(-512, 512, 200), "D": rng.integers(0, 64, 200)}
    data = pack_signals(mixed, vals, 200)
    for i in range(200):
        d = mixed.decode(bytes(data[i]))
        assert d["A"] == pytest.approx(vals["A"][i], abs=0.25 + 1e-9)
        assert d["B"] == pytest.approx(vals["B"][i], abs=0.0005 + 1e-9)
        assert d["C"] == vals["C"][i] and d["D"] == vals["D"][i]
        assert bytes(data[i]) == mixed.encode({k: d[k] for k in d})


def test_decoded_values_follow_the_physics_and_quantisation():
    frames, truth = simulate_trial(config=short(noise_N=0.0))
    _, fz = decode(frames, FZ, ["Fz", "FzStatus"])
    raw = fz["Fz"] / 1e-5
    np.testing.assert_allclose(raw, np.rint(raw), atol=1e-6)  # 24-bit ADC steps of 10 uN
    assert abs(fz["Fz"].mean() / truth.subject.normal_force_N - 1) < 0.15
    assert (fz["FzStatus"] == 0).all()
    _, hv = decode(frames, HV, ["HvAmp", "HvFreq", "HvWave"])
    assert (hv["HvAmp"] == 140.0).all() and (hv["HvFreq"] == 10_000.0).all()
    assert (hv["HvWave"] == 1).all()  # "square" in the DBC's value table


@pytest.mark.parametrize(("frame_id", "signal", "modulo"),
                         [(FZ, "FzCounter", 256), (FX, "FxCounter", 256),
                          (HV, "HvCounter", 16)])
def test_counters_increment_modulo_their_width(frame_id, signal, modulo):
    frames, _ = simulate_trial(config=short())
    _, d = decode(frames, frame_id, [signal])
    steps = np.diff(d[signal]) % modulo
    assert (steps == 1).all()
    if modulo == 256:
        assert d[signal].max() == 255  # it wraps


def test_dropped_frames_leave_counter_gaps_that_the_truth_counts():
    frames, truth = simulate_trial(config=short(drop_probability=0.01, seed=5))
    for frame_id, name, signal in ((FZ, "FzCell", "FzCounter"), (FX, "FxCell", "FxCounter")):
        _, d = decode(frames, frame_id, [signal])
        missing = int(((np.diff(d[signal]) - 1) % 256).sum())
        assert missing == truth.nodes[name]["dropped"] > 0


def test_each_cell_runs_at_its_own_rate_and_clock_drift():
    cfg = short(duration_s=10.0, fz_rate_Hz=1000.0, fx_rate_Hz=1800.0, fz_ppm=300.0,
                fx_ppm=-500.0)
    frames, truth = simulate_trial(config=cfg)
    for frame_id, rate, ppm in ((FZ, 1000.0, 300.0), (FX, 1800.0, -500.0)):
        ts, d = decode(frames, frame_id, ["FzCounter" if frame_id == FZ else "FxCounter"])
        counter = next(iter(d.values()))
        index = np.concatenate([[0], np.cumsum(np.diff(counter) % 256)])
        slope = np.polyfit(index, ts - ts[0], 1)[0]
        assert 1 / slope == pytest.approx(rate * (1 + ppm * 1e-6), rel=2e-6)
        assert abs(1 / slope / rate - 1) == pytest.approx(abs(ppm) * 1e-6, rel=0.05)
        # reception jitter: spread around the line, always after the sample
        resid = ts - ts[0] - slope * index
        assert 1e-5 < resid.std() < 5e-4
    assert truth.nodes["FzCell"]["rate_Hz"] == pytest.approx(1000.3)


def test_hvstatus_follows_the_on_off_schedule():
    cfg = short(duration_s=9.0, on_s=1.0, off_s=2.0, start_on=True, hv_rate_Hz=80.0)
    frames, truth = simulate_trial(config=cfg)
    assert truth.schedule == [(0.0, 1.0, True), (1.0, 3.0, False), (3.0, 4.0, True),
                              (4.0, 6.0, False), (6.0, 7.0, True), (7.0, 9.0, False)]
    ts, hv = decode(frames, HV, ["HvOn"])
    t = ts - cfg.start_time
    checked = 0
    for a, b, on in truth.schedule:
        inside = (t > a + 0.01) & (t < b)
        assert (hv["HvOn"][inside] == on).all()
        checked += int(inside.sum())
    assert checked > 0.95 * len(t)


def test_whole_trial_conditions():
    for condition, expected in (("on", 1), ("off", 0)):
        frames, truth = simulate_trial(config=short(condition=condition, duration_s=2.0))
        _, hv = decode(frames, HV, ["HvOn"])
        assert (hv["HvOn"] == expected).all()
        assert truth.schedule == [(0.0, 2.0, bool(expected))]
    assert truth.electrostatic_force_N is None and truth.normal_force_on_N is None


def _forces_on_fx_times(frames, start):
    tz, fz = decode(frames, FZ, ["Fz"])
    tx, fx = decode(frames, FX, ["Fx"])
    return tx - start, fx["Fx"], np.interp(tx, tz, fz["Fz"])


def _in_slides(t, truth, margin=0.05):
    mask = np.zeros(t.shape, bool)
    for a, b, _ in truth.slides:
        mask |= (t > a + margin) & (t < b - margin)
    return mask


def test_truth_is_the_model_and_the_frames_carry_it():
    subject = SubjectParams(mu=0.6, h_L=4e-6, normal_force_N=0.8)
    cfg = short(duration_s=16.0, amplitude_V=120.0, seed=2)
    frames, truth = simulate_trial(subject, cfg)
    params = dataclasses.replace(TABLE_1, mu=0.6, h_L=4e-6)
    assert truth.mu == 0.6
    assert truth.electrostatic_force_N == pytest.approx(
        float(electrostatic_force(truth.normal_force_on_N, 120.0, params)), rel=1e-12)
    assert truth.electrostatic_force_mean_N == pytest.approx(truth.electrostatic_force_N,
                                                             rel=0.02)
    # what the analysis does, crudely: F_el = mean(|F_t| / mu - F_n) over ON slides
    t, ft, fn = _forces_on_fx_times(frames, cfg.start_time)
    slide = _in_slides(t, truth)
    on = np.zeros(t.shape, bool)
    for a, b, is_on in truth.schedule:
        on |= is_on & (t > a + 0.02) & (t < b)
    inferred_on = np.mean(np.abs(ft[slide & on]) / truth.mu - fn[slide & on])
    inferred_off = np.mean(np.abs(ft[slide & ~on]) / truth.mu - fn[slide & ~on])
    assert inferred_on == pytest.approx(truth.electrostatic_force_N, rel=0.05)
    assert abs(inferred_off) < 0.02 * truth.electrostatic_force_N
    # the friction force changes sign between slides and passes through zero
    assert ft.max() > 0.4 and ft.min() < -0.4
    assert np.any(np.abs(ft) < 0.02)


@pytest.mark.parametrize("m", [0.67, 0.8, 1.0])
def test_friction_grows_as_the_load_to_the_power_m_and_the_voltage_loads_the_contact(m):
    # F_t = mu W0 (W / W0)^m with W = F_n + F_el (Adams et al. 2013): a press wandering
    # over 0.3-0.9 N shows m in the OFF slides, and the law inverted gives F_el ON
    subject = SubjectParams(mu=0.5, h_L=4e-6, normal_force_N=0.6, force_drift=0.25,
                            drift_time_s=2.0, friction_exponent=m)
    cfg = short(duration_s=16.0, amplitude_V=140.0, noise_N=0.0, seed=5)
    frames, truth = simulate_trial(subject, cfg)
    assert truth.friction["exponent"] == m and truth.friction["reference_load_N"] == 0.6
    t, ft, fn = _forces_on_fx_times(frames, cfg.start_time)
    on, near_on = np.zeros(t.shape, bool), np.zeros(t.shape, bool)
    for a, b, is_on in truth.schedule:
        on |= is_on & (t > a + 0.02) & (t < b)
        near_on |= is_on & (t > a - 0.02) & (t < b + 0.02)
    use = _in_slides(t, truth) & (fn > 0.1)
    off = use & ~near_on
    slope = np.polyfit(np.log(fn[off]), np.log(np.abs(ft[off])), 1)[0]
    assert slope == pytest.approx(m, abs=0.02)
    load = 0.6 * (np.abs(ft) / (0.5 * 0.6)) ** (1 / m)
    assert np.mean(load[use & on] - fn[use & on]) == pytest.approx(
        truth.electrostatic_force_mean_N, rel=0.05)
    # the truth's coefficient is F_t / F_n at each instant's press, without the voltage
    mid = [(a + b) / 2 for a, b, _ in truth.slides if b - a > 0.4]
    quiet = [c for c in mid if any(not is_on and a + 0.1 < c < b - 0.1
                                   for a, b, is_on in truth.schedule)]
    assert len(quiet) >= 3
    for c in quiet:
        near = np.abs(t - c) < 0.05
        assert truth.mu_between(c - 0.05, c + 0.05) == pytest.approx(
            np.mean(np.abs(ft[near]) / fn[near]), rel=0.01)


def test_normal_force_drifts_by_a_few_percent_around_the_target():
    subject = SubjectParams(normal_force_N=1.0, force_drift=0.06)
    frames, _ = simulate_trial(subject, short(duration_s=30.0, noise_N=0.0, seed=9))
    _, fz = decode(frames, FZ, ["Fz"])
    rel = fz["Fz"] / 1.0 - 1
    assert abs(rel.mean()) < 0.06
    assert 0.015 < rel.std() < 0.12


def test_sine_trial_modulates_friction_at_twice_the_drive_frequency_during_on():
    subject = SubjectParams(stroke_length_m=0.5, normal_force_N=0.5)  # one long slide
    cfg = short(duration_s=8.0, waveform="sine", frequency_Hz=10.0, on_s=4.0, off_s=4.0,
                fx_rate_Hz=1000.0)
    frames, truth = simulate_trial(subject, cfg)
    assert truth.friction_modulation_Hz == 20.0
    t, ft, _ = _forces_on_fx_times(frames, cfg.start_time)
    slide = _in_slides(t, truth)
    def peak(mask):
        x = np.abs(ft[mask])
        x = x - np.polyval(np.polyfit(t[mask], x, 2), t[mask])
        grid = np.arange(t[mask][0], t[mask][-1], 1e-3)
        spectrum = np.abs(np.fft.rfft(np.interp(grid, t[mask], x) * np.hanning(grid.size)))
        freqs = np.fft.rfftfreq(grid.size, 1e-3)
        band = freqs > 2
        return freqs[band][np.argmax(spectrum[band])], spectrum[band].max()
    on_mask = slide & (t > 4.2) & (t < 8.0)
    off_mask = slide & (t > 0.2) & (t < 3.9)
    f_on, p_on = peak(on_mask)
    _, p_off = peak(off_mask)
    assert f_on == pytest.approx(20.0, abs=0.5)
    assert p_on > 20 * p_off


def test_foreign_traffic_uses_other_ids():
    frames, truth = simulate_trial(config=short(foreign_rate_Hz=200.0, duration_s=3.0))
    foreign = ~np.isin(frames.arbitration_id, [FZ, FX, HV])
    assert foreign.sum() == truth.foreign_frames > 300
    assert frames.is_extended[foreign].any() and not frames.is_extended[~foreign].any()
    assert np.all(np.diff(frames.timestamp) >= 0)


@pytest.mark.parametrize(("kwargs", "key"), [({"waveform": "triangle"}, "TrialConfig.waveform"),
                                             ({"amplitude_V": -1.0}, "TrialConfig.amplitude_V"),
                                             ({"fz_rate_Hz": 0.0}, "TrialConfig.fz_rate_Hz")])
def test_bad_settings_name_the_key(kwargs, key):
    with pytest.raises(ConfigError) as err:
        TrialConfig(**kwargs)
    assert err.value.key == key


def test_streaming_on_a_virtual_bus_delivers_every_frame():
    cfg = short(fz_rate_Hz=1000.0, fx_rate_Hz=2000.0, foreign_rate_Hz=50.0, seed=11)
    offline, _ = simulate_trial(config=dataclasses.replace(cfg, duration_s=1.5))
    channel = f"sim-test-{time.monotonic_ns()}"
    rx = can.Bus(interface="virtual", channel=channel)
    tx = can.Bus(interface="virtual", channel=channel)
    received = []
    stop = threading.Event()

    def receive():
        while True:
            msg = rx.recv(0.3)
            if msg is None:
                if stop.is_set():
                    return
                continue
            received.append(msg)

    reader = threading.Thread(target=receive)
    reader.start()
    try:
        before = time.time()
        stats = Simulator(config=cfg).run(tx, duration=1.5)
    finally:
        stop.set()
        reader.join()
        tx.shutdown()
        rx.shutdown()
    assert stats.sent == stats.generated == len(offline) == len(received)
    assert stats.not_sent == 0
    # paced: no frame left before its time (the virtual bus stamps each when it is sent);
    # how late a busy machine sent them is not asserted
    due = offline.timestamp - cfg.start_time
    sent_at = np.array([m.timestamp for m in received]) - before
    assert due[-1] > 1.4 and np.all(sent_at >= due - 1e-3)
    got_ids = np.array([m.arbitration_id for m in received])
    np.testing.assert_array_equal(got_ids, offline.arbitration_id)
    got = [bytes(m.data).ljust(8, b"\0") for m in received]
    assert got == [bytes(r) for r in offline.data]
    fz_counters = np.array([m.data[7] for m in received if m.arbitration_id == FZ])
    assert (np.diff(fz_counters) % 256 == 1).all()


def test_stop_event_ends_a_stream_early():
    channel = f"sim-stop-{time.monotonic_ns()}"
    bus = can.Bus(interface="virtual", channel=channel)
    rx = can.Bus(interface="virtual", channel=channel)
    stop = threading.Event()

    def stop_once_sending():  # once the rig's first frame is out, however late that is
        rx.recv(timeout=600)
        stop.set()

    listener = threading.Thread(target=stop_once_sending, daemon=True)
    listener.start()
    try:
        stats = Simulator().run(bus, stop_event=stop)  # returns: stopped, not run for 24 h
    finally:
        listener.join(600)
        bus.shutdown()
        rx.shutdown()
    assert stats.sent > 0 and stats.not_sent == 0
    assert stats.generated == stats.sent  # what was made but not yet due is not counted


def test_simulate_study_writes_a_study_folder(tmp_path):
    cfg = short(duration_s=2.0, start_on=True, on_s=1.0, off_s=1.0)
    truths = simulate_study(tmp_path / "s", [SubjectParams(name="P01"),
                                             SubjectParams(name="P02", mu=0.3)],
                            amplitudes=(60.0, 140.0), config=cfg)
    root = tmp_path / "s"
    config = read_study_toml(root / "study.toml")
    assert (root / config["rig"]["dbc"]).read_text() == DEFAULT_DBC.read_text()
    assert config["rig"]["normal_force"] == "FzCell.Fz"
    trials, _ = discover_trials(root)
    assert sorted(t.key for t in trials) == ["P01/run-01", "P01/run-02", "P01/run-03",
                                              "P02/run-01", "P02/run-02", "P02/run-03"]
    side = read_sidecar(root / "P02" / "run-03.json", default_subject="P02")
    assert (side.waveform, side.frequency_Hz, side.amplitude_V) == ("sine", 10.0, 140.0)
    assert side.extra["simulation"]["mu"] == 0.3
    assert truths["P02"]["run-03"].friction_modulation_Hz == 20.0
    lines = (root / "P01" / "run-01.log").read_text().splitlines()
    pattern = re.compile(r"^\(\d+\.\d{6}\) vcan0 (0C1|0C2|1A0)#[0-9A-F]{16}$")
    assert all(pattern.match(line) for line in lines)
    first = read_sidecar(root / "P01" / "run-01.json", default_subject="P01")
    assert len(lines) == first.extra["frames"] > 2000
    back, _ = read_frames(root / "P01" / "run-01.log")
    again, _ = simulate_trial(SubjectParams(name="P01"), dataclasses.replace(
        cfg, seed=0, amplitude_V=60.0))
    np.testing.assert_array_equal(back.data, again.data)
    np.testing.assert_allclose(back.timestamp, again.timestamp, atol=1e-6)
    with pytest.raises(OutputExistsError):
        simulate_study(root, [SubjectParams(name="P01")], amplitudes=(60.0,), config=cfg)


# -- the command line ----------------------------------------------------------------------
def test_cli_writes_a_trial_to_a_study(tmp_path, capsys):
    code = main(["simulate", "--study", str(tmp_path / "st"), "--subject", "P07", "--trial",
                 "sine-1", "--duration", "1.5", "--waveform", "sine", "--frequency", "10",
                 "--mu", "0.4", "--air-gap", "6e-6", "--condition", "on"])
    assert code == 0
    side = read_sidecar(tmp_path / "st" / "P07" / "sine-1.json", default_subject="P07")
    assert (side.waveform, side.frequency_Hz, side.condition) == ("sine", 10.0, "on")
    assert side.extra["simulation"]["subject"]["h_L"] == 6e-6
    assert "frames" in capsys.readouterr().out
    assert main(["simulate", "--study", str(tmp_path / "st"), "--subject", "P07", "--trial",
                 "sine-1", "--duration", "1"]) == 2  # exists: needs --force


@pytest.mark.parametrize("leftover", ["run-01.log.part", "run-01.json"])
def test_simulated_trial_never_overwrites_a_partial_log_or_sidecar_without_force(
        tmp_path, capsys, leftover):
    """A killed recording's ``.log.part``, or a sidecar alone, is a trial: left untouched
    without --force, and with it (simulate replaces only a trial it simulated)."""
    folder = tmp_path / "st" / "P01"
    folder.mkdir(parents=True)
    (folder / leftover).write_text("precious\n")
    argv = ["simulate", "--study", str(tmp_path / "st"), "--subject", "P01", "--trial",
            "run-01", "--duration", "0.5"]
    assert main(argv) == 2
    assert "--force" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == [leftover]
    assert (folder / leftover).read_text() == "precious\n"
    assert main([*argv, "--force"]) == 2
    assert "replaces only a trial it simulated" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == [leftover]
    assert (folder / leftover).read_text() == "precious\n"


@pytest.mark.parametrize(("argv", "needle"), [
    (["--amplitude", "-5"], "--amplitude"),
    (["--fz-rate", "0"], "--fz-rate"),
    (["--pty", "--interface", "virtual"], "choose one of"),
    (["--target-force", "nan"], "--target-force"),
])
def test_cli_bad_options_exit_2_naming_the_option(tmp_path, capsys, argv, needle):
    prefix = [] if "--pty" in argv else ["--study", str(tmp_path)]
    assert main(["simulate", *prefix, *argv]) == 2
    assert needle in capsys.readouterr().err


def test_cli_streams_on_a_virtual_bus():
    channel = f"sim-cli-{time.monotonic_ns()}"
    rx = can.Bus(interface="virtual", channel=channel)
    try:
        code = main(["simulate", "--interface", "virtual", "--channel", channel,
                     "--duration", "0.5", "--fz-rate", "400", "--fx-rate", "400"])
        got = []
        while (msg := rx.recv(0.05)) is not None:
            got.append(msg.arbitration_id)
    finally:
        rx.shutdown()
    assert code == 0
    assert got.count(FZ) == pytest.approx(200, abs=3) and got.count(FX) == pytest.approx(200,
                                                                                           abs=3)


def test_cli_opens_its_bus_as_acquire_does_with_bus_options(capsys):
    """--bus-option reaches the python-can bus (here: the virtual bus receives its own
    frames), and a bus python-can refuses is a named usage error (exit 2)."""
    channel = f"sim-opt-{time.monotonic_ns()}"
    got = []
    original = can.Bus

    def spy(*args, **kwargs):
        bus = original(*args, **kwargs)
        got.append(kwargs)
        return bus

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(can, "Bus", spy)
        code = main(["simulate", "--interface", "virtual", "--channel", channel,
                     "--duration", "0.2", "--fz-rate", "100", "--fx-rate", "100",
                     "--bus-option", "receive_own_messages=True"])
    assert code == 0
    assert got == [{"receive_own_messages": True, "interface": "virtual", "channel": channel}]
    assert main(["simulate", "--interface", "no_such_interface", "--duration", "0.1"]) == 2
    assert "'--interface'" in capsys.readouterr().err
    assert main(["simulate", "--interface", "virtual", "--bus-option", "novalue",
                 "--duration", "0.1"]) == 2
    assert "'--bus-option'" in capsys.readouterr().err


@pytest.mark.parametrize("recording", ["from a bus", "cut short", "log without sidecar"])
def test_simulate_force_never_replaces_a_recording(recording, tmp_path, capsys):
    """``simulate --study --force`` replaces a trial it simulated, never a recording: a log
    recorded from a bus (its sidecar names the bus), one cut short (``.log.part``), or a log
    without a sidecar that says it was simulated."""
    study = tmp_path / "study"
    argv = ["simulate", "--study", str(study), "--subject", "P01", "--trial", "run-01",
            "--duration", "1", "--force"]
    assert main(argv) == 0  # a simulated trial: --force replaces it
    assert main([*argv, "--seed", "5"]) == 0
    log, sidecar = study / "P01" / "run-01.log", study / "P01" / "run-01.json"
    if recording == "from a bus":
        doc = json.loads(sidecar.read_text())
        doc.pop("simulation")
        doc["bus"] = {"interface": "socketcan", "channel": "can0"}
        sidecar.write_text(json.dumps(doc))
    elif recording == "cut short":
        log.with_name("run-01.log.part").write_bytes(log.read_bytes()[:1000])
    else:
        sidecar.unlink()
    before = {p.name: p.read_bytes() for p in (study / "P01").iterdir()}
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "replaces only a trial it simulated" in err and "--force included" in err, err
    assert {p.name: p.read_bytes() for p in (study / "P01").iterdir()} == before


@pytest.mark.parametrize("changes", [{}, {"fx_offset_N": 0.01}, {"fx_drift_N_per_s": 1e-4},
                                     {"crosstalk": ((1.0, 0.0), (0.02, 1.0))}])
def test_a_new_study_of_an_exact_tangential_cell_says_its_zero_is_known(tmp_path, changes):
    # an exact cell's zero is known, as a calibrated rig's is; a cell with an offset, a drift
    # or cross-talk leaves it to the analysis to find
    cfg = dataclasses.replace(TrialConfig(duration_s=2.0, seed=1), **changes)
    write_trial(tmp_path / "st", "run-01", SubjectParams(name="P01"), cfg)
    table = read_study_toml(tmp_path / "st" / "study.toml")["rig"]
    if changes:
        assert "calibration" not in table
    else:
        assert table["calibration"] == {"tangential_offset_N": 0.0}
        text = (tmp_path / "st" / "study.toml").read_text()
        assert "# The simulated tangential cell reads exactly zero at rest" in text
