"""What a recording shows while it runs: the console line, the monitor's rates and state, the
live view in the browser."""

__all__: list[str] = []
