"""A load cell's rolling frame counter as its firmware has it: what it counts from and to, by
how much, and whether it counts at all (:mod:`evtribo.canlog.counters.law`)."""

__all__: list[str] = []
