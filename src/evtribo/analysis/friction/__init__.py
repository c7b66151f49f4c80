"""From steady-sliding windows to the friction coefficient and the inferred electrostatic force
of a trial, and the power law over amplitudes."""

__all__: list[str] = []
