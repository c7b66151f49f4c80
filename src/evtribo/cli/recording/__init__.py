"""Commands that record: ``acquire``, ``session``, ``simulate``."""
