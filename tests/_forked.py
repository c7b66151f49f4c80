"""Running ``evtribo`` commands in forked processes, to kill them, stop them or starve them.

A forked child shares the test process's imported modules (so it starts in milliseconds)
and runs :func:`evtribo.cli.main`; what it prints goes to a file the test reads.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import resource
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

FORK = multiprocessing.get_context("fork")


def _child(argv: Sequence[str], log: str, setup: Callable[[], None] | None) -> None:
    fh = open(log, "w", encoding="utf-8")
    sys.stdout = sys.stderr = fh
    os.dup2(fh.fileno(), 1)
    os.dup2(fh.fileno(), 2)
    if setup is not None:
        setup()
    from evtribo.cli import main

    code = main(list(argv))
    fh.flush()
    os._exit(code)


def start(argv: Sequence[str], log: Path, setup: Callable[[], None] | None = None
          ) -> Any:
    """Start ``evtribo *argv`` in a forked process (``setup()`` runs in it first)."""
    proc = FORK.Process(target=_child, args=([os.fspath(a) for a in argv], os.fspath(log),
                                             setup))
    proc.start()
    return proc


def run(argv: Sequence[str], log: Path, setup: Callable[[], None] | None = None
        ) -> tuple[int, str]:
    """Run ``evtribo *argv`` in a forked process; its exit code and what it printed."""
    proc = start(argv, log, setup)
    proc.join(120)
    return proc.exitcode, log.read_text(encoding="utf-8")


def file_size_limit(limit: int) -> Callable[[], None]:
    """A setup that lets the process write no file beyond *limit* bytes (EFBIG, as a full
    disk would refuse the write)."""
    def setup() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))
    return setup


#: The capabilities through which root ignores a file's mode (CAP_DAC_OVERRIDE,
#: CAP_DAC_READ_SEARCH, CAP_FOWNER).
_MODE_OVERRIDES = (1, 2, 3)


def modes_apply() -> None:
    """A setup under which a file's mode applies to the process even if it runs as root
    (the tests' machines do; root ignores a folder's mode 555 and a file's mode 000):
    root's capabilities to override it are dropped, for good (``capset``), and the process
    is held to the modes as the files' owner (the tests' folders stay its own): a file of
    mode 000 cannot be read, a folder of mode 000 neither listed nor entered. Nothing to do
    for another user."""
    if os.geteuid() != 0:
        return
    import ctypes

    class Header(ctypes.Structure):
        _fields_ = [("version", ctypes.c_uint32), ("pid", ctypes.c_int)]

    class Data(ctypes.Structure):
        _fields_ = [("effective", ctypes.c_uint32), ("permitted", ctypes.c_uint32),
                    ("inheritable", ctypes.c_uint32)]

    libc = ctypes.CDLL(None, use_errno=True)
    header, data = Header(0x20080522, 0), (Data * 2)()  # _LINUX_CAPABILITY_VERSION_3
    if libc.capget(ctypes.byref(header), data) != 0:
        raise OSError(ctypes.get_errno(), "capget")
    for bit in _MODE_OVERRIDES:
        data[bit // 32].effective &= ~(1 << bit % 32)
        data[bit // 32].permitted &= ~(1 << bit % 32)
        data[bit // 32].inheritable &= ~(1 << bit % 32)
    if libc.capset(ctypes.byref(header), data) != 0:
        raise OSError(ctypes.get_errno(), "capset")


def _call_child(conn: Any, setup: Callable[[], None] | None, func: Callable[..., Any],
                args: tuple[Any, ...]) -> None:
    try:
        if setup is not None:
            setup()
        conn.send(("returned", func(*args)))
    except BaseException as err:  # sent back whole: the test asserts on it
        conn.send(("raised", err))
    finally:
        conn.close()


def call(func: Callable[..., Any], *args: Any, setup: Callable[[], None] | None = None
         ) -> tuple[str, Any]:
    """``func(*args)`` in a forked process (``setup()`` run in it first): ``("returned",
    value)`` or ``("raised", error)``, both sent back pickled."""
    parent, child = FORK.Pipe(duplex=False)
    proc = FORK.Process(target=_call_child, args=(child, setup, func, args))
    proc.start()
    child.close()
    try:
        if not parent.poll(120):
            raise TimeoutError(f"{func.__name__} did not return within 120 s")
        return parent.recv()
    finally:
        parent.close()
        proc.join(30)


def children(pid: int) -> list[int]:
    """The processes whose parent is *pid* (from /proc)."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[1]) == pid:
            out.append(int(entry))
    return out


def alive(pid: int) -> bool:
    """True while *pid* exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


def tree(folder: Path) -> dict[str, bytes]:
    """Every file under *folder*: relative name -> bytes."""
    if not folder.is_dir():
        return {}
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def run_id(folder: Path) -> str:
    return json.loads((folder / "summary.json").read_text(encoding="utf-8"))["run_id"]
