"""What a log file holds, from its first bytes and lines, whatever its name says.

A log saved under another format's suffix (Vector ASC text as ``run-01.log``, a SavvyCAN CSV
as ``run-01.csv``, candump's screen output as ``run-01.log``) would otherwise be read by the
wrong reader: zero frames and every line "damaged". :func:`sniff` looks at the file's first
lines (decompressed for a ``.gz`` name) and tells what the file looks like, which suffix
evtribo reads it under, and how to convert it, the way MNE's ``read_raw`` suggests the
right reader for a file.

A text log after a power cut may begin with a run of NUL bytes (blocks the file system lost)
or a junk line of any length; the readers skip both, and so does :func:`sniff`: it looks
past NULs and lines longer than :data:`MAX_LINE`, through up to :data:`SCAN_BYTES`, for the
first :data:`HEAD_LINES` lines. :func:`frame_line` goes through the whole file for one
line that is a frame of a text log (what :mod:`evtribo.guard` asks before it lets a file be
written over).
"""

from __future__ import annotations

import gzip
import os
import re
import stat
import zlib
from collections import Counter
from dataclasses import dataclass
from typing import BinaryIO

from evtribo.store.files import PARTIAL_SUFFIX

#: Bytes looked at (of a binary format; read at a time for a text one).
HEAD_BYTES = 1 << 16
#: Non-empty lines looked at.
HEAD_LINES = 40
#: A line longer than this is no record of any log format: junk, skipped, bytes.
MAX_LINE = 4096
#: Bytes of a text file looked through for its first lines (past NULs and junk lines).
SCAN_BYTES = 16 << 20
#: What a header line weighs against one frame line.
_HEADER_WEIGHT = 5

PYTHON_CAN_CSV_HEADER = "timestamp,arbitration_id,extended,remote,error,dlc,data"

_MAGIC = (
    (b"LOGG", "blf", "a Vector BLF binary log", ".blf"),
    (b"MDF     4", "mf4", "an ASAM MDF 4 (MF4) measurement file", ".mf4"),
    (b"MDF     ", "mdf", "an ASAM MDF 3 measurement file (python-can reads MDF 4 only)", None),
    (b"SQLite format 3\x00", "sqlite", "an SQLite database (python-can's .db)", ".db"),
    (b"PK\x03\x04", "zip", "a ZIP archive", None),
)

#: (kind, pattern of one line, is a header line).
_LINES = (
    ("candump-L", re.compile(r"\s*\(\s*\d+(?:\.\d+)?\s*\)\s+\S+\s+[0-9A-Fa-f]{1,8}#.*"), False),
    ("candump-text", re.compile(
        r"\s*\((?:\d+\.\d+|\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d+)\)\s+\S+\s+(?:[RT]X\s+\S\s\S\s+)?"
        r"[0-9A-Fa-f]{3,8}\s+(?:\[\d{1,4}\]|\{[0-9A-Fa-f]\}).*"), False),
    ("candump-plain", re.compile(
        r"\s*[^\s(]\S*\s+(?:[RT]X\s+\S\s\S\s+)?[0-9A-Fa-f]{3,8}\s+(?:\[\d{1,4}\]|"
        r"\{[0-9A-Fa-f]\}).*"), False),
    ("asc", re.compile(r"(?:date \w|base (?:hex|dec)|(?:no )?internal events logged|"
                       r"Begin Triggerblock).*", re.IGNORECASE), True),
    ("asc", re.compile(r"\s*\d+\.\d+\s+(?:\d+|CANFD)\s+.*"), False),
    ("trc", re.compile(r";\s*(?:\$FILEVERSION|Start time|\$STARTTIME|Message Number).*"), True),
    ("python-can-csv", re.compile(re.escape(PYTHON_CAN_CSV_HEADER) + r"\s*", re.IGNORECASE),
     True),
    ("python-can-csv", re.compile(r"\d+(?:\.\d*)?,(?:0x)?[0-9A-Fa-f]+,[01],[01],[01],\d+,"
                                  r"[A-Za-z0-9+/=]*\s*"), False),
    ("savvycan", re.compile(r"Time Stamp,ID,Extended,.*", re.IGNORECASE), True),
    ("savvycan", re.compile(r"\d+,[0-9A-Fa-f]+,(?:true|false),(?:\w+,)?\d+,\d+,.*",
                            re.IGNORECASE), False),
    ("decoded", re.compile(r"timestamp,message(?:,.*)?", re.IGNORECASE), True),
)

