"""The CAN buses a trial is recorded from: opened with a receive queue sized for a saturated
bus; slcan in bulk; SocketCAN's drop counter; error frames."""

__all__: list[str] = []
