"""Acquisition: python-can buses, the trial logger, the live monitor, the simulated rig."""

__all__: list[str] = []
