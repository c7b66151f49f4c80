"""The seed paper's model fitted to a study's results: parameters, weighted least squares with
intervals, model comparison; reading a result folder."""

__all__: list[str] = []
