"""From subjects to the population: random-effects pooling, the power law across subjects,
contrasts and outliers (study format section 10)."""

__all__: list[str] = []
