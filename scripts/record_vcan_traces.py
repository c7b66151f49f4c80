"""Record the reference study through a kernel's CAN stack: ``data/vcan-traces``.

Each trial of ``data/reference-study`` is played into ``vcan0`` by can-utils' ``canplayer``
(its frames at their recorded times) while ``evtribo acquire --interface socketcan`` and
``candump -L`` record it side by side, in the VM of ``tests/_vcanvm.py`` (this machine's
kernel may have no SocketCAN). The result:

- ``data/vcan-traces/study/``: a study folder as ``evtribo acquire`` wrote it (study.toml
  and rig of the reference study; logs gzip-compressed after recording, as there);
- ``data/vcan-traces/candump/SUBJECT/TRIAL.log.gz``: candump's log of the same frames.

Both logs carry the kernel's times of reception, so they are the same frames at the same
times (``tests/test_vcan_traces.py`` checks it). ::

    .venv/bin/python scripts/record_vcan_traces.py --out data/vcan-traces --force

takes about 20 s per trial and the VM's start (7-10 minutes for the 18 trials).
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

REFERENCE = ROOT / "data" / "reference-study"
#: Receive queue of candump (as evtribo's own default): nothing lost on a busy machine.
QUEUE_BYTES = 32 * 1024 * 1024
#: Seconds a trial records beyond its trace's span (canplayer may start late and lag on a
#: busy machine).
SPARE_S = 8.0


def _gzip(src: Path, dst: Path) -> None:
    """gzip *src* to *dst* reproducibly (no name, mtime 0), then remove *src*."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    with src.open("rb") as fin, dst.open("wb") as raw, \
            gzip.GzipFile(filename="", mode="wb", fileobj=raw, compresslevel=9,
                          mtime=0) as fout:
        shutil.copyfileobj(fin, fout)
    src.unlink()


def _span(log: Path) -> float:
    """Seconds from the first frame of a candump log to its last."""
    with gzip.open(log, "rt") as fh:
        lines = fh.read().splitlines()
    return float(lines[-1].split()[0].strip("()")) - float(lines[0].split()[0].strip("()"))


def record_trial(reference: Path, out: Path, tmp: Path) -> str:
    """Play one trial of the reference study into vcan0, recorded by acquire and candump."""
    subject, trial = reference.parent.name, reference.name.removesuffix(".log.gz")
    ref = json.loads(reference.with_name(f"{trial}.json").read_text(encoding="utf-8"))
    trace = tmp / "trace.log"
    with gzip.open(reference, "rb") as fin, trace.open("wb") as fout:
        shutil.copyfileobj(fin, fout)
    candump_log = tmp / "candump.log"
    with candump_log.open("wb") as fh:
        candump = subprocess.Popen(["candump", "-L", "-r", str(QUEUE_BYTES),
                                    "vcan0,0:0,#FFFFFFFF"], stdout=fh)
    notes = (f"{ref.get('notes', '')}; replayed from data/reference-study by canplayer into "
             "vcan0 and recorded there by evtribo acquire (and candump -L, in "
             "data/vcan-traces/candump)")
    args = ["acquire", "--study", str(out / "study"), "--subject", subject, "--trial", trial,
            "--interface", "socketcan", "--channel", "vcan0", "--tare-s", "0",
            "--duration", f"{_span(reference) + SPARE_S:.1f}", "--waveform", ref["waveform"],
            "--frequency", str(ref["frequency_Hz"]), "--amplitude", str(ref["amplitude_V"]),
            "--condition", ref["condition"], "--notes", notes]
    acquire = _vcanvm.Forked(args, tmp / f"{subject}-{trial}.out")
    while f"recording {subject}/{trial}" not in acquire.output():
        if acquire.poll() is not None:
            raise RuntimeError(acquire.output())
        time.sleep(0.05)
    subprocess.run(["canplayer", "-I", str(trace), "vcan0=vcan0"], check=True)
    code = acquire.wait(120)
    time.sleep(0.5)
    candump.send_signal(2)
    candump.wait(10)
    if code:
        raise RuntimeError(acquire.output())
    folder = out / "study" / subject
    _gzip(folder / f"{trial}.log", folder / f"{trial}.log.gz")
    side = json.loads((folder / f"{trial}.json").read_text(encoding="utf-8"))
    side.update(log=f"{trial}.log.gz",
                log_compressed=f"{trial}.log gzip-compressed after recording")
    (folder / f"{trial}.json").write_text(json.dumps(side, indent=2) + "\n", encoding="utf-8")
    _gzip(candump_log, out / "candump" / subject / f"{trial}.log.gz")
    return (f"{subject}/{trial}: {side['frames']} frames logged, "
            f"{side['queue_dropped_frames']} dropped by the receive queue")


def in_vm(out: Path) -> int:
    """Record every trial of the reference study (run in the VM)."""
    (out / "study").mkdir(parents=True)
    shutil.copy2(REFERENCE / "study.toml", out / "study" / "study.toml")
    shutil.copytree(REFERENCE / "rig", out / "study" / "rig")
    tmp = Path("/tmp/vcan-traces")
    tmp.mkdir(exist_ok=True)
    for log in sorted(REFERENCE.glob("P*/run-*.log.gz")):
        print(record_trial(log, out, tmp), flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Boot the VM and record the traces into ``--out``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "data" / "vcan-traces")
    parser.add_argument("--force", action="store_true", help="replace --out")
    parser.add_argument("--in-vm", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    out = args.out.resolve()
    if args.in_vm:
        return in_vm(out)
    if out.exists():
        if not args.force:
            parser.error(f"{out} exists (--force replaces it)")
        shutil.rmtree(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = out.with_name(out.name + ".part")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir()
    result = _vcanvm.run([sys.executable, str(Path(__file__).resolve()), "--in-vm", "--out",
                          str(staging)], cwd=ROOT, writable=[staging], timeout=3600)
    sys.stdout.write(result.stdout)
    sys.stderr.write(result.stderr)
    if result.returncode:
        return result.returncode
    staging.rename(out)
    print(f"{out}: VM booted in {result.boot_s:.1f} s, recorded in {result.command_s:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
