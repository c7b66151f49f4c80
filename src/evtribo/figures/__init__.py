"""The figures of ``evtribo compare`` and ``evtribo plot``, in a journal's style."""

__all__: list[str] = []
