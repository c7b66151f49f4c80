"""The live display: the target band gauge, the status block, the refresh thread."""

import io
import re
import time
from pathlib import Path

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.counters import NOT_COUNTING, NOT_KNOWN
from evtribo.acquisition.live.display import view_state
from evtribo.acquisition.live.monitor import (
    Monitor,
    Snapshot,
    band_state,
    render_band,
    render_line,
    render_status,
)
from evtribo.acquisition.logger import LogStats, frame_key
from evtribo.acquisition.rigfile import default_rig_path, load_rig_toml


@pytest.mark.parametrize("value,state", [(0.5, "in"), (0.41, "in"), (0.6, "in"),
                                         (0.39, "low"), (0.61, "high"), (None, "none"),
                                         (float("nan"), "none")])
def test_band_state(value, state):
    assert band_state(value, 0.5, 0.1) == state


def test_band_gauge_marks_band_target_and_value():
    # 0.5 ± 0.1 N on a 41-character gauge spanning 0.1..0.9 N: 0.02 N per character
    gauge = render_band(0.5, 0.5, 0.1, width=41)
    assert len(gauge) == 43 and gauge[0] == "[" and gauge[-1] == "]"
    cells = gauge[1:-1]
    assert cells.index("=") == 15 and cells.rindex("=") == 25     # 0.4 N .. 0.6 N
    assert cells[20] == "O"                                        # the value hides the target
    assert set(cells[:15]) == set(cells[26:]) == {"-"}

    inside = render_band(0.56, 0.5, 0.1, width=41)[1:-1]
    assert inside[20] == "|" and inside[23] == "O"
    low = render_band(0.3, 0.5, 0.1, width=41)[1:-1]
    assert low[10] == "O" and low.index("=") == 15
    assert render_band(0.0, 0.5, 0.1, width=41)[1] == "<"          # off the scale
    assert render_band(5.0, 0.5, 0.1, width=41)[-2] == ">"
    assert "O" not in render_band(None, 0.5, 0.1)


def test_status_block_shows_everything_asked():
    snap = Snapshot(elapsed_s=12.34, remaining_s=17.66, normal_force_N=0.712,
                    tangential_force_N=-0.25, rates_Hz={"FzCell": 1000.0, "FxCell": 800.0},
                    frames=21600, dropped=3, bus_errors=1)
    lines = render_status(snap, target=0.5, band=0.1, title="P01/run-01")
    text = "\n".join(lines)
    assert lines[0].startswith("P01/run-01")
    assert "elapsed   12.3 s" in lines[0] and "remaining   17.7 s" in lines[0]
    assert "0.712 N" in lines[1] and "TOO HIGH" in lines[1]
    assert "-0.250 N" in lines[2] and "target 0.500 ± 0.100 N" in lines[2]
    assert "FzCell   1000" in text and "FxCell    800" in text
    assert "dropped 3" in text and "bus errors 1" in text
    assert "\x1b" not in text
    coloured = render_status(snap, target=0.5, band=0.1, colour=True)
    assert "\x1b[31mTOO HIGH" in coloured[1]
    assert "IN BAND" in render_status(Snapshot(1.0, normal_force_N=0.45), target=0.5)[1]
    # no target: the value without a gauge
    assert "[" not in render_status(snap)[1]
    assert "Fn=0.712 N (high)" in render_line(snap, target=0.5, band=0.1)


def _stats(rig, fz, fx):
    fz_msg, fx_msg = (rig.database.get_message_by_name(m) for m in ("FzCell", "FxCell"))
    stats = LogStats()
    stats.latest[fz_msg.frame_id] = can.Message(arbitration_id=fz_msg.frame_id, data=fz_msg.encode(
        {"Fz": fz, "FzStatus": 0, "FzTemp": 20, "FzCounter": 1}))
    stats.latest[fx_msg.frame_id] = can.Message(arbitration_id=fx_msg.frame_id, data=fx_msg.encode(
        {"Fx": fx, "FxStatus": 0, "FxTemp": 20, "FxCounter": 1}))
    return stats


