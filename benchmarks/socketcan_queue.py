"""Frames ``evtribo acquire --interface socketcan`` loses with the system's receive queue
and with its own, on a kernel's CAN stack (the VM of ``tests/_vcanvm.py``).

A trial of the reference study (``data/vcan-traces``, ~2,000 frames/s) is played into
``vcan0`` at its frames' times by can-utils' ``canplayer`` while ``acquire`` records it,
once with ``--bus-option receive_buffer=0`` (the system's default queue, the baseline) and
once with evtribo's default (32 MiB asked for); for each it prints the frames logged, those
the kernel says the receive queue dropped (``queue_dropped_frames``), the queue granted, and
how long after the last frame was sent ``acquire`` had read them all. The VM emulates its
processors in software: a receiver far slower than a lab's laptop, as a busy one is.

Usage: ``python benchmarks/socketcan_queue.py [--trial P01/run-05]``
"""

from __future__ import annotations

import argparse
import gzip
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import _vcanvm  # noqa: E402

TRACES = ROOT / "data" / "vcan-traces" / "study"


def one(trace: Path, queue: int | None, work: Path) -> dict[str, object]:
    """Record the played *trace* with a receive queue of *queue* bytes (None: evtribo's)."""
    study = work / f"queue-{queue}"
    args = ["acquire", "--study", str(study), "--subject", "P01", "--trial", "run-01",
            "--interface", "socketcan", "--channel", "vcan0", "--tare-s", "0",
            "--duration", "600"]
    if queue is not None:
        args += ["--bus-option", f"receive_buffer={queue}"]
    total = sum(1 for _ in trace.open())
    proc = _vcanvm.Forked(args, work / f"queue-{queue}.out")
    while "recording P01/run-01" not in proc.output():
        time.sleep(0.05)
    subprocess.run(["canplayer", "-I", str(trace), "vcan0=vcan0"], check=True)
    sent = time.monotonic()
    log = study / "P01" / "run-01.log.part"
    caught_up: float | None = None
    while time.monotonic() - sent < 30:  # until acquire has read every frame (or 30 s)
        time.sleep(0.5)
        if log.exists() and log.read_text().count("\n") >= total:
            caught_up = round(time.monotonic() - sent, 1)
            break
    proc.send_signal(2)
    proc.wait(600)
    side = json.loads((study / "P01" / "run-01.json").read_text())
    return {"sent": total, "logged": side["frames"], "queue_dropped": side["queue_dropped_frames"],
            "queue_bytes": side["receive"]["queue"]["bytes"], "caught_up_s": caught_up}


def in_vm(trial: str) -> int:
    """Both recordings, in the VM; one JSON line each."""
    work = Path("/tmp/socketcan-queue")
    work.mkdir()
    trace = work / "trace.log"
    with gzip.open(TRACES / f"{trial}.log.gz", "rb") as fin, trace.open("wb") as fout:
        shutil.copyfileobj(fin, fout)
    for name, queue in (("system default (baseline)", 0), ("evtribo's default", None)):
        print(json.dumps({"queue": name, **one(trace, queue, work)}), flush=True)
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trial", default="P01/run-05", help="a trial of data/vcan-traces")
    parser.add_argument("--in-vm", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.in_vm:
        return in_vm(args.trial)
    why = _vcanvm.unavailable()
    if why:
        print(f"no VM with SocketCAN: {why}")
        return 0
    result = _vcanvm.run([sys.executable, str(Path(__file__).resolve()), "--in-vm",
                          "--trial", args.trial], cwd=ROOT, timeout=1800)
    if result.returncode:
        sys.stderr.write(result.stdout + result.stderr)
        return result.returncode
    rows = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    for row in rows:
        share = row["logged"] / row["sent"]
        late = ("" if row["caught_up_s"] is None else
                f", all read {row['caught_up_s']} s after the last was sent")
        print(f"{row['queue']:27s} queue {row['queue_bytes']:>10,} B: logged {row['logged']:,}"
              f" of {row['sent']:,} ({share:.1%}), {row['queue_dropped']:,} dropped by the "
              f"queue{late}")
    if len(rows) == 2 and rows[0]["logged"]:
        print(f"frames logged, evtribo's queue against the system's: "
              f"{rows[1]['logged'] / rows[0]['logged']:.2f}x")
    print(f"(VM booted in {result.boot_s:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