_DESCRIPTIONS = {
    "candump-L": ("a candump -L log", ".log"),
    "candump-text": ("candump's screen output with timestamps (candump -ta, -tz, -td or -tA)",
                     ".log"),
    "candump-plain": ("candump's screen output without timestamps (plain `candump can0`)",
                      None),
    "asc": ("a Vector ASC log", ".asc"),
    "trc": ("a PEAK TRC log", ".trc"),
    "python-can-csv": ("a python-can CSV log", ".csv"),
    "savvycan": ("a SavvyCAN/GVRET CSV log (header 'Time Stamp,ID,Extended,...')", None),
    "decoded": ("a table of decoded signals (what `evtribo decode` writes), not a raw CAN log",
                None),
}


_HINTS = {
    "candump-plain": "it has no timestamps, hence no time base to analyse: record with "
                     "`candump -L can0 > {stem}.log` (or `candump -l`), which evtribo reads",
    "savvycan": "save it from SavvyCAN as a candump log instead (File > Save Log File..., "
                "type 'Candump/Kayak (*.log)') and give evtribo that .log",
    "decoded": "give evtribo the raw CAN log it was decoded from",
    "zip": "unpack it and give evtribo the log inside",
    "mdf": "convert it to MDF 4 (asammdf: MDF(file).convert('4.10').save(...))",
}


@dataclass(frozen=True)
class Sniffed:
    """What a file looks like.

    Attributes
    ----------
    kind : str
        ``candump-L``, ``candump-text``, ``candump-plain``, ``asc``, ``trc``,
        ``python-can-csv``, ``savvycan``, ``decoded``, ``csv``, ``blf``, ``mf4``, ``mdf``,
        ``sqlite``, ``zip``, ``gzip:<kind>``, ``binary`` or ``unknown``.
    description : str
        In words (``"a Vector ASC log"``).
    suffix : str or None
        The suffix evtribo reads it under (``".asc"``; ``".log.gz"`` for gzip), or None
        when evtribo cannot read it.
    first_line : str
        Its first non-empty line (text files), shortened.
    encoding : str or None
        ``"UTF-16"`` or ``"UTF-32"`` (with a byte order mark), ``"UTF-16LE"`` or
        ``"UTF-16BE"`` (without) for text saved so (a Windows editor's "Unicode"), which no
        reader of evtribo or python-can reads; None for UTF-8, ASCII and binary.
    """

    kind: str
    description: str
    suffix: str | None
    first_line: str = ""
    encoding: str | None = None

    def hint(self, path: str | os.PathLike[str]) -> str:
        """How to give evtribo this file (a sentence naming the file's new name)."""
        stem = _stem(path)
        if self.encoding is not None:
            name = os.path.basename(os.fspath(path))
            return (f"evtribo and python-can read logs as UTF-8 (or ASCII) only; save a copy "
                    f"as UTF-8 (`iconv -f {self.encoding} -t UTF-8 {name} > "
                    f"{stem}-utf8{self.suffix or '.log'}`, or an editor's Save As with the "
                    "encoding UTF-8) and give evtribo the copy")
        if self.kind in _HINTS:
            return _HINTS[self.kind].format(stem=stem)
        if self.suffix is None:
            return ("convert it to a format evtribo reads: candump -L (.log), python-can's "
                    f"CSV (header '{PYTHON_CAN_CSV_HEADER}'), .asc, .blf, .trc, .mf4 or .db; "
                    "python-can converts between its formats: python -m can.logconvert IN OUT")
        return f"rename it to {stem}{self.suffix}"


def _stem(path: str | os.PathLike[str]) -> str:
    """The file's name without its format suffixes (``run-01`` of ``run-01.log.gz``)."""
    name = os.path.basename(os.fspath(path))
    for _ in range(3):
        stem, ext = os.path.splitext(name)
        if not ext or len(ext) > 5 or not stem:
            break
        name = stem
    return name


