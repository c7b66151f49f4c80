"""The held-out generator itself: its files follow the study format, its truth is its model.

Nothing here runs evtribo's analysis: the logs are read by ``evtribo inspect`` and by
python-can, decoded with cantools, and the truth is held against the model's parameters.
"""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import can
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import evtribo
from heldout import canframes, physics
from heldout.config import Drive, Electrostatic, Friction, Press, StudyConfig
from heldout.generator import generate
from heldout.scenarios import SCENARIOS
from heldout.trial import Subject, TrialSpec, simulate
from heldout.truth import window_truth

EVTRIBO = str(Path(sys.executable).with_name("evtribo"))
SMALL = replace(StudyConfig(), subjects=2, trial_s=7.0, drive=Drive(amplitudes_V=(80.0, 140.0)))


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    dest = tmp_path_factory.mktemp("heldout") / "small"
    return dest, generate(dest, SMALL, seed=3)


def _frames(log: Path) -> list[can.Message]:
    with can.CanutilsLogReader(log) as reader:
        return list(reader)


@given(st.data())
def test_the_packer_is_cantools_encode(data: st.DataObject) -> None:
    db = canframes.database()
    msg = data.draw(st.sampled_from(db.messages))
    values = {}
    for sig in msg.signals:
        raw_lo = -(1 << (sig.length - 1)) if sig.is_signed else 0
        raw_hi = (1 << (sig.length - 1)) - 1 if sig.is_signed else (1 << sig.length) - 1
        raw = data.draw(st.integers(raw_lo, raw_hi))
        values[sig.name] = raw * sig.scale + sig.offset
    packed = canframes.pack(msg, {k: np.array([v]) for k, v in values.items()}, 1)
    assert bytes(packed[0]) == msg.encode(values, scaling=True, strict=False)


@given(frames=st.lists(st.tuples(st.integers(0, 2**31 - 1), st.booleans(),
                                 st.binary(max_size=8),
                                 st.integers(1_700_000_000_000_000, 1_900_000_000_000_000)),
                       min_size=1, max_size=20))
def test_candump_lines_read_back_by_python_can(frames, tmp_path_factory) -> None:
    ids = np.array([f[0] & (0x1FFFFFFF if f[1] else 0x7FF) for f in frames])
    ext = np.array([f[1] for f in frames])
    payload = np.zeros((len(frames), 8), dtype=np.uint8)
    for i, f in enumerate(frames):
        payload[i, : len(f[2])] = np.frombuffer(f[2], dtype=np.uint8)
    dlc = np.array([len(f[2]) for f in frames])
    stamps = np.array([f[3] for f in frames], dtype=np.int64)
    log = tmp_path_factory.mktemp("lines") / "x.log"
    log.write_bytes(canframes.candump_lines(stamps, ids, ext, payload, dlc))
    back = _frames(log)
    assert [m.arbitration_id for m in back] == ids.tolist()
    assert [m.is_extended_id for m in back] == ext.tolist()
    assert [bytes(m.data) for m in back] == [f[2] for f in frames]
    assert [round(m.timestamp * 1e6) for m in back] == stamps.tolist()


def test_the_study_folder_follows_the_format(small) -> None:
    dest, truth = small
    study = evtribo.open_study(dest / "study")
    assert sorted(study.subjects) == ["P01", "P02"]
    assert len(study.trials) == len(truth["trials"]) == 4
    for record in truth["trials"]:
        side = json.loads((dest / "study" / record["subject"] / f"{record['trial']}.json")
                          .read_text())
        assert side["subject"] == record["subject"]
        assert side["amplitude_V"] == record["amplitude_V"]
        assert side["condition"] == "alternating"


def test_evtribo_inspect_reads_every_frame(small) -> None:
    dest, truth = small
    record = truth["trials"][0]
    log = dest / "study" / record["subject"] / f"{record['trial']}.log"
    done = subprocess.run([EVTRIBO, "inspect", str(log), "--dbc",
                           str(dest / "study" / "rig" / "heldout.dbc")],
                          capture_output=True, text=True, check=True)
    assert f"{record['frames']} frames" in done.stdout
    assert "0 damaged lines" in done.stdout
    assert "(not in the DBC)" in done.stdout  # the heartbeat
    assert "-> normal_force" in done.stdout
    assert "-> tangential_force" in done.stdout


