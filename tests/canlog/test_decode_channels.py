"""decode_trial over logs of several buses, frames of the other kind of ID, candump's
DROPCOUNT notices and CAN XL frames; inspect naming messages by ID and kind."""

import logging
import shutil
from pathlib import Path

import numpy as np
import pytest

from evtribo.canlog.decode import decode_messages, decode_trial
from evtribo.canlog.io import read_frames
from evtribo.canlog.rig import default_rig, load_dbc, load_rig
from evtribo.cli import main
from evtribo.errors import UserInputError

TEXT = Path(__file__).parents[1] / "data" / "candump-text"
T0 = 1763700000.0
CANTOOLS = Path(__file__).parents[1] / "data" / "cantools"


def _cell_lines(channel: str, fz: float, fx: float, n: int, *, t0: float = T0,
                extended: bool = False) -> list[tuple[float, str]]:
    """candump -L lines of the default rig's two load cells, *n* frames each at 1 kHz."""
    db = default_rig().database
    out = []
    for i in range(n):
        for name, sig, value, dt in (("FzCell", "Fz", fz, 0.0), ("FxCell", "Fx", fx, 4e-4)):
            m = db.get_message_by_name(name)
            data = m.encode({sig: value, f"{sig}Status": 0, f"{sig}Temp": 20,
                             f"{sig}Counter": i % 256})
            ident = f"{m.frame_id:08X}" if extended else f"{m.frame_id:03X}"
            t = t0 + i * 1e-3 + dt
            out.append((t, f"({t:.6f}) {channel} {ident}#{data.hex().upper()}"))
    return out


def _write(path: Path, *streams: list[tuple[float, str]], extra: str = "") -> Path:
    lines = sorted(line for stream in streams for line in stream)
    path.write_text("\n".join(text for _, text in lines) + "\n" + extra)
    return path


def test_the_same_rig_ids_on_two_buses_are_not_merged(tmp_path, caplog):
    """vcan0 carries the rig (500 frames per cell); can1 carries other nodes with the same
    IDs (100 frames per cell, other forces). Merged, the forces would jump between 0.5 N and
    3 N and the counters would count hundreds of frames lost."""
    path = _write(tmp_path / "two.log", _cell_lines("vcan0", 0.5, 0.2, 500),
                  _cell_lines("can1", 3.0, -1.0, 100, t0=T0 + 0.0002))
    frames, _ = read_frames(path)
    rig = default_rig()
    with caplog.at_level(logging.WARNING, logger="evtribo.canlog.decode"):
        trial = decode_trial(frames, rig)
    assert trial.channel == "vcan0"
    np.testing.assert_allclose(trial.normal.value, 0.5, atol=1e-5)
    np.testing.assert_allclose(trial.tangential.value, 0.2, atol=1e-5)
    assert len(trial.normal.t) == 500 and trial.dropped_frames == 0
    assert trial.frames == 1000 and trial.ignored_frames == 200
    assert len(trial.warnings) == 1
    assert trial.warnings[0].kind == "channels-several"
    warning = trial.warnings[0].text
    assert "vcan0: 1000 frames" in warning and "can1: 200 frames" in warning
    assert "FzCell, FxCell on more than one" in warning and warning in caplog.text
    other = decode_trial(frames, rig, channel="can1")
    assert other.channel == "can1" and len(other.normal.t) == 100
    np.testing.assert_allclose(other.normal.value, 3.0, atol=1e-5)
    with pytest.raises(UserInputError, match="no channel 'can9'; its channels: vcan0, can1"):
        decode_trial(frames, rig, channel="can9")


def test_a_one_bus_log_is_decoded_whole_without_a_warning(tmp_path, caplog):
    path = _write(tmp_path / "one.log", _cell_lines("can0", 0.5, 0.2, 50))
    with caplog.at_level(logging.WARNING):
        trial = decode_trial(read_frames(path)[0], default_rig())
    assert trial.channel == "can0" and trial.frames == 100 and not trial.warnings
    assert not caplog.records


