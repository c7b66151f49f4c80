"""The VM's kernel has a CAN stack: a frame sent on a vcan interface comes back with the
kernel's timestamp."""

import time

import can
import pytest

pytestmark = pytest.mark.slow


def test_a_frame_goes_round_a_vcan_interface(vcan):
    with can.Bus(interface="socketcan", channel=vcan) as rx, \
            can.Bus(interface="socketcan", channel=vcan) as tx:
        before = time.time()
        tx.send(can.Message(arbitration_id=0x123, data=b"\x01\x02", is_extended_id=False))
        msg = rx.recv(5.0)
    assert msg is not None and msg.arbitration_id == 0x123 and bytes(msg.data) == b"\x01\x02"
    assert before - 1 < msg.timestamp < time.time() + 1

