"""evtribo: tribometer experiments on electrovibration.

Layers, lowest first: ``model`` (the seed paper's physics), ``rig``/``frames``/``decode``
(CAN logs to forces), ``acquisition`` (buses, logger, simulated rig), ``analysis``
(windows, friction, electrostatic force), ``compare`` (model fit and report), ``cli``.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("evtribo")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
