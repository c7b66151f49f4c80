"""The amplifier under command: the excitation command frames and their schedule."""

from __future__ import annotations

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.command import Excitation, ExcitationCommand, _Holder
from evtribo.canlog.rig import default_rig
from evtribo.errors import RigConfigError

ROLES = {"excitation_command_enabled": "HvCmd.HvOn",
         "excitation_command_amplitude": "HvCmd.HvAmp",
         "excitation_command_frequency": "HvCmd.HvFreq",
         "excitation_command_waveform": "HvCmd.HvWave"}


@settings(max_examples=40, deadline=None)
@given(on=st.booleans(), amp=st.floats(0, 600), freq=st.floats(0, 100_000),
       wave=st.sampled_from(["sine", "square", "Square"]))
def test_command_frame_decodes_to_the_state(on, amp, freq, wave):
    db = default_rig().database
    frame = ExcitationCommand(None, db, ROLES).frame(Excitation(on, amp, freq, wave))
    msg = db.get_message_by_name("HvCmd")
    assert frame.arbitration_id == msg.frame_id and not frame.is_extended_id
    got = msg.decode(frame.data, decode_choices=True)
    assert got["HvOn"] == int(on) and str(got["HvWave"]) == wave.lower()
    assert got["HvAmp"] == pytest.approx(amp, abs=0.005 + 1e-9)  # half its 0.01 V scale
    assert got["HvFreq"] == pytest.approx(freq, abs=0.005 + 1e-9)


def test_commands_reach_the_bus_and_end_off():
    db = default_rig().database
    with can.Bus(interface="virtual", channel="cmd-test") as tx, \
            can.Bus(interface="virtual", channel="cmd-test") as rx:
        command = ExcitationCommand(tx, db, ROLES)
        with command.hold(Excitation(True, 100.0, 10_000.0, "square"), "on"):
            first = rx.recv(timeout=5)
        frames = [first]
        while (m := rx.recv(timeout=0.2)) is not None:
            frames.append(m)
    decoded = [db.decode_message(m.arbitration_id, m.data) for m in frames]
    assert decoded[0]["HvOn"] == 1 and decoded[0]["HvAmp"] == pytest.approx(100.0)
    assert decoded[-1]["HvOn"] == 0  # leaving the context commands the amplifier off


@settings(max_examples=50, deadline=None)
@given(t=st.floats(0, 100), tare=st.floats(0, 3), on_s=st.floats(0.5, 5),
       off_s=st.floats(0.5, 5))
def test_alternating_schedule(t, tare, on_s, off_s):
    command = ExcitationCommand(None, default_rig().database, ROLES)
    state = Excitation(True, 100.0, 10_000.0, "square")
    kw = {"off_first_s": tare, "on_s": on_s, "off_s": off_s}
    h = _Holder(command, state, "alternating", **kw)
    expected = t >= tare and ((t - tare) % (on_s + off_s)) >= off_s
    assert h.enabled_at(t) == expected
    assert not _Holder(command, state, "off", **kw).enabled_at(t)
    assert _Holder(command, state, "on", **kw).enabled_at(t) == (t >= tare)


def test_command_roles_in_two_messages_are_refused():
    roles = {**ROLES, "excitation_command_amplitude": "HvStatus.HvAmp"}
    with pytest.raises(RigConfigError, match="one message"):
        ExcitationCommand(None, default_rig().database, roles)


def test_unknown_waveform_names_the_key():
    command = ExcitationCommand(None, default_rig().database, ROLES)
    with pytest.raises(RigConfigError, match="no waveform 'saw'") as err:
        command.frame(Excitation(True, 1.0, 1.0, "saw"))
    assert err.value.key == "excitation_command_waveform"


def test_the_phases_begin_when_the_recording_does():
    """A session holds the amplifier off until the trial's log is open (begin=False, then
    begin()): however long a busy machine takes to open it, the first phase is the tare's
    off stretch of the recording itself."""
    db = default_rig().database
    with can.Bus(interface="virtual", channel="cmd-begin") as tx, \
            can.Bus(interface="virtual", channel="cmd-begin") as rx:
        command = ExcitationCommand(tx, db, ROLES)
        with command.hold(Excitation(True, 100.0, 10_000.0, "square"), "on",
                          begin=False) as holder:
            waiting = [db.decode_message(m.arbitration_id, m.data)["HvOn"]
                       for m in (rx.recv(timeout=60) for _ in range(5))]
            holder.begin()
            for _ in range(10_000):  # the next commands are on (a loaded machine: later)
                m = rx.recv(timeout=60)
                if db.decode_message(m.arbitration_id, m.data)["HvOn"]:
                    break
            else:
                pytest.fail("never commanded on after begin()")
    assert waiting == [0] * 5
