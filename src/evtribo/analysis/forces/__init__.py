"""One trial's signal processing: continuous time, sample times, the cells on one grid, the
excitation and ON/OFF, mains hum, taring and the finger-lifted stretches, cross-talk."""

__all__: list[str] = []