def test_the_dbc_decodes_what_the_truth_says(small) -> None:
    dest, truth = small
    db = canframes.database()
    record = truth["trials"][1]
    frames = _frames(dest / "study" / record["subject"] / f"{record['trial']}.log")
    assert all(np.diff([m.timestamp for m in frames]) >= 0)
    decoded: dict[str, list] = {"PadNormal": [], "PadShear": [], "HvMonitor": []}
    for m in frames:
        if m.arbitration_id == canframes.HEARTBEAT_ID:
            continue
        msg = db.get_message_by_frame_id(m.arbitration_id)
        decoded[msg.name].append((m.timestamp, msg.decode(bytes(m.data))))
    for name, width in (("PadNormal", 256), ("PadShear", 16)):
        seq = np.array([d["Seq"] for _, d in decoded[name]])
        assert np.all(np.diff(seq) % width == 1)  # no frame dropped in the clean study
    status = decoded["HvMonitor"]
    assert {d["Volts"] for _, d in status} == {record["amplitude_V"]}
    assert {str(d["Shape"]) for _, d in status} == {"square"}
    assert {d["Active"] for _, d in status} == {0, 1}
    # the finger is lifted for the tare stretch: the normal cell reads its zero offset
    t0 = record["log_first_stamp_s"]
    lifted = [d["Normal"] for t, d in decoded["PadNormal"] if t - t0 < 1.2]
    assert np.mean(lifted) == pytest.approx(record["normal_offset_N"], abs=0.002)
    pressed = [d["Normal"] for t, d in decoded["PadNormal"] if t - t0 > 3.0]
    assert np.mean(pressed) - record["normal_offset_N"] == pytest.approx(0.5, abs=0.1)


def test_the_paper_model_is_the_papers() -> None:
    # the README's figure for Table 1 at 0.5 N and 140 V: F_el = 0.197 N
    force = physics.paper_force(Electrostatic(), 5e-6, np.array(140.0), np.array(0.5))
    assert float(force) == pytest.approx(0.1972, abs=2e-4)
    # eq. (13): with the external force dominating, F_el goes as U^2 (local exponent ~2.05)
    f = physics.paper_force(Electrostatic(), 5e-6, np.array([100.0, 140.0]), np.full(2, 0.5))
    assert np.log(f[1] / f[0]) / np.log(1.4) == pytest.approx(2.05, abs=0.02)


def test_power_law_truth_is_k_and_n(tmp_path: Path) -> None:
    cfg = replace(SMALL, subjects=3, trial_s=6.0,
                  electrostatic=Electrostatic(model="power", n_sd=0.2),
                  drive=Drive(amplitudes_V=(60.0, 100.0, 140.0)))
    truth = generate(tmp_path / "p", cfg, seed=5)
    for name, s in truth["subjects"].items():
        cells = [c for c in truth["cells"] if c["subject"] == name]
        for c in cells:
            assert c["F_el_N"] == pytest.approx(s["k"] * c["amplitude_V"] ** s["n"], rel=1e-9)
        assert s["exponent"] == pytest.approx(s["n"], abs=1e-9)
        assert s["prefactor_N"] == pytest.approx(s["k"], rel=1e-6)


@given(st.floats(0.6, 1.0), st.floats(0.2, 0.8))
def test_the_friction_law_is_mu_at_the_reference_load(m: float, mu: float) -> None:
    c = physics.friction_prefactor(mu, m, 0.5)
    assert physics.sliding_friction(c, np.array(0.5), m) == pytest.approx(mu * 0.5)
    loads = np.array([0.3, 0.6])
    ratio = physics.sliding_friction(c, loads[1], m) / physics.sliding_friction(c, loads[0], m)
    assert ratio == pytest.approx(2.0**m)


def test_the_contact_carries_the_electrostatic_force() -> None:
    """ON, the friction follows c*(F_n + F_el)^m; OFF, c*F_n^m (steady sliding, no noise)."""
    cfg = replace(SMALL, trial_s=10.0, friction=Friction(
        m=0.7, stroke_scatter=0.0, texture_noise=0.0, trial_spread=0.0),
        electrostatic=Electrostatic(model="power"))
    s = Subject("P01", mu=0.5, c=physics.friction_prefactor(0.5, 0.7, 0.5), asymmetry=0.0,
                weak=False, k=1e-5, n=2.0)
    spec = TrialSpec(s, "run-01", 140.0, "alternating", 1.0, 0.0, 5.0)
    p = simulate(cfg, spec, np.random.default_rng(0))
    # 3 mm of travel since the stroke's reversal and the amplifier's last switch: the pad's
    # pre-sliding (Dahl, 0.5 mm) has settled
    step = np.abs(p.velocity) * cfg.grid_s
    change = np.r_[True, (np.diff(p.on.astype(int)) != 0) | (np.diff(p.stroke) != 0)]
    total = np.cumsum(step)
    since = total - np.maximum.accumulate(np.where(change, total, 0.0))
    steady = (since > 3e-3) & (p.contact >= 0.999) & (np.abs(p.velocity) > 0.02)
    assert steady.sum() > 3000
    expect = s.c * (p.normal + p.electrostatic) ** 0.7
    assert np.abs(p.tangential[steady]) == pytest.approx(expect[steady], rel=0.02)
    assert np.all(p.electrostatic[p.on & (p.contact >= 0.999)] == pytest.approx(0.196))
    assert np.all(p.electrostatic[~p.on] == 0.0)


