"""CAN logs: frames read from every format (:mod:`evtribo.canlog.io`), the rig (a DBC and its
roles), frames decoded into signals, the decoded cache, frames lost."""

__all__: list[str] = []
