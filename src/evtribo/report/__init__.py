"""``evtribo compare`` (fits and figures written as one unit) and ``evtribo report`` (one self-
contained HTML page)."""

__all__: list[str] = []
