"""The documents evtribo writes and reads, one module each: its version, its fields, its
reader and its writer.

- :mod:`evtribo.documents.sidecar`: a trial's ``<trial>.json``.
- :mod:`evtribo.documents.summary`: an analysis's ``summary.json``.
- :mod:`evtribo.documents.fit`: the model fit's ``fit.json``.

Every module that writes or reads one of these files goes through its document module; no
other module builds or parses their JSON.
"""
