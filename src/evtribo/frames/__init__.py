"""Raw CAN frames: the column table, and one reader per log format behind a suffix registry."""

from evtribo.frames.table import FrameTable

__all__ = ["FrameTable"]