def _extended_rig(tmp_path: Path):
    """The default rig with FzCell and FxCell as extended (29-bit) messages 0xC1, 0xC2."""
    src = default_rig()
    dbc = src.dbc.read_text().replace("BO_ 193 ", "BO_ 2147483841 ").replace(
        "BO_ 194 ", "BO_ 2147483842 ").replace(" 193 ", " 2147483841 ").replace(
        " 194 ", " 2147483842 ")
    (tmp_path / "ext.dbc").write_text(dbc)
    (tmp_path / "rig.toml").write_text('dbc = "ext.dbc"\nnormal_force = "FzCell.Fz"\n'
                                       'tangential_force = "FxCell.Fx"\n')
    return load_rig(tmp_path / "rig.toml")


def test_a_standard_frame_is_not_an_extended_message_of_the_same_number(tmp_path):
    rig = _extended_rig(tmp_path)
    assert rig.normal_force.message.is_extended_frame
    path = _write(tmp_path / "mixed.log", _cell_lines("vcan0", 0.5, 0.2, 40, extended=True),
                  _cell_lines("vcan0", 3.0, -1.0, 10, t0=T0 + 0.0002))
    trial = decode_trial(read_frames(path)[0], rig)
    np.testing.assert_allclose(trial.normal.value, 0.5, atol=1e-5)
    assert trial.frames == 80 and trial.ignored_frames == 20
    assert ("10 frames have the standard (11-bit) ID 0x0C1, but the DBC's message FzCell has "
            "the extended (29-bit) ID 0x000000C1") in trial.warnings[0].text
    std = decode_trial(read_frames(path)[0], default_rig())  # and the other way round
    np.testing.assert_allclose(std.normal.value, 3.0, atol=1e-5)
    assert "40 frames have the extended (29-bit) ID 0x000000C1" in std.warnings[0].text


def test_inspect_names_messages_by_number_and_kind(tmp_path, capsys):
    rig = _extended_rig(tmp_path)
    path = _write(tmp_path / "mixed.log", _cell_lines("vcan0", 0.5, 0.2, 5, extended=True),
                  _cell_lines("vcan0", 3.0, -1.0, 5, t0=T0 + 0.0002))
    assert main(["inspect", str(path), "--dbc", str(rig.dbc)]) == 0
    rows = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert "FzCell: Fz [N]" in rows["000000C1x"]
    assert "(not in the DBC: its FzCell has this number as an extended ID)" in rows["0C1"]


def test_extended_frames_of_a_standard_dbc_message_are_said_so(tmp_path, caplog):
    """cantools' abs.dbc defines 0x343 as a standard message; the candump log carries the
    number as an extended ID: nothing is decoded, and the warning says why."""
    (tmp_path / "abs.dbc").write_text(
        'VERSION ""\nNS_ :\nBS_:\nBU_: ABS\nBO_ 835 BREMSE_33: 8 ABS\n'
        ' SG_ whlspeed_FL : 0|16@1+ (0.015625,0) [0|100] "m/s" ABS\n')
    log = tmp_path / "ext.log"
    shutil.copy(TEXT / "candump-L-extended.log", log)
    db = load_dbc(tmp_path / "abs.dbc")
    with caplog.at_level(logging.WARNING, logger="evtribo.canlog.decode"):
        assert decode_messages(read_frames(log)[0], db) == {}
    assert ("5 frames have the extended (29-bit) ID 0x00000343, but the DBC's message "
            "BREMSE_33 has the standard (11-bit) ID 0x343") in caplog.text


def test_dropcount_and_can_xl_frames_reach_the_trial(tmp_path):
    drop0 = "DROPCOUNT: dropped 7 CAN frames on 'vcan0' socket (total drops 7)\n"
    drop1 = "DROPCOUNT: dropped 40 CAN frames on 'can1' socket (total drops 40)\n"
    xl = f"({T0 + 1:.6f}) vcan0 45123#80:00:00000000#11223344\n"
    path = _write(tmp_path / "drops.log", _cell_lines("vcan0", 0.5, 0.2, 100),
                  _cell_lines("can1", 0.5, 0.2, 10), extra=drop0 + drop1 + xl)
    frames, report = read_frames(path)
    assert report.dropped_frames == 47 and report.xl_frames == 1
    trial = decode_trial(frames, default_rig())
    assert trial.channel == "vcan0"
    assert trial.logger_dropped == 7           # the decoded channel's socket only
    assert trial.normal.dropped == trial.tangential.dropped == 0
    assert trial.dropped_frames == 7           # the larger of the cells' and the logger's
    assert trial.frames == 200 and trial.ignored_frames == 20 + 1


