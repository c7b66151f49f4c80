"""Small tools the other packages share: docstring parts, an exact fast median, running counts,
a moving average and runs, numbers printed for people."""

__all__: list[str] = []