def _open(path: str | os.PathLike[str]) -> BinaryIO | None:
    """*path* open for reading if it is a regular file (a FIFO or a device is not read)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        return None
    return os.fdopen(fd, "rb")


def _head(path: str | os.PathLike[str]) -> bytes | None:
    fh = _open(path)
    if fh is None:
        return None
    with fh:
        try:
            return fh.read(HEAD_BYTES)
        except OSError:
            return None


class _Lines:
    """The lines of a text file, NUL bytes removed and lines over :data:`MAX_LINE` dropped,
    fed a block at a time."""

    def __init__(self) -> None:
        self.lines: list[bytes] = []
        self._part = b""
        self._junk = False  # inside a line too long to keep

    def feed(self, block: bytes, *, last: bool = False) -> None:
        pieces = (self._part + block.replace(b"\x00", b"")).split(b"\n")
        self._part = b"" if last else pieces.pop()
        for i, piece in enumerate(pieces):
            if not (self._junk and i == 0) and len(piece) <= MAX_LINE:
                self.lines.append(piece)
            self._junk = False
        if len(self._part) > MAX_LINE:
            self._part, self._junk = b"", True

    def text(self) -> str:
        return "\n".join(ln.decode("utf-8", "replace") for ln in self.lines)

    def count(self) -> int:
        return sum(1 for ln in self.lines if ln.strip())


def _text_head(path: str | os.PathLike[str], first: bytes) -> str:
    """The first lines of a text file whose first bytes are *first* (see :class:`_Lines`),
    read further while there are fewer than :data:`HEAD_LINES`, up to SCAN_BYTES."""
    lines = _Lines()
    lines.feed(first)
    fh = _open(path) if lines.count() < HEAD_LINES and len(first) == HEAD_BYTES else None
    if fh is None:
        lines.feed(b"", last=True)
        return lines.text()
    with fh:
        fh.seek(len(first))
        seen = len(first)
        while lines.count() < HEAD_LINES and seen < SCAN_BYTES:
            block = fh.read(HEAD_BYTES)
            if not block:
                break
            seen += len(block)
            lines.feed(block)
    lines.feed(b"", last=True)
    return lines.text()


def _gunzip_head(raw: bytes) -> bytes | None:
    try:
        return zlib.decompressobj(wbits=31).decompress(raw, HEAD_BYTES)
    except zlib.error:
        return None


def sniff_bytes(head: bytes) -> Sniffed | None:
    """What a file whose first bytes are *head* looks like (None: empty).

    Parameters
    ----------
    head : bytes
        The file's first bytes.

    Returns
    -------
    Sniffed or None
    """
    for magic, kind, description, suffix in _MAGIC:
        if head.startswith(magic):
            return Sniffed(kind, description, suffix)
    if head.startswith(b"\x1f\x8b"):
        inner = _gunzip_head(head)
        found = sniff_bytes(inner) if inner else None
        if found is None or found.suffix is None:
            return Sniffed("gzip", "gzip-compressed data", None)
        return Sniffed(f"gzip:{found.kind}", f"gzip-compressed {found.description}",
                       found.suffix + ".gz", found.first_line)
    lines = _Lines()
    lines.feed(head, last=True)
    return _sniff_lines(head, lines.text())


def _sniff_lines(head: bytes, text: str) -> Sniffed | None:
    """What a file of no binary format is, from its first bytes and its first lines (NUL
    bytes and junk lines left out)."""
    wide = _wide_text(head)
    if wide is not None:
        found = _sniff_text(head.decode(wide, "replace"))
        if found is not None and found.kind not in ("unknown", "csv"):
            encoding = wide.upper().replace("-LE", "LE").replace("-BE", "BE")
            return Sniffed(found.kind, f"{found.description} saved as {encoding[:6]} text",
                           found.suffix, found.first_line, encoding)
    # NUL bytes: binary data, or a text log with a run of them (a file system's answer to a
    # power cut): the lines decide
    found = _sniff_text(text)
    if b"\x00" in head[:4096] and (found is None or found.kind in ("unknown", "csv")):
        return Sniffed("binary", "binary data of no log format evtribo knows", None)
    return found


def _wide_text(head: bytes) -> str | None:
    """The codec of text saved as UTF-16 or UTF-32 (by its byte order mark, or without one
    by a NUL byte beside every character of the first ones), else None."""
    for bom, codec in ((b"\xff\xfe\x00\x00", "utf-32"), (b"\x00\x00\xfe\xff", "utf-32"),
                       (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16")):
        if head.startswith(bom):
            return codec
    sample = head[:4096 - 4096 % 4]
    if len(sample) < 64:
        return None
    even, odd = sample[0::2], sample[1::2]
    for zeros, other, codec in ((odd, even, "utf-16-le"), (even, odd, "utf-16-be")):
        if zeros.count(0) > 0.9 * len(zeros) and other.count(0) < 0.05 * len(other):
            return codec
    return None


def _sniff_text(text: str) -> Sniffed | None:
    lines = [ln.rstrip("\r") for ln in text.split("\n")[:4 * HEAD_LINES]]
    lines = [ln for ln in lines if ln.strip()][:HEAD_LINES]
    if not lines:
        return None
    first = lines[0].strip()[:80]
    votes: Counter[str] = Counter()
    for line in lines:
        for kind, pattern, header in _LINES:
            if pattern.fullmatch(line):
                votes[kind] += _HEADER_WEIGHT if header else 1
                break
    if votes:
        kind = votes.most_common(1)[0][0]
        description, suffix = _DESCRIPTIONS[kind]
        return Sniffed(kind, description, suffix, first)
    if first.count(",") >= 2 or first.count(";") >= 2:
        return Sniffed("csv", f"a table whose first line is {first!r}", None, first)
    return Sniffed("unknown", f"text whose first line is {first!r}", None, first)


def sniff(path: str | os.PathLike[str]) -> Sniffed | None:
    """What *path* looks like (decompressed first when its name ends in ``.gz``).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    Sniffed or None
        None when the file is empty or cannot be read (its reader then says why).
    """
    head = _head(path)
    if head is None:
        return None
    if os.fspath(path).lower().removesuffix(PARTIAL_SUFFIX).endswith(".gz"):
        if not head.startswith(b"\x1f\x8b"):
            return None  # not gzip: gzip's own error names it
        try:
            with gzip.open(path, "rb") as fh:
                head = fh.read(HEAD_BYTES)
        except (OSError, EOFError, zlib.error):
            head = _gunzip_head(head) or b""
        return sniff_bytes(head)
    if any(head.startswith(magic) for magic, *_ in _MAGIC) or head.startswith(b"\x1f\x8b"):
        return sniff_bytes(head)
    return _sniff_lines(head, _text_head(path, head))


#: A frame's line in each text log format, anywhere in a file (bytes, one line at a time).
_FRAME_LINE = re.compile(
    rb"^[ \t]*(?:"
    rb"(?P<candump_L>\([ \t]*\d+(?:\.\d+)?[ \t]*\)[ \t]+\S+[ \t]+[0-9A-Fa-f]{1,8}#)"
    rb"|(?P<candump_text>\((?:\d+\.\d+|\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d+)\)[ \t]+\S+"
    rb"[ \t]+(?:[RT]X[ \t]+\S[ \t]\S[ \t]+)?[0-9A-Fa-f]{3,8}[ \t]+"
    rb"(?:\[\d{1,4}\]|\{[0-9A-Fa-f]\}))"
    rb"|(?P<asc>\d+\.\d+[ \t]+(?:\d+|CANFD)[ \t]+(?:\d+[ \t]+)?[0-9A-Fa-f]+x?[ \t]+"
    rb"(?:Rx|Tx))"
    rb"|(?P<python_can_csv>\d+(?:\.\d*)?,(?:0x)?[0-9A-Fa-f]+,[01],[01],[01],\d+,))",
    re.MULTILINE)


def frame_line(path: str | os.PathLike[str]) -> Sniffed | None:
    """The first line anywhere in *path* (NUL bytes and junk lines skipped, however long the
    file) that is a frame of a text log (candump, ASC, python-can CSV), as what the file
    is; None when there is none, or when *path* is not a regular file.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    Sniffed or None
    """
    fh = _open(path)
    if fh is None:
        return None
    with fh:
        lines = _Lines()
        while True:
            block = fh.read(1 << 22)
            lines.feed(block, last=not block)
            found = _FRAME_LINE.search(b"\n".join(lines.lines))
            if found is not None:
                kind = str(found.lastgroup).replace("_", "-")
                description, suffix = _DESCRIPTIONS[kind]
                return Sniffed(kind, description, suffix, found.group(0).decode(
                    "utf-8", "replace").strip()[:80])
            if not block:
                return None
            lines.lines.clear()


__all__ = ["PYTHON_CAN_CSV_HEADER", "Sniffed", "frame_line", "sniff", "sniff_bytes"]
