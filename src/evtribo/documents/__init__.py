"""The documents evtribo writes and reads, one module each: its version, its fields, its
reader and its writer.

- :mod:`evtribo.documents.sidecar`: a trial's ``<trial>.json``.
- :mod:`evtribo.documents.summary`: an analysis's ``summary.json``.
- :mod:`evtribo.documents.fit`: the model fit's ``fit.json``.
- :mod:`evtribo.documents.session`: a subject's ``session.json`` (``evtribo session``).
- :mod:`evtribo.documents.replacing`: a trial recorded again over itself, the new one in a
  folder of its own beside the old one until it is whole.
- :mod:`evtribo.documents.names`: the plain names of subjects and trials they all check.

Every module that writes or reads one of these files goes through its document module; no
other module builds or parses their JSON.
"""

__all__: list[str] = []
