"""What evtribo writes, written safely: whole files (atomic), one writer at a time (locks), a
result folder as one unit, the memo of what an analysis depended on."""

__all__: list[str] = []
