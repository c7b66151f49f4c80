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


#: The longest a test waits for what runs in real time in the VM: a guard against a hang
#: only, far beyond a busy machine's pace, s.
HANG_S = 600.0


def evtribo(args: Sequence[str], out: Path, setup: Callable[[], None] | None = None
            ) -> Forked:
    """``evtribo ARGS`` as a process (forked: nothing to import again); *setup* runs in it
    first."""
    preload()
    return Forked(list(args), out, setup)


def wait_for(proc: Forked, text: str, timeout: float = 120.0) -> None:
    """Wait until *proc* has written *text* (it must not end first)."""
    deadline = time.monotonic() + timeout
    while text not in proc.output():
        assert proc.poll() is None, f"it ended ({proc.returncode}): {proc.output()}"
        assert time.monotonic() < deadline, f"no {text!r} in {timeout:g} s: {proc.output()}"
        time.sleep(0.05)


class Candump:
    """``candump -L`` of an interface (data and error frames) into a file, with a receive
    queue as large as evtribo's; with *count*, it ends by itself once it has received that
    many frames (:meth:`stop` waits for that: every frame sent has then reached every socket
    on the interface, the recorder's too)."""

    def __init__(self, interface: str, log: Path, count: int | None = None) -> None:
        self.log = log
        self.count = count
        self._fh = log.open("wb")
        self.proc = subprocess.Popen(["candump", "-L", "-r", str(QUEUE_BYTES),
                                      *(["-n", str(count)] if count else []),
                                      f"{interface},0:0,#FFFFFFFF"], stdout=self._fh)

    def wait(self, recording: Forked | None = None) -> None:
        """Wait until it has received its *count* frames (and ended); *recording* must not
        end first."""
        deadline = time.monotonic() + HANG_S
        while self.proc.poll() is None:
            assert recording is None or recording.poll() is None, \
                f"the recording ended before the trace: {recording.output()}"
            assert time.monotonic() < deadline, f"candump got fewer than {self.count} frames"
            time.sleep(0.05)

    def stop(self) -> list[str]:
        """Its lines, once it has received its *count* frames (without one: stopped now)."""
        if self.count:
            self.wait()
        else:
            self.proc.send_signal(signal.SIGINT)
        self.proc.wait(HANG_S)
        self._fh.close()
        return self.log.read_text().splitlines()


def player(log: Path, interface: str, *, from_channel: str = "vcan0",
           ignore_times: bool = False) -> list[str]:
    """``canplayer`` playing the candump -L *log* into *interface* (at its frames' times, or
    as fast as it can with *ignore_times*), on one processor (a vcan interface delivers a
    sender's frames through the backlog queue of the processor it sends from: one moved
    between two can see two of its frames delivered swapped) and at a real-time priority
    (the recorder beside it does not delay its frames)."""
    args = ["taskset", "-c", "0", "chrt", "-f", "10", "canplayer", "-I", str(log)]
    if ignore_times:
        args.append("-t")
    return [*args, f"{interface}={from_channel}"]


def playing(log: Path, interface: str, *, from_channel: str = "vcan0",
            ignore_times: bool = False, slow_start_s: float = 0.0) -> Callable[[], None]:
    """A *setup* for :func:`evtribo` ``acquire``: canplayer plays *log* (:func:`player`)
    once the trial has started (what the bus held before read away, the trial's clock
    going), and the trial receives once canplayer's first frame is on the interface. The
    trace never races the recording's wait for the rig's frames (3 s), however long a busy
    machine takes to start canplayer (*slow_start_s* makes it take that much longer); a
    frame sent before the recording listens is none."""
    def setup() -> None:
        import evtribo.cli.recording.acquire as cli

        real = cli.record_trial
        args = player(log, interface, from_channel=from_channel, ignore_times=ignore_times)
        if slow_start_s:
            args = ["sh", "-c", f'sleep {slow_start_s:g}; exec "$@"', "sh", *args]

        def record(bus: Any, *a: Any, **kwargs: Any) -> Any:
            kwargs["started"] = lambda _paths: _play_now(args, interface)
            return real(bus, *a, **kwargs)

        cli.record_trial = record
    return setup


_PLAYERS: list[subprocess.Popen[bytes]] = []


def _play_now(args: list[str], interface: str) -> None:
    """Start canplayer (*args*); return once its first frame is on *interface*."""
    import can

    with can.Bus(interface="socketcan", channel=interface) as seen:
        proc = subprocess.Popen(args)
        _PLAYERS.append(proc)  # it ends by itself, once the trace is played
        deadline = time.monotonic() + HANG_S
        while seen.recv(1.0) is None:
            assert proc.poll() in (None, 0) and time.monotonic() < deadline, \
                "canplayer sent nothing"


def stop_when_dumped(candump: Candump, recording: Forked) -> None:
    """End *recording* with Ctrl-C once *candump* has received every frame of the trace
    (they are in the recording's socket too: it reads what its queue still holds):
    canplayer takes as long as the machine lets it (twice a trace's span on a busy one),
    which no duration given in advance fits."""
    candump.wait(recording)
    recording.send_signal(signal.SIGINT)


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
