"""Raw CAN frames: the column table, and one reader per log format behind a suffix registry.

>>> frames, report = read_frames("P01/run-01.log")      # doctest: +SKIP
>>> write_candump("copy.log", frames)                     # doctest: +SKIP

``read_frames`` picks the reader by suffix (:data:`READERS`): candump ``-L`` text
(``.log``, ``.log.gz``) is parsed by evtribo with numpy in bulk; ``.asc``, ``.blf``,
``.trc``, ``.csv``, ``.db`` (and gzipped text formats) through python-can's readers.
"""

from evtribo.frames.candump import write_candump
from evtribo.frames.pycan import frames_from_messages
from evtribo.frames.registry import READERS, ReadReport, log_suffix, read_frames, supported_suffixes
from evtribo.frames.table import FrameTable

__all__ = [
    "READERS",
    "FrameTable",
    "ReadReport",
    "frames_from_messages",
    "log_suffix",
    "read_frames",
    "supported_suffixes",
    "write_candump",
]