def test_monitor_decodes_forces_and_rates_with_the_rig():
    rig = load_rig_toml(default_rig_path())
    stats = _stats(rig, 0.55, 0.2)
    mon = Monitor(rig, io.StringIO(), duration=10.0, target=0.5, band=0.1, tty=False)
    mon._stats, mon._t0 = stats, 1000.0  # the trial began 2 s before the picture
    mon._last = (mon._t0, {})
    stats.frames_by_id.update({"0C1": 2000, "0C2": 2000, "18FF0001": 10})
    snap = mon.snapshot(now=1002.0)
    assert snap.normal_force_N == pytest.approx(0.55, abs=1e-5)
    assert snap.tangential_force_N == pytest.approx(0.2, abs=1e-5)
    assert snap.rates_Hz["FzCell"] == pytest.approx(1000, rel=0.01)
    assert snap.rates_Hz["other"] == pytest.approx(5, rel=0.01)
    assert snap.remaining_s == pytest.approx(8.0, abs=0.1)


@pytest.mark.parametrize("tty", [True, False])
def test_monitor_thread_redraws_on_a_terminal_and_prints_lines_otherwise(tty):
    rig = load_rig_toml(default_rig_path())
    out = io.StringIO()
    mon = Monitor(rig, out, duration=5.0, target=0.5, band=0.1, tty=tty, interval=0.05,
                  line_interval=0.05)
    mon.start(_stats(rig, 0.5, 0.1))
    drawn = "\x1b[5F" if tty else "\n"
    for _ in range(600):  # two refreshes, however long a loaded machine takes to give them
        if out.getvalue().count(drawn) >= 2:
            break
        time.sleep(0.05)
    mon.stop()
    text = out.getvalue()
    if tty:
        assert text.count("\x1b[5F") >= 2            # cursor back up over the 5-line block
        assert "IN BAND" in text
    else:
        assert "\x1b" not in text
        assert text.count("\n") >= 2 and "Fn=0.500 N (in)" in text


def test_monitor_names_and_decodes_extended_id_messages():
    rig = load_rig_toml(Path(__file__).parents[1] / "data" / "rigs" / "motorola.toml")
    normal = rig.database.get_message_by_name("NormalCell")
    stats = LogStats()
    msg = can.Message(arbitration_id=normal.frame_id, is_extended_id=True,
                      data=normal.encode({"Force_mN": 0.75, "Seq": 1, "Spare": 0}))
    stats.latest[frame_key(normal.frame_id, True)] = msg
    # a standard frame with the same number is another message
    stats.latest[normal.frame_id & 0x7FF] = can.Message(arbitration_id=normal.frame_id & 0x7FF,
                                                        data=bytes(8))
    mon = Monitor(rig, io.StringIO(), duration=10.0, tty=False)
    mon._stats, mon._t0 = stats, 1000.0
    mon._last = (mon._t0, {})
    stats.frames_by_id.update({f"{normal.frame_id:08X}": 1000, "700": 20, "0C1": 30})
    snap = mon.snapshot(now=1002.0)
    assert snap.normal_force_N == pytest.approx(0.75, abs=1e-6)
    assert snap.rates_Hz["NormalCell"] == pytest.approx(500, rel=0.01)
    assert snap.rates_Hz["AmpState"] == pytest.approx(10, rel=0.01)
    assert snap.rates_Hz["other"] == pytest.approx(15, rel=0.01)


def test_the_display_asks_for_the_finger_lifted_then_sliding():
    lifting = Snapshot(0.4, normal_force_N=0.031, tare_left_s=1.1)
    lines = render_status(lifting, target=0.5, band=0.1)
    # the instruction on a line of its own, under the title
    assert "LIFT THE FINGER" in lines[1] and "1.1 s" in lines[1]
    assert "TARING" in lines[2] and "TOO LOW" not in lines[2]  # no alarm while lifted
    assert "LIFT THE FINGER" in render_line(lifting)
    sliding = Snapshot(2.0, normal_force_N=0.35, tare_left_s=0.0)
    lines = render_status(sliding, target=0.5, band=0.1)
    assert "SLIDE" in lines[1] and "TOO LOW" in lines[2]
    assert "LIFT" not in "".join(render_status(Snapshot(2.0), target=0.5))  # no tare
    rig = load_rig_toml(default_rig_path())
    mon = Monitor(rig, io.StringIO(), duration=10.0, tty=False, tare_s=1.5)
    mon._stats, mon._t0 = _stats(rig, 0.0, 0.0), 1000.0
    mon._last = (mon._t0, {})
    assert mon.snapshot(now=1000.5).tare_left_s == pytest.approx(1.0)
    assert mon.snapshot(now=1003.0).tare_left_s == 0.0


_ANSI = re.compile(r"\x1b\[[0-9;]*m")

finite = st.floats(-5, 5, allow_nan=False)


