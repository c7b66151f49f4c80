"""Vectorised decoding equals cantools; a second rig's trial decodes to the right forces."""

import math
from pathlib import Path

import can
import cantools
import numpy as np
import pandas as pd
import pytest
from cantools.database.can import Database, Message, Signal
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.canlog.decode import SignalCodec, decode_message, decode_messages, decode_trial
from evtribo.canlog.dropped import count_dropped
from evtribo.canlog.io import FrameTable, frames_from_messages, read_frames, write_candump
from evtribo.canlog.rig import default_rig, load_rig
from evtribo.cli import main

RIGS = Path(__file__).parents[1] / "data" / "rigs"


@st.composite
def layouts(draw):
    n_bytes = draw(st.sampled_from([1, 2, 5, 8, 8, 8, 12, 16, 64]))
    is_float = draw(st.booleans()) and n_bytes >= 4
    if is_float:
        length = draw(st.sampled_from([32, 64] if n_bytes >= 8 else [32]))
    else:
        length = draw(st.integers(1, min(64, 8 * n_bytes)))
    little = draw(st.booleans())
    pos = draw(st.integers(0, 8 * n_bytes - length))  # sequential bit position
    if little:
        start = pos
    else:  # DBC "sawtooth" numbering of the MSB
        start = (pos // 8) * 8 + (7 - pos % 8)
    scale = draw(st.sampled_from([1, 2, 10, 0.5, 1e-5, 0.01])
                 | st.floats(1e-6, 1e3, allow_nan=False))
    offset = draw(st.sampled_from([0, -40, 1000]) | st.floats(-1e4, 1e4, allow_nan=False))
    signal = Signal("S", start, length, "little_endian" if little else "big_endian",
                    is_signed=draw(st.booleans()) and not is_float,
                    conversion=cantools.database.conversion.BaseConversion.factory(
                        scale=scale, offset=offset, is_float=is_float))
    ext = draw(st.booleans())
    frame_id = draw(st.integers(0, 0x1FFFFFFF if ext else 0x7FF))
    # a payload over 8 bytes is a CAN FD message's (and an FD frame is only an FD message)
    message = Message(frame_id, "M", n_bytes, [signal], is_extended_frame=ext,
                      is_fd=n_bytes > 8)
    payloads = draw(st.lists(st.binary(min_size=n_bytes, max_size=n_bytes), min_size=1,
                             max_size=20))
    return message, payloads


def _table(message: Message, payloads: list[bytes]) -> FrameTable:
    return frames_from_messages(
        can.Message(timestamp=i * 1e-3, arbitration_id=message.frame_id,
                    is_extended_id=message.is_extended_frame, data=p, is_fd=message.is_fd)
        for i, p in enumerate(payloads))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(layouts())
def test_vectorised_decoder_equals_cantools(case):
    message, payloads = case
    frames = _table(message, payloads)
    decoded = decode_message(frames, message)
    assert len(decoded) == len(payloads)
    sig = message.signals[0]
    for i, p in enumerate(payloads):
        raw = message.decode(p, decode_choices=False, scaling=False)["S"]
        scaled = message.decode(p, decode_choices=False)["S"]
        ours_raw = decoded.raw["S"][i]
        ours = decoded.scaled("S")[i]
        if sig.is_float:
            assert (math.isnan(raw) and math.isnan(ours_raw)) or ours_raw == raw
            assert (math.isnan(scaled) and math.isnan(ours)) or ours == scaled \
                or (math.isinf(scaled) and ours == scaled)
        else:
            assert int(ours_raw) == raw
            # cantools computed it exactly (an int), or from a code float64 cannot hold
            # (|raw| > 2**53, scaled by an int): equal up to float64 rounding
            if isinstance(scaled, int) or abs(raw) > 2**53:
                tol = 4 * np.spacing(abs(raw * sig.scale) + abs(sig.offset) + 1.0)
                assert abs(ours - scaled) <= tol
            else:
                assert ours == scaled


def test_value_tables_give_raw_codes_and_names():
    db = default_rig().database
    msg = db.get_message_by_name("HvStatus")
    payloads = [msg.encode({"HvOn": 1, "HvWave": w, "HvCounter": 0, "HvAmp": 140,
                            "HvFreq": 10000, "HvCurrent": 1}) for w in (0, 1, 3)]
    decoded = decode_messages(_table(msg, payloads), db)["HvStatus"]
    assert decoded.raw["HvWave"].tolist() == [0, 1, 3]
    assert decoded.choice_names("HvWave").tolist() == ["sine", "square", "dc"]
    np.testing.assert_allclose(decoded.scaled("HvAmp"), 140)
    assert decoded.units["HvAmp"] == "V"


def test_multiplexed_message_falls_back_to_cantools():
    db = cantools.database.load_string(
        'VERSION ""\nNS_ :\nBS_:\nBU_: A\n'
        'BO_ 100 Mux: 8 A\n'
        ' SG_ Sel M : 0|8@1+ (1,0) [0|255] "" A\n'
        ' SG_ X m0 : 8|16@1+ (0.5,0) [0|1000] "" A\n'
        ' SG_ Y m1 : 8|16@1- (1,-3) [-100|100] "" A\n', database_format="dbc")
    msg = db.get_message_by_name("Mux")
    payloads = [msg.encode({"Sel": 0, "X": 10.5}), msg.encode({"Sel": 1, "Y": -7})]
    decoded = decode_messages(_table(msg, payloads), db)["Mux"]
    np.testing.assert_array_equal(decoded.scaled("X"), [10.5, np.nan])
    np.testing.assert_array_equal(decoded.scaled("Y"), [np.nan, -7])


def test_dropped_frames_counter_wraps_and_long_gaps():
    t = np.arange(1000) * 1e-3
    counter = np.arange(1000) % 16
    keep = np.ones(1000, bool)
    keep[[10, 11, 500]] = False  # 3 frames lost
    keep[700:740] = False  # 40 frames lost: more than the counter's period
    assert count_dropped(t[keep], counter[keep], 16) == 43
    assert count_dropped(t[keep]) == 43  # timing alone finds them on a clean clock
    # a late frame (jitter) is no loss when the counter says so
    t2 = t.copy()
    t2[300] += 0.0009
    assert count_dropped(t2, counter, 16) == 0


def _second_rig_trial(tmp_path):
    rig = load_rig(RIGS / "motorola.toml")
    db = rig.database
    nmsg, tmsg, amsg = (db.get_message_by_name(n)
                        for n in ("NormalCell", "TangentialCell", "AmpState"))
    rng = np.random.default_rng(5)
    msgs, fn, ft = [], [], []
    for k in range(400):
        t = 100.0 + k * 2e-3
        if k not in (50, 51, 52):  # normal cell: 3 frames lost
            fn.append(round(rng.uniform(-20, 20), 3))
            msgs.append(can.Message(timestamp=t, arbitration_id=nmsg.frame_id,
                                    data=nmsg.encode({"Force_mN": fn[-1], "Seq": k % 16,
                                                      "Spare": 7})))
        ft.append(round(rng.uniform(-3, 3), 5))
        msgs.append(can.Message(timestamp=t + 7e-4, arbitration_id=tmsg.frame_id,
                                data=tmsg.encode({"Ft": ft[-1], "SeqT": k % 256})))
        if k % 40 == 0:
            msgs.append(can.Message(timestamp=t + 1e-4, arbitration_id=amsg.frame_id,
                                    is_extended_id=False, data=amsg.encode(
                                        {"Enabled": (k // 40) % 2, "Shape": (k // 80) % 2,
                                         "Volts": 140.5, "Hertz": 250})))
            msgs.append(can.Message(timestamp=t + 2e-4, arbitration_id=0x701,
                                    is_extended_id=False, data=bytes(8)))
            msgs.append(can.Message(timestamp=t + 3e-4, is_error_frame=True))
            msgs.append(can.Message(timestamp=t + 4e-4, arbitration_id=0x0C1,
                                    is_extended_id=False, data=bytes(8)))
    path = tmp_path / "trial.log"
    write_candump(path, frames_from_messages(msgs))
    return rig, path, np.array(fn), np.array(ft)


def test_second_rig_extended_ids_motorola_other_scalings(tmp_path):
    rig, path, fn, ft = _second_rig_trial(tmp_path)
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    trial = decode_trial(frames, rig)
    np.testing.assert_allclose(trial.normal.value, fn, atol=1e-9)
    np.testing.assert_allclose(trial.tangential.value, ft, atol=1e-9)
    assert trial.normal.dropped == 3 and trial.tangential.dropped == 0
    assert trial.dropped_frames == 3
    assert trial.frames == 397 + 400 + 10
    assert trial.ignored_frames == 30  # Other, error frames, a default-rig ID
    ex = trial.excitation
    assert ex.enabled.tolist() == [bool(i % 2) for i in range(10)]
    assert ex.waveform.tolist() == ["sine", "sine", "square", "square"] * 2 + ["sine"] * 2
    np.testing.assert_allclose(ex.amplitude, 140.5)
    np.testing.assert_allclose(ex.frequency, 250)
    assert np.all(np.diff(trial.normal.t) > 0)


def test_default_rig_trial_without_excitation_roles(tmp_path):
    rig = default_rig()
    toml = tmp_path / "rig.toml"
    toml.write_text(f'dbc = "{rig.dbc}"\nnormal_force = "FzCell.Fz"\n'
                    'tangential_force = "FxCell.Fx"\n')
    plain = load_rig(toml)
    fz = rig.database.get_message_by_name("FzCell")
    frames = frames_from_messages(
        can.Message(timestamp=i * 1e-3, arbitration_id=fz.frame_id, is_extended_id=False,
                    data=fz.encode({"Fz": 0.5, "FzStatus": 0, "FzTemp": 20,
                                    "FzCounter": i % 256})) for i in range(10))
    trial = decode_trial(frames, plain)
    assert trial.excitation is None
    # no counter role: FzCell's FzCounter is used, as the logger does (Rig.counter)
    assert trial.normal.counter.tolist() == list(range(10))
    np.testing.assert_allclose(trial.normal.value, 0.5)
    assert len(trial.tangential.t) == 0 and trial.frames == 10


def test_signal_codec_matches_cantools_naming():
    sig = default_rig().normal_force.signal
    codec = SignalCodec.from_signal(sig)
    raw = np.array([-50000, 0, 123456])
    np.testing.assert_allclose(codec.raw_to_scaled(raw),
                               [sig.conversion.raw_to_scaled(int(r)) for r in raw])


@pytest.mark.parametrize("db_case", ["default"])
def test_decode_messages_covers_every_message(db_case):
    db: Database = default_rig().database
    payload = bytes(range(8))
    frames = frames_from_messages(
        can.Message(timestamp=i, arbitration_id=m.frame_id, is_extended_id=False, data=payload)
        for i, m in enumerate(db.messages))
    out = decode_messages(frames, db)
    assert list(out) == [m.name for m in db.messages]
    for m in db.messages:
        ref = m.decode(payload, decode_choices=False)
        for name, value in ref.items():
            assert out[m.name].scaled(name)[0] == pytest.approx(value, rel=1e-12)


# --- the inspect and decode commands -----------------------------------------------------------

def test_decode_command_writes_one_column_per_signal(tmp_path, capsys):
    rig, path, fn, _ft = _second_rig_trial(tmp_path)
    out = tmp_path / "out.parquet"
    assert main(["decode", str(path), "--dbc", str(rig.dbc), "-o", str(out)]) == 0
    table = pd.read_parquet(out)
    assert list(table.columns[:2]) == ["timestamp", "message"]
    assert {"Force_mN", "Ft", "Seq", "Volts", "Shape", "Junk"} <= set(table.columns)
    frames, _ = read_frames(path)  # rows in log order: every frame of a DBC message
    known = np.isin(frames.arbitration_id, [m.frame_id for m in rig.database.messages])
    known &= ~frames.is_error & (frames.arbitration_id != 0x0C1)
    np.testing.assert_array_equal(table["timestamp"], frames.timestamp[known])
    normal = table[table["message"] == "NormalCell"]
    np.testing.assert_allclose(normal["Force_mN"], fn, atol=1e-9)
    assert normal["Ft"].isna().all()
    # refuses to overwrite, then does with --force; CSV with value-table names
    assert main(["decode", str(path), "--dbc", str(rig.dbc), "-o", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    csv = tmp_path / "out.csv"
    assert main(["decode", str(path), "--dbc", str(rig.dbc), "-o", str(csv), "--choices"]) == 0
    shapes = pd.read_csv(csv)["Shape"].dropna().unique().tolist()
    assert sorted(shapes) == ["sine", "square"]


def test_inspect_command_names_ids_rates_and_messages(tmp_path, capsys):
    rig, path, _fn, _ft = _second_rig_trial(tmp_path)
    assert main(["inspect", str(path), "--dbc", str(rig.dbc)]) == 0
    out = capsys.readouterr().out
    assert "18FF0000x" in out and "NormalCell: Force_mN [N]" in out
    assert "0C1" in out and "(not in the DBC)" in out
    row = next(line for line in out.splitlines() if "18FF0001x" in line)
    assert row.split()[1] == "400" and float(row.split()[2]) == pytest.approx(500, rel=1e-3)


def test_commands_strict_exit_code_on_damaged_line(tmp_path, capsys):
    log = tmp_path / "bad.log"
    log.write_text("(1.000000) vcan0 0C1#0000000000000000\n(1.001000) vcan0 0C1#00Z\n")
    assert main(["inspect", str(log)]) == 0
    assert main(["inspect", str(log), "--strict"]) == 2
    assert f"{log}:2" in capsys.readouterr().err
    dbc = default_rig().dbc
    assert main(["decode", str(log), "--dbc", str(dbc), "-o", str(tmp_path / "o.csv"),
                 "--strict"]) == 2


MUX_DBC = ('VERSION ""\nNS_ :\nBS_:\nBU_: A\n'
           'BO_ 193 FzCell: 8 A\n'
           ' SG_ Sel M : 0|8@1+ (1,0) [0|255] "" A\n'
           ' SG_ Fz m0 : 8|16@1+ (0.001,0) [0|65] "N" A\n'
           ' SG_ Temp m1 : 8|16@1+ (1,0) [0|100] "degC" A\n'
           'BO_ 194 FxCell: 8 A\n'
           ' SG_ Fx : 0|16@1+ (0.001,0) [0|65] "N" A\n')


def test_unknown_multiplexer_value_is_one_ignored_frame_not_a_failed_decode(tmp_path,
                                                                              caplog):
    """A frame whose multiplexer value the DBC does not know gets NaN signals and is counted
    as ignored; the other frames of the message, and the trial, decode."""
    (tmp_path / "mux.dbc").write_text(MUX_DBC)
    (tmp_path / "rig.toml").write_text('dbc = "mux.dbc"\nnormal_force = "FzCell.Fz"\n'
                                       'tangential_force = "FxCell.Fx"\n')
    rig = load_rig(tmp_path / "rig.toml")
    fz = rig.database.get_message_by_name("FzCell")
    fx = rig.database.get_message_by_name("FxCell")
    payloads = [fz.encode({"Sel": 0, "Fz": 0.5}), fz.encode({"Sel": 1, "Temp": 25}),
                bytes([5]) + bytes(7),                          # Sel = 5: not in the DBC
                fz.encode({"Sel": 0, "Fz": 0.75})]
    msgs = [can.Message(timestamp=i * 1e-3, arbitration_id=0xC1, is_extended_id=False,
                        data=p) for i, p in enumerate(payloads)]
    msgs += [can.Message(timestamp=0.01 + i * 1e-3, arbitration_id=0xC2, is_extended_id=False,
                         data=fx.encode({"Fx": 0.25})) for i in range(3)]
    frames = frames_from_messages(msgs)
    decoded = decode_messages(frames, rig.database)["FzCell"]
    np.testing.assert_array_equal(decoded.scaled("Fz"), [0.5, np.nan, np.nan, 0.75])
    np.testing.assert_array_equal(decoded.scaled("Temp"), [np.nan, 25, np.nan, np.nan])
    assert decoded.undecoded.tolist() == [2]
    assert "expected multiplexer id" in caplog.text
    trial = decode_trial(frames, rig)
    np.testing.assert_allclose(trial.normal.value, [0.5, np.nan, 0.75])   # Sel 1: no Fz
    np.testing.assert_allclose(trial.normal.t, [0.0, 0.001, 0.003])
    assert (trial.frames, trial.ignored_frames) == (6, 1)
    log = tmp_path / "mux.log"
    write_candump(log, frames)
    out = tmp_path / "mux.csv"
    assert main(["decode", str(log), "--dbc", str(tmp_path / "mux.dbc"), "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert len(table) == 7 and table["Fz"].isna().sum() == 5


def test_decode_command_renames_signals_named_like_its_columns(tmp_path):
    (tmp_path / "ts.dbc").write_text(
        'VERSION ""\nNS_ :\nBS_:\nBU_: N\nBO_ 256 Msg: 2 N\n'
        ' SG_ A : 0|8@1+ (1,0) [0|255] "" N\n SG_ timestamp : 8|8@1+ (1,0) [0|255] "" N\n'
        'BO_ 257 Other: 1 N\n SG_ message : 0|8@1+ (1,0) [0|255] "" N\n')
    log = tmp_path / "ts.log"
    log.write_text("(2.000000) vcan0 100#0107\n(3.000000) vcan0 101#09\n")
    out = tmp_path / "ts.csv"
    assert main(["decode", str(log), "--dbc", str(tmp_path / "ts.dbc"), "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == ["timestamp", "message", "A", "Msg.timestamp",
                                   "Other.message"]
    assert table["timestamp"].tolist() == [2.0, 3.0]
    assert table["message"].tolist() == ["Msg", "Other"]
    assert table["Msg.timestamp"].tolist()[:1] == [7.0]
    assert table["Other.message"].tolist()[1:] == [9.0]


def test_inspect_and_decode_load_a_dbc_the_rig_loads(tmp_path, capsys):
    """A DBC with overlapping signals (cantools' strict check) loads, with a warning, for
    inspect and decode as for a study's rig."""
    (tmp_path / "overlap.dbc").write_text(
        'VERSION ""\nNS_ :\nBS_:\nBU_: N\nBO_ 256 Msg: 2 N\n'
        ' SG_ A : 0|16@1+ (1,0) [0|65535] "" N\n SG_ B : 8|8@1+ (1,0) [0|255] "" N\n')
    log = tmp_path / "o.log"
    log.write_text("(1.000000) vcan0 100#0102\n")
    dbc = str(tmp_path / "overlap.dbc")
    assert main(["inspect", str(log), "--dbc", dbc]) == 0
    assert "Msg: A, B" in capsys.readouterr().out
    out = tmp_path / "o.csv"
    assert main(["decode", str(log), "--dbc", dbc, "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert table["A"].tolist() == [0x0201] and table["B"].tolist() == [2]


def test_logger_and_decoder_count_lost_frames_with_the_same_counter(tmp_path):
    """A rig naming no counter role: the logger's check and decode_trial both use the
    force message's *Counter signal (Rig.counter), and agree on the frames lost."""
    from evtribo.acquisition.logger import CounterTracker
    from evtribo.acquisition.rigfile import AcquisitionRig

    rig = default_rig()
    toml = tmp_path / "rig.toml"
    toml.write_text(f'dbc = "{rig.dbc}"\nnormal_force = "FzCell.Fz"\n'
                    'tangential_force = "FxCell.Fx"\n')
    plain = load_rig(toml)
    assert plain.normal_force_counter is None
    assert plain.counter("normal").qualified_name == "FzCell.FzCounter"
    assert plain.counter("tangential").qualified_name == "FxCell.FxCounter"
    fz = rig.database.get_message_by_name("FzCell")
    # stamped on the host in bursts of 50 (as slcan adapters are): timing cannot see the
    # frames lost inside a burst, the counter can
    msgs = [can.Message(timestamp=(i // 50) * 0.05, arbitration_id=fz.frame_id,
                        is_extended_id=False, data=fz.encode(
                            {"Fz": 0.5, "FzStatus": 0, "FzTemp": 20, "FzCounter": i % 256}))
            for i in range(600) if i not in (110, 111, 112, 420)]
    tracker = CounterTracker(AcquisitionRig.from_rig(plain).counters)
    logged = sum(tracker.update(m.arbitration_id, m.data, m.timestamp) for m in msgs)
    trial = decode_trial(frames_from_messages(msgs), plain)
    assert logged == trial.normal.dropped == 4


def test_a_waveform_without_value_table_is_named_by_the_fallback_with_a_warning(tmp_path):
    """A rig whose DBC gives the waveform signal no value table: its codes are named by
    evtribo.canlog.decode.FALLBACK_WAVEFORMS, and the trial says so; the DBC's own table wins."""
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
    from evtribo.canlog.rig import default_rig_path

    frames, _ = simulate_trial(SubjectParams(), TrialConfig(duration_s=2.0, seed=3))
    source = default_rig_path()
    dbc_name = "default.dbc"
    dbc = (source.parent / dbc_name).read_text(encoding="utf-8")
    val = next(line for line in dbc.splitlines() if line.startswith("VAL_") and "HvWave" in line)
    variants = {"plain": dbc.replace(val, ""),
                "renamed": dbc.replace(val, val.replace('"sine"', '"sinus"')
                                       .replace('"square"', '"rect"'))}
    found = {}
    for name, text in variants.items():
        folder = tmp_path / name
        folder.mkdir()
        (folder / dbc_name).write_text(text, encoding="utf-8")
        (folder / "rig.toml").write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
        found[name] = decode_trial(frames, load_rig(folder / "rig.toml"))
    plain = found["plain"]
    assert any("HvWave" in w.text and w.kind == "waveform-codes" for w in plain.warnings)
    assert set(plain.excitation.waveform.tolist()) <= {"sine", "square", "triangle", "dc"}
    renamed = found["renamed"]
    assert not any(w.kind == "waveform-codes" for w in renamed.warnings)
    assert set(renamed.excitation.waveform.tolist()) <= {"sinus", "rect", "triangle", "dc"}
    assert set(renamed.excitation.waveform.tolist()) & {"sinus", "rect"}
