"""The analysis settings that take one of a few words, and those words: a module of their
own, so that the command line lists them without importing the analysis."""

__all__ = ["HUM_MODES", "TARE_MODES"]

#: Values of ``tare``: how the load cells' zero offsets are found (see :mod:`.zero_offsets`).
TARE_MODES = ("auto", "lifted", "friction-loop", "calibration", "none")
#: Values of ``hum``: where mains hum is notched out (see :mod:`.hum`).
HUM_MODES = ("auto", "remove", "keep")
