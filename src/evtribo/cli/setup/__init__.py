"""Commands for a rig and its logs: ``init``, ``inspect``, ``calibrate``, ``decode``."""
