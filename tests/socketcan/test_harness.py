"""The VM's kernel has a CAN stack: a frame sent on a vcan interface comes back with the
kernel's timestamp; and a trace played into it starts as the recording does, however long
canplayer takes to start."""

import time

import can
import pytest

from _socketcan import HANG_S, Candump, evtribo, frames_of, playing, stop_when_dumped

pytestmark = pytest.mark.slow


def test_a_frame_goes_round_a_vcan_interface(vcan):
    with can.Bus(interface="socketcan", channel=vcan) as rx, \
            can.Bus(interface="socketcan", channel=vcan) as tx:
        before = time.time()
        tx.send(can.Message(arbitration_id=0x123, data=b"\x01\x02", is_extended_id=False))
        msg = rx.recv(5.0)
    assert msg is not None and msg.arbitration_id == 0x123 and bytes(msg.data) == b"\x01\x02"
    assert before - 1 < msg.timestamp < time.time() + 1



def test_a_trace_slow_to_start_is_recorded_whole(tmp_path, vcan):
    """canplayer taking 4 s to start (longer than the 3 s a recording waits for the rig's
    frames: what a busy machine's VM took): the trace still starts as the recording does,
    and is recorded whole, in order, as candump beside it has it."""
    trace = tmp_path / "trace.log"
    trace.write_text("".join(f"(1700000000.{k * 1000:06d}) vcan0 0C1#{k:016X}\n"
                             for k in range(200)))
    lines = trace.read_text().splitlines()
    candump = Candump(vcan, tmp_path / "candump.log", count=len(lines))
    proc = evtribo(["acquire", "--study", str(tmp_path / "study"), "--subject", "P01",
                    "--trial", "run-01", "--interface", "socketcan", "--channel", vcan,
                    "--tare-s", "0", "--duration", "600", "--quiet"], tmp_path / "acquire.out",
                   setup=playing(trace, vcan, slow_start_s=4.0))
    stop_when_dumped(candump, proc)
    assert proc.wait(HANG_S) == 0, proc.output()
    got = (tmp_path / "study" / "P01" / "run-01.log").read_text().splitlines()
    assert frames_of(got) == frames_of(candump.stop()) == frames_of(lines)
