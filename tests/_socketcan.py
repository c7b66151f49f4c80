"""What the SocketCAN tests (``tests/socketcan``) share: evtribo's command line in a forked
child, can-utils, and candump -L logs written and read."""

from __future__ import annotations

import gzip
import shutil
import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from _vcanvm import Forked

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
#: candump's receive queue in the tests (evtribo's own default).
QUEUE_BYTES = 32 * 1024 * 1024


def evtribo(args: Sequence[str], out: Path) -> Forked:
    """``evtribo ARGS`` as a process (forked: nothing to import again)."""
    preload()
    return Forked(list(args), out)


def wait_for(proc: Forked, text: str, timeout: float = 120.0) -> None:
    """Wait until *proc* has written *text* (it must not end first)."""
    deadline = time.monotonic() + timeout
    while text not in proc.output():
        assert proc.poll() is None, f"it ended ({proc.returncode}): {proc.output()}"
        assert time.monotonic() < deadline, f"no {text!r} in {timeout:g} s: {proc.output()}"
        time.sleep(0.05)


class Candump:
    """``candump -L`` of an interface (data and error frames) into a file, with a receive
    queue as large as evtribo's."""

    def __init__(self, interface: str, log: Path) -> None:
        self.log = log
        self._fh = log.open("wb")
        self.proc = subprocess.Popen(["candump", "-L", "-r", str(QUEUE_BYTES),
                                      f"{interface},0:0,#FFFFFFFF"], stdout=self._fh)

    def stop(self) -> list[str]:
        """Stop it; its lines."""
        time.sleep(0.2)
        self.proc.send_signal(2)
        self.proc.wait(10)
        self._fh.close()
        return self.log.read_text().splitlines()


def play(log: Path, interface: str, *, from_channel: str = "vcan0",
         ignore_times: bool = False) -> None:
    """``canplayer`` the candump -L *log* into *interface* (at its frames' times, or as fast
    as it can with *ignore_times*), on one processor (a vcan interface delivers a sender's
    frames through the backlog queue of the processor it sends from: one moved between two
    can see two of its frames delivered swapped) and at a real-time priority (the recorder
    beside it does not delay its frames)."""
    args = ["taskset", "-c", "0", "chrt", "-f", "10", "canplayer", "-I", str(log)]
    if ignore_times:
        args.append("-t")
    subprocess.run([*args, f"{interface}={from_channel}"], check=True, timeout=600)


def play_then_stop(log: Path, interface: str, proc: Forked, *, from_channel: str = "vcan0"
                   ) -> None:
    """:func:`play` *log*, then end the recording *proc* with Ctrl-C once what was sent
    has had a second to arrive (it reads what its queue still holds): canplayer takes as
    long as the machine lets it (twice a trace's span on a busy one), which no duration
    given in advance fits."""
    play(log, interface, from_channel=from_channel)
    assert proc.poll() is None, f"the recording ended before the trace: {proc.output()}"
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)


def kernel_drops(interface: str) -> dict[str, int]:
    """What the kernel dropped before any socket saw it: the interface's ``rx_dropped``
    and ``tx_dropped``, and the processors' backlog queues' drops (``/proc/net/softnet_stat``'s
    second column, summed; ``net.core.netdev_max_backlog``)."""
    stats = Path("/sys/class/net") / interface / "statistics"
    out = {name: int((stats / name).read_text()) for name in ("rx_dropped", "tx_dropped")}
    rows = Path("/proc/net/softnet_stat").read_text().split("\n")
    out["backlog_dropped"] = sum(int(row.split()[1], 16) for row in rows if row.strip())
    return out


def unzip(log_gz: Path, to: Path) -> Path:
    """The log *log_gz* uncompressed into the folder *to*."""
    out = to / log_gz.name.removesuffix(".gz")
    with gzip.open(log_gz, "rb") as fin, out.open("wb") as fout:
        shutil.copyfileobj(fin, fout)
    return out


def frames_of(lines: Sequence[str]) -> list[str]:
    """The ``ID#DATA`` field of each candump -L line (no time, no channel)."""
    return [line.split()[2] for line in lines]


def times_of(lines: Sequence[str]) -> list[str]:
    """The ``(seconds.micros)`` field of each candump -L line."""
    return [line.split()[0] for line in lines]


def without_fdf(fields: Sequence[str]) -> list[str]:
    """``ID#DATA`` fields with the ``CANFD_FDF`` bit (4) of an FD frame's flags digit cleared:
    Linux 6 sets it on every FD frame it receives (candump and evtribo write it), a log
    written by another program may not."""
    out = []
    for field in fields:
        head, fd, rest = field.partition("##")
        out.append(f"{head}##{int(rest[0], 16) & ~4:X}{rest[1:]}" if fd else field)
    return out


@dataclass(frozen=True)
class HostSteps:
    """What a SocketCAN test leaves to the machine the suite runs on (its processors are not
    emulated): *before* it, *after* it, each given the test's ``exports`` folder."""

    before: Callable[[Path], None] | None = None
    after: Callable[[Path], None] | None = None


_Test = TypeVar("_Test", bound=Callable[..., Any])


def on_host(*, before: Callable[[Path], None] | None = None,
            after: Callable[[Path], None] | None = None) -> Callable[[_Test], _Test]:
    """Mark a SocketCAN test's steps that run on the host (``tests/socketcan/conftest.py``):
    *before* the VM boots (a trace to play), *after* it (the analysis of what was recorded).
    The test requests the ``exports`` fixture: the folder they share."""
    def mark(test: _Test) -> _Test:
        test.host_steps = HostSteps(before, after)  # type: ignore[attr-defined]
        return test
    return mark


def preload() -> None:
    """Import what ``evtribo acquire``, ``simulate`` and ``session`` import when they run, in
    this process: the commands forked from it then import nothing (in the VM, an import of
    numpy and pandas takes 20-60 s)."""
    import evtribo.acquisition.buses.socketcan
    import evtribo.acquisition.simulator
    import evtribo.acquisition.trial
    import evtribo.cli.recording.acquire
    import evtribo.cli.recording.session
    import evtribo.cli.recording.simulate
    import evtribo.session  # noqa: F401
