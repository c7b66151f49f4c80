"""The subjects fitted side by side in worker processes (as compare fits them) give the fits
made here, and what each fit logged is said here, in the subjects' order."""

from __future__ import annotations

import logging
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from evtribo.fit.fit import fit_study
from evtribo.fit.tables import read_results
from evtribo.model import TABLE_1
from synthetic import make_out


def test_fits_in_worker_processes_are_the_fits_made_here(tmp_path, caplog):
    tables = read_results(make_out(tmp_path / "out"))
    with caplog.at_level(logging.INFO, logger="evtribo"):
        here = fit_study(tables, TABLE_1, ("h_L",))
        said_here = [r.getMessage() for r in caplog.records if r.name == "evtribo.fit.fit"]
        caplog.clear()
        with ProcessPoolExecutor(2) as pool:
            there = fit_study(tables, TABLE_1, ("h_L",),
                              mapper=lambda f, items: list(pool.map(f, items)))
        said_there = [r.getMessage() for r in caplog.records if r.name == "evtribo.fit.fit"]
    assert len(tables.subjects) >= 2
    assert [f.subject for f in there] == [f.subject for f in here] == list(tables.subjects)
    for a, b in zip(here, there, strict=True):
        assert a.params == b.params
        assert [(e.name, e.value, e.ci_low, e.ci_high) for e in a.estimates] == \
            [(e.name, e.value, e.ci_low, e.ci_high) for e in b.estimates]
        assert np.array_equal(a.correlation, b.correlation)
        assert a.n_replicates == b.n_replicates > 0
    assert said_there == said_here
    assert len(said_here) >= len(tables.subjects)  # each subject's fit says its estimate
