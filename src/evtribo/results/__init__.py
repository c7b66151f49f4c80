"""A study's results: the trials analysed in workers (or on Dask), reused when unchanged,
gathered into the result tables with their provenance."""

__all__: list[str] = []