def test_moisture_rises_with_first_order_kinetics() -> None:
    cfg = replace(SMALL, trial_s=20.0, friction=Friction(stroke_scatter=0.0, texture_noise=0.0))
    s = Subject("P01", mu=0.5, c=0.5, asymmetry=0.0, weak=False, k=1e-5, n=2.0)
    spec = TrialSpec(s, "run-01", 100.0, "off", 1.0, moisture_rise=0.4, moisture_tau_s=6.0)
    p = simulate(cfg, spec, np.random.default_rng(1))
    since = p.t - cfg.cells.tare_s
    expect = 0.5 * (1.0 + 0.4 * (1.0 - np.exp(-since / 6.0)))
    keep = since > 0
    assert p.mu_now[keep] == pytest.approx(expect[keep], rel=1e-9)


def test_the_press_stays_in_its_band_or_visits_its_targets() -> None:
    band = replace(SMALL, trial_s=30.0)
    s = Subject("P01", mu=0.5, c=0.5, asymmetry=0.0, weak=False, k=1e-5, n=2.0)
    spec = TrialSpec(s, "run-01", 100.0, "alternating", 1.0, 0.0, 5.0)
    p = simulate(band, spec, np.random.default_rng(2))
    pressed = p.normal[p.contact >= 0.999]
    assert np.mean(np.abs(pressed - 0.5) <= 0.15) > 0.95
    targets = replace(band, press=Press(mode="targets"))
    p = simulate(targets, spec, np.random.default_rng(2))
    off = p.normal[(~p.on) & (p.contact >= 0.999)]
    for goal in (0.3, 0.6, 0.9):
        assert np.any(np.abs(off - goal) < 0.05)


def test_window_truth_is_the_mean_over_the_window() -> None:
    t = np.arange(100) * 0.01
    trace = {"t_s": t, "bin_s": 0.01, "electrostatic_N": np.where(t < 0.5, 0.1, 0.3)}
    got = window_truth(trace, np.array([0.0, 0.5, 0.25]), np.array([0.5, 1.0, 0.75]))
    assert got == pytest.approx([0.1, 0.3, 0.2])


def test_the_same_seed_writes_the_same_bytes(tmp_path: Path) -> None:
    cfg = replace(SMALL, subjects=1, trial_s=4.0, drive=Drive(amplitudes_V=(100.0,)))
    generate(tmp_path / "a", cfg, seed=9)
    generate(tmp_path / "b", cfg, seed=9)
    for log in (tmp_path / "a" / "study").rglob("*.log"):
        twin = tmp_path / "b" / log.relative_to(tmp_path / "a")
        assert log.read_bytes() == twin.read_bytes()


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_scenario_writes_a_study(name: str, tmp_path: Path) -> None:
    cfg = replace(SCENARIOS[name], subjects=1, trial_s=5.0,
                  drive=replace(SCENARIOS[name].drive, amplitudes_V=(120.0,), phase_s=1.0))
    truth = generate(tmp_path / name, cfg, seed=1)
    study = evtribo.open_study(tmp_path / name / "study")
    assert len(study.trials) == len(truth["trials"])
    assert all(c["F_el_N"] > 0 for c in truth["cells"])


def test_population_cells_make_a_result_folder_evtribo_reads(tmp_path: Path) -> None:
    from heldout import population_cells as pc

    cfg = replace(pc.CELL_SCENARIOS["cells-weak"], subjects=4, weak_share=0.5, n_boot=50)
    truth = pc.generate(tmp_path / "cells", cfg, seed=2)
    results = evtribo.load_results(tmp_path / "cells" / "out")
    est = results.electrostatic.set_index(["subject", "amplitude_V"])
    assert len(est) == 4 * len(cfg.amplitudes_V)
    for c in truth["cells"]:
        row = est.loc[(c["subject"], c["amplitude_V"])]
        assert row["electrostatic_force_N"] == pytest.approx(c["estimate_N"])
        half = (row["electrostatic_force_ci_high_N"] - row["electrostatic_force_ci_low_N"]) / 2
        assert half == pytest.approx(1.959964 * c["se_N"])
        s = truth["subjects"][c["subject"]]
        assert c["true_N"] == pytest.approx(s["k"] * c["amplitude_V"] ** s["n"])
    assert sum(s["weak"] for s in truth["subjects"].values()) == 2
    assert set(results.exponents["subject"]) == set(truth["subjects"])
    assert truth["superpopulation"] is None  # weak responders: a mixture, no one typical value