def test_the_sidecar_s_log_channel_picks_the_bus_an_analysis_decodes(tmp_path):
    """A log of two buses that both carry the rig's IDs (a replay on can1, twice over): the
    analysis takes the bus with most of the rig's frames, unless the sidecar's
    ``log_channel`` names the one the trial was recorded on; a channel the log lacks is an
    error naming the sidecar and the key."""
    import json

    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
    from evtribo.results.pipeline import analyze_study

    study = tmp_path / "study"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(120.0,),
                   config=TrialConfig(duration_s=5.0, tare_s=1.0), sine_trial=False)
    log = sorted(study.rglob("*.log"))[0]
    lines = log.read_text(encoding="ascii").splitlines()
    own = lines[0].split()[1]
    replay = []
    for line in lines:
        stamp, _, frame = line.split()
        t = float(stamp.strip("()"))
        replay += [f"({t + 1e-4:.6f}) can1 {frame}", f"({t + 2e-4:.6f}) can1 {frame}"]
    log.write_text("\n".join(lines + replay) + "\n", encoding="ascii")
    sidecar = log.with_suffix(".json")
    meta = json.loads(sidecar.read_text(encoding="utf-8"))

    def run(out, log_channel):
        meta.pop("log_channel", None)
        if log_channel is not None:
            meta["log_channel"] = log_channel
        sidecar.write_text(json.dumps(meta), encoding="utf-8")
        res = analyze_study(study, tmp_path / out, jobs=1, cache_dir=tmp_path / "cache")
        return res.trials.iloc[0], json.loads((tmp_path / out / "summary.json").read_text())

    mine, _ = run("own", own)
    assert mine.frames == len(lines) - sum(1 for line in lines if "#" not in line)
    assert mine.dropped_frames == 0
    most, summary = run("most", None)
    assert most.frames == 2 * mine.frames          # can1 carries most of the rig's frames
    assert "several channels" in json.dumps(summary)
    _, summary = run("none", "can9")
    said = json.dumps(summary)
    assert "log_channel" in said and "can9" in said and str(sidecar) in said


def _fd_lines(channel: str, n: int, *, t0: float, ident: str = "0C1") -> list[tuple[float, str]]:
    """CAN FD frames (``##1``, bit-rate switch) of another node that has the number of the
    rig's classic load-cell message: 12 bytes of its own data, its own counter."""
    out = []
    for i in range(n):
        t = t0 + i * 7.3e-3
        data = bytes([0x7F, 0xFF, 0x40, 0x00, 0x10, 0x20, 0x30, (i * 37) % 256, 1, 2, 3, 4])
        out.append((t, f"({t:.6f}) {channel} {ident}##1{data.hex().upper()}"))
    return out