snapshots = st.builds(
    Snapshot, elapsed_s=st.just(12.3), remaining_s=st.just(7.7),
    normal_force_N=st.none() | finite, tangential_force_N=st.none() | finite,
    rates_Hz=st.dictionaries(st.sampled_from(["FzCell", "FxCell", "HvStatus", "other"]),
                             st.floats(0, 20000), max_size=4),
    frames=st.just(123456), dropped=st.just(7), bus_errors=st.just(2),
    tare_left_s=st.none() | st.floats(0, 2),
    alert=st.sampled_from(["", "NO DATA FROM THE RIG: no FzCell (0x0C1) or FxCell (0x0C2) "
                           "frame in 3 s; wrong bus, or the study's DBC is not this rig's?"]),
    hv_on=st.sampled_from([None, False, True]), hv_amplitude_V=st.just(140.0),
    hv_frequency_Hz=st.just(10000.0), hv_waveform=st.just("square"),
    counters=st.dictionaries(st.sampled_from(["FzCell", "FxCell"]),
                             st.sampled_from([NOT_KNOWN, NOT_COUNTING]), max_size=2))


@settings(max_examples=60, deadline=None)
@given(columns=st.integers(70, 200), snap=snapshots)
def test_the_block_fits_the_terminal_so_it_redraws_in_place(columns, snap):
    # a line as wide as the terminal wraps, and the cursor-up of the next redraw misses it
    alert = snap.alert
    for colour in (False, True):
        lines = render_status(snap, target=0.5, band=0.1, columns=columns, colour=colour,
                              title="P01/run-03  (3/10: square 10000 Hz 140 V alternating)")
        assert all(len(_ANSI.sub("", line)) < columns for line in lines)
        normal = _ANSI.sub("", next(line for line in lines if line.startswith("normal")))
        assert "[" in normal and any(w in normal for w in ("IN BAND", "TOO", "TARING",
                                                              "NO DATA"))
        # the alert is wrapped, never cut, and what a counter says is said whole
        shown = " ".join(_ANSI.sub("", line) for line in lines)
        assert not alert or " ".join(alert.split()[-3:]) in shown
        assert all(f"{name}: {text}" in shown for name, text in snap.counters.items())


def test_a_count_not_known_yet_is_said_on_the_display():
    """A cell whose counter's period is being learnt: the display says its lost frames are
    not known yet (they are left out of the count shown), and that a counter does not
    count, on the terminal, in the line for pipes, and to the live view."""
    rig = load_rig_toml(default_rig_path())
    mon = Monitor(rig, io.StringIO(), duration=10.0, tty=False)
    mon._stats = LogStats(frames=900, dropped=2, counters={"FzCell": NOT_KNOWN,
                                                          "FxCell": NOT_COUNTING})
    snap = mon.snapshot()
    assert snap.counters == {"FzCell": NOT_KNOWN, "FxCell": NOT_COUNTING}
    block = "\n".join(render_status(snap, columns=70))
    assert f"FzCell: {NOT_KNOWN}" in block and f"FxCell: {NOT_COUNTING}" in block
    line = render_line(snap)
    assert "dropped=2 [FzCell: period not yet learnt, its lost frames not known yet;" in line
    assert view_state(snap)["counters"] == snap.counters


def test_the_high_voltage_is_shown_and_decoded_from_the_status():
    on = Snapshot(3.0, hv_on=True, hv_amplitude_V=100.0, hv_frequency_Hz=10000.0,
                  hv_waveform="square")
    assert "high voltage     ON 100 V square 10000 Hz" in render_status(on)
    assert "high voltage     off" in render_status(Snapshot(3.0, hv_on=False))
    assert not any("high voltage" in line for line in render_status(Snapshot(3.0)))
    assert "HV=ON 100 V square 10000 Hz" in render_line(on)
    rig = load_rig_toml(default_rig_path())
    hv = rig.database.get_message_by_name("HvStatus")
    stats = _stats(rig, 0.5, 0.1)
    stats.latest[hv.frame_id] = can.Message(arbitration_id=hv.frame_id, data=hv.encode(
        {"HvOn": 1, "HvWave": 1, "HvCounter": 0, "HvAmp": 120.0, "HvFreq": 250.0,
         "HvCurrent": 0.0}))
    mon = Monitor(rig, io.StringIO(), duration=10.0, tty=False)
    mon._stats, mon._t0 = stats, time.monotonic() - 1.0
    snap = mon.snapshot()
    assert (snap.hv_on, snap.hv_amplitude_V, snap.hv_frequency_Hz, snap.hv_waveform) == \
        (True, pytest.approx(120.0), pytest.approx(250.0), "square")
