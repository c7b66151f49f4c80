"""Warnings as records: one catalogue of kinds, one way to say them, one way to show them.

Every warning evtribo says about a result is a :class:`~evtribo.warning.record.WarningRecord`
of a kind in the catalogue (:mod:`evtribo.warning.catalogue`: its id, what it does to the
reported numbers, its wording with named fields, what to do about it, what it is said of).
A module says one with its emitter (:mod:`evtribo.warning.collect`); the console, the
report, the API and summary.json show the records (:mod:`evtribo.warning.render`);
``docs/warnings.md`` is written from the catalogue (:mod:`evtribo.warning.docs`); the
warnings of results written by earlier versions are lifted into records
(:mod:`evtribo.warning.legacy`).

Nothing here imports more than the standard library: ``evtribo analyze``'s console uses it.
"""

__all__: list[str] = []