def test_can_fd_frames_are_not_decoded_as_a_classic_message_of_their_id(tmp_path, caplog):
    """489 FD frames on a load cell's ID, decoded as that cell, changed a subject's F_el at
    80 V by -7.8 % and made dropped_frames 124,376: an FD frame is only an FD message."""
    path = _write(tmp_path / "fd.log", _cell_lines("vcan0", 0.5, 0.2, 2000),
                  _fd_lines("vcan0", 250, t0=T0 + 1e-4))
    with caplog.at_level(logging.WARNING, logger="evtribo.canlog.decode"):
        trial = decode_trial(read_frames(path)[0], default_rig())
    np.testing.assert_allclose(trial.normal.value, 0.5, atol=1e-5)
    assert len(trial.normal.t) == 2000 and trial.dropped_frames == 0
    assert trial.frames == 4000 and trial.ignored_frames == 250
    said = [w.text for w in trial.warnings if w.kind == "frames-fd-kind"]
    assert said == [
        "250 CAN FD frames have the standard (11-bit) ID 0x0C1 of the DBC's classic CAN "
        "message FzCell: not decoded as FzCell, counted with the frames the DBC does not "
        "describe (a CAN FD frame is only an FD message, a classic frame only a classic one)"]
    assert said[0] in caplog.text
    # evtribo decode's table: no FzCell row from an FD frame
    decoded = decode_messages(read_frames(path)[0], default_rig().database)
    assert len(decoded["FzCell"]) == 2000
    np.testing.assert_allclose(decoded["FzCell"].scaled("Fz"), 0.5, atol=1e-5)


def test_classic_frames_are_not_decoded_as_an_fd_message_of_their_id(tmp_path):
    """The other way round: a DBC whose message 0x0C1 is CAN FD (``VFrameFormat``) decodes
    the FD frames, and names the classic ones it leaves."""
    dbc = default_rig().dbc.read_text(encoding="utf-8")
    dbc += ('\nBA_DEF_ BO_ "VFrameFormat" ENUM "StandardCAN","ExtendedCAN","reserved",'
            '"reserved","reserved","reserved","reserved","reserved","reserved","reserved",'
            '"reserved","reserved","reserved","reserved","StandardCAN_FD","ExtendedCAN_FD";\n'
            'BA_DEF_DEF_ "VFrameFormat" "StandardCAN";\nBA_ "VFrameFormat" BO_ 193 14;\n')
    (tmp_path / "fd.dbc").write_text(dbc, encoding="utf-8")
    db = load_dbc(tmp_path / "fd.dbc")
    assert db.get_message_by_name("FzCell").is_fd
    path = _write(tmp_path / "fd.log", _cell_lines("vcan0", 0.5, 0.2, 40),
                  _fd_lines("vcan0", 30, t0=T0 + 1e-4))
    from evtribo.canlog.frame_match import kind_mismatches

    frames = read_frames(path)[0]
    decoded = decode_messages(frames, db)
    assert len(decoded["FzCell"]) == 30 and len(decoded["FxCell"]) == 40
    assert [w.text for w in kind_mismatches(frames, db.messages, db)] == [
        "40 classic CAN frames have the standard (11-bit) ID 0x0C1 of the DBC's CAN FD "
        "message FzCell: not decoded as FzCell, counted with the frames the DBC does not "
        "describe (a CAN FD frame is only an FD message, a classic frame only a classic one)"]


def test_a_message_longer_than_8_bytes_is_can_fd_whatever_its_frame_format(tmp_path, caplog):
    """cantools' variable_dlc.dbc: a 10-byte J1939 message (``VFrameFormat`` 3), which
    cantools calls classic. Only a CAN FD frame carries 10 bytes: its frames were refused,
    with a warning, and their values lost. Many DBCs in the wild give no frame format."""
    db = load_dbc(CANTOOLS / "variable_dlc.dbc")
    msg = db.get_message_by_name("TestMessage2")
    assert msg.length == 10 and not msg.is_fd   # cantools' reading of the attribute
    payloads = [bytes(range(k, k + 10)) for k in range(20)]
    lines = [(T0 + k * 1e-3, f"({T0 + k * 1e-3:.6f}) vcan0 {msg.frame_id:08X}##0"
              f"{(p + bytes(2)).hex().upper()}") for k, p in enumerate(payloads)]
    frames = read_frames(_write(tmp_path / "j1939.log", lines))[0]
    with caplog.at_level(logging.WARNING, logger="evtribo.canlog.decode"):
        decoded = decode_messages(frames, db)
    assert "not decoded" not in caplog.text
    assert len(decoded["TestMessage2"]) == 20
    for name in ("Signal4", "Signal8"):
        np.testing.assert_array_equal(decoded["TestMessage2"].scaled(name),
                                      [msg.decode(p)[name] for p in payloads])
