"""Raw CAN frames: the column table, and one reader per log format behind a suffix registry.

>>> frames, report = read_frames("P01/run-01.log")      # doctest: +SKIP
>>> write_candump("copy.log", frames)                     # doctest: +SKIP

``read_frames`` picks the reader by suffix (:data:`READERS`), after a look at the content
(:mod:`~evtribo.canlog.io.sniff`: a log of another format than its suffix says is refused with
what it looks like and how to convert it): candump ``-L`` text (``.log``, ``.log.gz``) is
parsed by evtribo with numpy in bulk, candump's screen output with timestamps (``-ta``,
``-tz``, ``-td``, ``-tA``) line by line (:mod:`~evtribo.canlog.io.candump_text`); ``.asc``,
``.blf``, ``.trc``, ``.csv``, ``.db``, ``.mf4`` (and gzipped text formats) through
python-can's readers. Each frame keeps its channel (``FrameTable.channel_index``).
"""

from evtribo.canlog.io.candump import write_candump
from evtribo.canlog.io.pycan import frames_from_messages
from evtribo.canlog.io.registry import (
    READERS,
    FrameStream,
    ReadReport,
    log_suffix,
    read_frames,
    sha256_log,
    supported_suffixes,
)
from evtribo.canlog.io.table import FrameTable

__all__ = [
    "READERS",
    "FrameStream",
    "FrameTable",
    "ReadReport",
    "frames_from_messages",
    "log_suffix",
    "read_frames",
    "sha256_log",
    "supported_suffixes",
    "write_candump",
]
