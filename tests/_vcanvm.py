"""A throw-away qemu VM whose Linux kernel has SocketCAN, for the tests that need a kernel's
CAN stack (this machine's kernel may have none, and may load no module).

The guest is Debian's own kernel (the ``linux-image-amd64`` package: its ``can``,
``can_raw`` and ``vcan`` modules) booted by ``qemu-system-x86_64`` with a busybox
initramfs. The host's whole file system is the guest's root (a read-only 9p share with a
tmpfs overlay, so the guest may write anywhere and nothing reaches the host), and the guest
runs one command, in the same folder, as root, with ``vcan0`` up. The checkout's ``.venv``
and can-utils (``canplayer``, ``candump``, ``cangen``) therefore run in the guest as they
are. A second 9p share, read-write, brings the command's output back.

``make vcan-vm`` prepares it (installs ``qemu-system-x86``, ``can-utils`` and
``busybox-static`` with apt when they are missing, downloads the kernel's package and
unpacks what the VM needs into :data:`CACHE`); ``python tests/_vcanvm.py prepare`` does the
download and unpacking alone, ``python tests/_vcanvm.py run -- CMD...`` runs a command in the
VM. The tests never download anything: :func:`unavailable` says why the VM cannot run here
(no qemu, no kernel prepared), and the SocketCAN tests skip with that reason.

Measured on the 2-core development machine (software emulation, TCG): the kernel reaches
the command in 4-14 s; ``import numpy, pandas, can, cantools`` then takes ~20 s in the
guest (9p reads, emulated CPU). Boot one VM and run every SocketCAN test in it.
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import io
import lzma
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

#: Where the kernel, its modules and the initramfs are kept.
CACHE = Path(os.environ.get("EVTRIBO_VCAN_VM_CACHE")
             or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
             / "evtribo" / "vcan-vm")
#: The Debian package whose kernel the guest boots.
KERNEL_META = "linux-image-amd64"
#: Modules loaded in the guest, in this order, after the ones they depend on.
MODULES = ("virtio_pci", "9pnet_virtio", "9p", "overlay", "virtio_rng", "can", "can_raw",
           "vcan")
#: Host programs the VM and the tests need, and the Debian package of each.
PROGRAMS = {"qemu-system-x86_64": "qemu-system-x86", "canplayer": "can-utils",
            "candump": "can-utils", "busybox": "busybox-static"}

INIT = r"""#!/bin/busybox sh
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
fail() { echo "VCANVM-ERROR: $*"; poweroff -f; }
for m in $(cat /modules.order); do insmod /mod/$m.ko || echo "VCANVM: insmod $m failed"; done
OUT=; RWS=
for x in $(cat /proc/cmdline); do
    case $x in vcanvm.out=*) OUT=${x#vcanvm.out=};; vcanvm.rw=*) RWS="$RWS ${x#vcanvm.rw=}";; esac
done
[ -n "$OUT" ] || fail "no vcanvm.out= on the kernel command line"
mkdir -p /host /ovl /newroot
mount -t 9p -o trans=virtio,version=9p2000.L,ro,msize=512000,cache=loose hostroot /host \
    || fail "mount hostroot"
mount -t tmpfs -o mode=0755 tmpfs /ovl
mkdir -p /ovl/upper /ovl/work
mount -t overlay overlay -o lowerdir=/host,upperdir=/ovl/upper,workdir=/ovl/work /newroot \
    || fail "overlay"
mount -t proc proc /newroot/proc
mount -t sysfs sys /newroot/sys
mount -t devtmpfs dev /newroot/dev
mkdir -p /newroot/dev/pts /newroot/dev/shm
mount -t devpts -o ptmxmode=0666,mode=0620 devpts /newroot/dev/pts
ln -sf /proc/self/fd /newroot/dev/fd
mount -t tmpfs tmpfs /newroot/dev/shm
mount -t tmpfs tmpfs /newroot/run
mount -t tmpfs tmpfs /newroot/tmp
mkdir -p "/newroot$OUT"
mount -t 9p -o trans=virtio,version=9p2000.L,msize=512000 out "/newroot$OUT" || fail "mount out"
for r in $RWS; do
    mkdir -p "/newroot${r#*:}"
    mount -t 9p -o trans=virtio,version=9p2000.L,msize=512000 "${r%%:*}" "/newroot${r#*:}" \
        || fail "mount $r"
done
ip link set lo up
chroot /newroot ip link add dev vcan0 type vcan || fail "ip link add vcan0"
ip link set up vcan0 || fail "ip link set up vcan0"
# canplayer at a real-time priority can send faster than the softirq drains the processor's
# backlog queue (1000 frames by default); the kernel drops what is beyond it before any
# socket sees it (483 frames of a replayed trace, 4000 of a 5000-frame burst)
echo 100000 > /proc/sys/net/core/netdev_max_backlog || fail "netdev_max_backlog"
hostname vcanvm
echo "VCANVM-START $(cut -d' ' -f1 /proc/uptime)"
chroot /newroot /bin/sh "$OUT/cmd.sh" > "/newroot$OUT/stdout" 2> "/newroot$OUT/stderr" < /dev/null
echo $? > "/newroot$OUT/rc"
echo "VCANVM-END $(cut -d' ' -f1 /proc/uptime)"
sync
umount "/newroot$OUT"
poweroff -f
"""


#: Folders the guest mounts a tmpfs of its own on (INIT): a checkout inside one of them is
#: shared with the guest on its own, or the guest would not see it.
GUEST_TMPFS = (Path("/tmp"), Path("/run"), Path("/dev/shm"))


class Unavailable(RuntimeError):
    """The VM cannot run on this machine (the message says why, and what to do)."""


@dataclass
class Kernel:
    """A prepared kernel: the image to boot and the initramfs with its modules."""

    version: str
    image: Path
    initramfs: Path


@dataclass
class GuestResult:
    """What a command run in the VM did.

    Attributes
    ----------
    returncode : int
        The command's exit status.
    stdout, stderr : str
    boot_s : float
        Seconds from the kernel's start to the command's (the guest's uptime).
    command_s : float
        Seconds the command ran (the guest's uptime).
    wall_s : float
        Seconds from starting qemu to its end, on the host.
    console : str
        The guest's console (kernel and init messages).
    files : dict
        The text of each file the command left in ``$VCANVM_OUT`` (a read-write folder).
    """

    returncode: int
    stdout: str
    stderr: str
    boot_s: float
    command_s: float
    wall_s: float
    console: str
    files: dict[str, str]


def _apt_env() -> dict[str, str]:
    return {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}


def kernel_package() -> str:
    """The versioned kernel package ``linux-image-amd64`` depends on now
    (``linux-image-6.1.0-56-amd64``)."""
    out = subprocess.run(["apt-cache", "depends", KERNEL_META], capture_output=True,
                         text=True, check=False).stdout
    for line in out.splitlines():
        dep = line.strip().removeprefix("Depends:").strip()
        if line.strip().startswith("Depends:") and dep.startswith("linux-image-"):
            return dep
    raise Unavailable(f"apt knows no kernel package behind {KERNEL_META} "
                      "(apt-get update?)")


def download_kernel() -> Path:
    """Download (not install) the kernel's package into the cache; return the ``.deb``."""
    debs = CACHE / "debs"
    debs.mkdir(parents=True, exist_ok=True)
    package = kernel_package()
    found = sorted(debs.glob(f"{package}_*.deb"))
    if not found:
        subprocess.run(["apt-get", "download", package], cwd=debs, check=True,
                       env=_apt_env())
        found = sorted(debs.glob(f"{package}_*.deb"))
    if not found:
        raise Unavailable(f"apt-get download {package} left no .deb in {debs}")
    return found[-1]


def _uncompressed(data: bytes, name: str) -> bytes:
    if name.endswith(".xz"):
        return lzma.decompress(data)
    if name.endswith(".gz"):
        return gzip.decompress(data)
    if name.endswith(".zst"):
        return subprocess.run(["zstd", "-dc"], input=data, capture_output=True,
                              check=True).stdout
    return data


def _depends(module: bytes) -> list[str]:
    """The ``depends=`` of a kernel module's ``.modinfo``."""
    for field in module.split(b"\0"):
        if field.startswith(b"depends="):
            return [d.replace("-", "_") for d in field[8:].decode().split(",") if d]
    return []


def _pvh_vmlinux(vmlinuz: bytes) -> bytes | None:
    """The uncompressed kernel inside a bzImage, when it has a PVH entry (qemu boots it
    directly: ~11 s to the command instead of ~22 s under TCG), else None."""
    for magic, unpack in ((b"\xfd7zXZ\x00", lzma.LZMADecompressor),
                          (b"\x1f\x8b\x08", None)):
        start = vmlinuz.find(magic)
        while start >= 0:
            try:
                if unpack is None:
                    elf = gzip.GzipFile(fileobj=io.BytesIO(vmlinuz[start:])).read()
                else:
                    elf = unpack().decompress(vmlinuz[start:])
            except (lzma.LZMAError, OSError, EOFError):
                elf = b""
            if elf.startswith(b"\x7fELF") and _has_pvh_note(elf):
                return elf
            start = vmlinuz.find(magic, start + 1)
    return None


def _has_pvh_note(elf: bytes) -> bool:
    """Whether an ELF kernel has the Xen ELF note ``XEN_ELFNOTE_PHYS32_ENTRY`` (18)."""
    note = b"\x04\x00\x00\x00"  # name size 4 ("Xen\0")
    at = elf.find(note)
    while at >= 0:
        if elf[at + 8:at + 12] == (18).to_bytes(4, "little") and elf[at + 12:at + 16] == b"Xen\0":
            return True
        at = elf.find(note, at + 1)
    return False


def unpack_kernel(deb: Path) -> Path:
    """Unpack the kernel image and the modules the guest loads from *deb* into the cache;
    return the kernel's folder (written whole, then renamed: safe from a parallel run)."""
    with tempfile.TemporaryDirectory(dir=CACHE) as tmp:
        tree = Path(tmp) / "tree"
        tree.mkdir()
        with subprocess.Popen(["dpkg-deb", "--fsys-tarfile", str(deb)],
                              stdout=subprocess.PIPE) as tar:
            subprocess.run(["tar", "-x", "-C", str(tree), "--wildcards", "./boot/vmlinuz-*",
                            "./lib/modules/*"], stdin=tar.stdout, check=True)
        if tar.returncode:
            raise Unavailable(f"dpkg-deb could not read {deb}")
        (vmlinuz,) = (tree / "boot").glob("vmlinuz-*")
        version = vmlinuz.name.removeprefix("vmlinuz-")
        out = Path(tmp) / version
        (out / "mod").mkdir(parents=True)
        by_name = {}
        for path in (tree / "lib" / "modules" / version).rglob("*.ko*"):
            by_name[path.name.split(".ko")[0].replace("-", "_")] = path
        order: list[str] = []

        def add(name: str) -> None:
            if name in order:
                return
            if name not in by_name:  # built into the kernel
                return
            data = _uncompressed(by_name[name].read_bytes(), by_name[name].name)
            for dep in _depends(data):
                add(dep)
            (out / "mod" / f"{name}.ko").write_bytes(data)
            order.append(name)

        for name in MODULES:
            add(name)
        (out / "modules.order").write_text("\n".join(order) + "\n")
        image = vmlinuz.read_bytes()
        (out / "vmlinuz").write_bytes(image)
        elf = _pvh_vmlinux(image)
        if elf is not None:
            (out / "vmlinux").write_bytes(elf)
        target = CACHE / f"kernel-{version}"
        try:
            out.rename(target)
        except OSError:
            if not (target / "modules.order").exists():
                raise
    return target


def _static_busybox() -> Path:
    path = shutil.which("busybox") or "/bin/busybox"
    head = Path(path).read_bytes() if Path(path).exists() else b""
    if not head.startswith(b"\x7fELF") or b"/ld-linux" in head[:4096]:
        raise Unavailable(f"{path} is not a static busybox: apt-get install busybox-static")
    return Path(path)


def build_initramfs(kdir: Path) -> Path:
    """The initramfs (busybox, the modules, :data:`INIT`) of the kernel in *kdir*."""
    busybox = _static_busybox()
    order = (kdir / "modules.order").read_text().split()
    key = hashlib.sha256(INIT.encode() + busybox.read_bytes() + " ".join(order).encode())
    target = kdir / f"initramfs-{key.hexdigest()[:12]}.cpio.gz"
    if target.exists():
        return target
    with tempfile.TemporaryDirectory(dir=kdir) as tmp:
        root = Path(tmp) / "root"
        for d in ("bin", "dev", "proc", "sys", "mod", "host", "ovl", "newroot"):
            (root / d).mkdir(parents=True)
        shutil.copy2(busybox, root / "bin" / "busybox")
        (root / "init").write_text(INIT)
        (root / "init").chmod(0o755)
        (root / "modules.order").write_text("\n".join(order) + "\n")
        for m in order:
            shutil.copy2(kdir / "mod" / f"{m}.ko", root / "mod" / f"{m}.ko")
        names = sorted(str(p.relative_to(root)) for p in root.rglob("*"))
        data = subprocess.run([str(busybox), "cpio", "-o", "-H", "newc"], cwd=root,
                              input=("\n".join([".", *names]) + "\n").encode(),
                              capture_output=True, check=True).stdout
        part = Path(tmp) / "initramfs.gz"
        part.write_bytes(gzip.compress(data, compresslevel=1))
        part.replace(target)
    return target


def _kvm_usable() -> bool:
    """Hardware KVM (``/dev/kvm`` alone may be a paravirtual hypervisor's, which boots no
    Debian kernel: then software emulation it is)."""
    return os.access("/dev/kvm", os.R_OK | os.W_OK) and any(
        Path(f"/sys/module/{m}").is_dir() for m in ("kvm_intel", "kvm_amd"))


def prepared_kernel() -> Kernel:
    """The newest kernel in the cache, with its initramfs (built when missing).

    Raises
    ------
    Unavailable
        No qemu, no static busybox, or no kernel in the cache (``make vcan-vm`` makes one).
    """
    missing = sorted({pkg for prog, pkg in PROGRAMS.items() if shutil.which(prog) is None})
    if missing:
        raise Unavailable(f"not installed: {' '.join(missing)} (make vcan-vm installs them)")
    kernels = sorted(CACHE.glob("kernel-*/modules.order"))
    if not kernels:
        raise Unavailable(f"no kernel for the VM in {CACHE} (make vcan-vm downloads Debian's "
                          f"{KERNEL_META} and prepares it)")
    kdir = kernels[-1].parent
    image = kdir / "vmlinux" if (kdir / "vmlinux").exists() else kdir / "vmlinuz"
    return Kernel(kdir.name.removeprefix("kernel-"), image, build_initramfs(kdir))


def unavailable() -> str | None:
    """Why the VM cannot run here (None: it can)."""
    try:
        prepared_kernel()
    except Unavailable as err:
        return str(err)
    return None


def _command_file(argv: Sequence[str], cwd: Path, env: Mapping[str, str], out: Path) -> str:
    lines = ["# written by tests/_vcanvm.py"]
    lines += [f"export {k}={shlex.quote(v)}" for k, v in env.items()]
    lines.append(f"export VCANVM_OUT={shlex.quote(str(out / 'files'))}")
    lines.append(f"cd {shlex.quote(str(cwd))} || exit 126")
    lines.append("exec " + " ".join(shlex.quote(a) for a in argv))
    return "\n".join(lines) + "\n"


def _uptimes(console: str) -> tuple[float, float]:
    start = end = float("nan")
    for line in console.splitlines():
        if line.startswith("VCANVM-START "):
            start = float(line.split()[1])
        elif line.startswith("VCANVM-END "):
            end = float(line.split()[1])
    return start, end - start


def run(argv: Sequence[str], *, cwd: str | os.PathLike[str] | None = None,
        env: Mapping[str, str] | None = None, timeout: float = 900.0, memory_mb: int = 1536,
        cpus: int = 2, writable: Sequence[str | os.PathLike[str]] = ()) -> GuestResult:
    """Boot the VM, run *argv* in it (as root, in *cwd*, with *env* only), power it off.

    The command may leave files in the folder ``$VCANVM_OUT``: their text comes back in
    :attr:`GuestResult.files`.

    Parameters
    ----------
    argv : sequence of str
        The command (a program on the host's file system).
    cwd : path, optional
        Folder it runs in (default: the current one).
    env : mapping, optional
        Its whole environment (default: ``PATH``, ``HOME``, ``LANG``).
    timeout : float, s
        The VM is killed after this long (:class:`subprocess.TimeoutExpired` is raised).
    memory_mb, cpus : int
        The guest's memory and processors.
    writable : sequence of paths
        Host folders the guest may write to (at the same path; no spaces or commas).

    Returns
    -------
    GuestResult

    Raises
    ------
    Unavailable
        The VM cannot run here.
    RuntimeError
        The guest did not run the command (its console is in the message).
    """
    kernel = prepared_kernel()
    env = dict(env or {"PATH": "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin",
                       "HOME": "/root", "LANG": "C.UTF-8"})
    with tempfile.TemporaryDirectory(prefix="vcanvm-") as tmp:
        out = Path(tmp)
        (out / "files").mkdir()
        (out / "cmd.sh").write_text(_command_file(argv, Path(cwd or os.getcwd()), env, out))
        accel = (["-accel", "kvm", "-cpu", "host"] if _kvm_usable() else
                 ["-accel", "tcg,thread=multi,tb-size=256", "-cpu", "max"])  # numpy: AVX2
        append = ("console=ttyS0 quiet loglevel=3 panic=-1 mitigations=off "
                  f"random.trust_cpu=on vcanvm.out={out}")
        shares = []
        folders = [Path(w).resolve(strict=True) for w in writable]
        here = Path(cwd or os.getcwd()).resolve()
        if any(here.is_relative_to(t) for t in GUEST_TMPFS) and \
                not any(here.is_relative_to(f) for f in folders):
            folders.append(here)  # the guest has its own tmpfs there: bring the checkout
        for k, folder in enumerate(folders):
            append += f" vcanvm.rw=rw{k}:{folder}"
            shares += ["-virtfs", f"local,path={folder},mount_tag=rw{k},security_model=none,"
                       "multidevs=remap"]
        qemu = ["qemu-system-x86_64", *accel, "-M", "pc", "-m", str(memory_mb),
                "-smp", str(cpus), "-nodefaults", "-no-user-config", "-display", "none",
                "-monitor", "none", "-serial", f"file:{out / 'console.log'}", "-no-reboot",
                "-kernel", str(kernel.image), "-initrd", str(kernel.initramfs),
                "-append", append,
                "-virtfs", "local,path=/,mount_tag=hostroot,security_model=none,readonly=on,"
                "multidevs=remap",
                "-virtfs", f"local,path={out},mount_tag=out,security_model=none,"
                "multidevs=remap", *shares,
                "-device", "virtio-rng-pci"]
        t0 = time.monotonic()
        with subprocess.Popen(qemu, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT) as proc:
            try:
                qemu_out, _ = proc.communicate(timeout=timeout)
            except BaseException:
                proc.kill()
                proc.communicate()
                raise
        wall = time.monotonic() - t0
        console = (out / "console.log").read_text(errors="replace") \
            if (out / "console.log").exists() else ""
        if not (out / "rc").exists():
            raise RuntimeError(f"the VM did not run the command (qemu exit {proc.returncode}"
                               f"): {qemu_out.decode(errors='replace')}\n{console[-4000:]}")
        boot, ran = _uptimes(console)
        return GuestResult(
            returncode=int((out / "rc").read_text().strip() or 125),
            stdout=(out / "stdout").read_text(errors="replace"),
            stderr=(out / "stderr").read_text(errors="replace"),
            boot_s=boot, command_s=ran, wall_s=wall, console=console,
            files={f.name: f.read_text(errors="replace")
                   for f in (out / "files").iterdir() if f.is_file()})


class Forked:
    """``evtribo ARGS`` run in a forked child of this process, as its own process (its exit
    code, its signals, its output in files), without a new interpreter's imports: in the
    VM, under software emulation, a fresh ``python -m evtribo acquire`` takes 20-90 s to
    import what this process has imported already.

    Parameters
    ----------
    args : sequence of str
        The command line after ``evtribo``.
    out : path
        Standard output goes to this file, standard error to ``<out>.err``.
    setup : callable, optional
        Run in the child before the command (to hook into it, as a test's fixture would).

    Fork it from a process without other threads (a test's, under ``pytest -n 0``).
    """

    def __init__(self, args: Sequence[str], out: str | os.PathLike[str],
                 setup: Callable[[], None] | None = None) -> None:
        self.setup = setup
        self.out = Path(out)
        self.err = self.out.with_name(self.out.name + ".err")
        self.returncode: int | None = None
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child
            self._child(list(args))
        self.pid = pid

    def _child(self, args: list[str]) -> None:
        import logging
        import signal
        import traceback
        import warnings

        code = 70
        try:
            for fd, path in ((1, self.out), (2, self.err)):
                target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
                os.dup2(target, fd)
                os.close(target)
            sys.stdout = open(1, "w", buffering=1, closefd=False)
            sys.stderr = open(2, "w", buffering=1, closefd=False)
            signal.signal(signal.SIGINT, signal.default_int_handler)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            logging.root.handlers.clear()  # the test's capture: the command sets its own
            warnings.resetwarnings()
            if self.setup is not None:
                self.setup()
            from evtribo.cli import main

            code = main(args)
        except SystemExit as err:
            code = err.code if isinstance(err.code, int) else 1
        except BaseException:
            traceback.print_exc()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)

    def send_signal(self, signum: int) -> None:
        """Send *signum* to the command (nothing once it has ended)."""
        if self.returncode is None:
            os.kill(self.pid, signum)

    def poll(self) -> int | None:
        """The exit code, or None while it runs."""
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float) -> int:
        """Wait at most *timeout* s for the end (then kill it: TimeoutError)."""
        deadline = time.monotonic() + timeout
        while self.poll() is None:
            if time.monotonic() > deadline:
                os.kill(self.pid, 9)
                os.waitpid(self.pid, 0)
                self.returncode = -9
                raise TimeoutError(f"evtribo did not end in {timeout:g} s: {self.output()}")
            time.sleep(0.05)
        assert self.returncode is not None
        return self.returncode

    def output(self) -> str:
        """What it wrote so far, standard output then standard error."""
        return "".join(f.read_text(errors="replace") for f in (self.out, self.err)
                       if f.exists())


def prepare(download: bool) -> Kernel:
    """Everything the VM needs in the cache; with *download*, the kernel's package is
    fetched with ``apt-get download`` when the cache has none."""
    CACHE.mkdir(parents=True, exist_ok=True)
    if download and not list(CACHE.glob("kernel-*/modules.order")):
        deb = download_kernel()
        unpack_kernel(deb)
        deb.unlink()  # the kernel's folder is all the VM needs
    return prepared_kernel()


def main(argv: Sequence[str] | None = None) -> int:
    """``prepare`` (download and unpack the kernel, build the initramfs) or ``run -- CMD``."""
    parser = argparse.ArgumentParser(prog="tests/_vcanvm.py", description=__doc__)
    sub = parser.add_subparsers(dest="what", required=True)
    sub.add_parser("prepare", help="download and unpack the kernel, build the initramfs")
    runp = sub.add_parser("run", help="run a command in the VM")
    runp.add_argument("--timeout", type=float, default=900.0)
    runp.add_argument("command", nargs="+")
    args = parser.parse_args(argv)
    try:
        if args.what == "prepare":
            t0 = time.monotonic()
            kernel = prepare(download=True)
            print(f"vcan VM ready ({time.monotonic() - t0:.1f} s): kernel {kernel.version}, "
                  f"{kernel.image}, {kernel.initramfs}")
            return 0
        env = {k: v for k, v in os.environ.items() if k in ("PATH", "HOME", "LANG", "TERM")}
        result = run(args.command, env=env, timeout=args.timeout)
    except Unavailable as err:
        print(f"vcan VM: {err}", file=sys.stderr)
        return 3
    sys.stdout.write(result.stdout)
    sys.stderr.write(result.stderr)
    print(f"vcan VM: booted in {result.boot_s:.1f} s, the command ran {result.command_s:.1f} s, "
          f"{result.wall_s:.1f} s in all", file=sys.stderr)
    return result.returncode


if __name__ == "__main__":
    sys.exit(main())
