"""The subjects fitted side by side in worker processes (as compare fits them) give the fits
made here, and what each fit said (its warnings, its estimates) is said here, in the
subjects' order; a fit that fails has the warnings it said before failing said, after the
subjects before it, then its error."""

from __future__ import annotations

import logging
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

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


@pytest.mark.parametrize("failing", [0, 1])
def test_a_fit_that_fails_in_a_worker_says_what_it_logged_then_its_error(tmp_path, caplog,
                                                                         monkeypatch, failing):
    import evtribo.fit.fit as fit_module
    from evtribo.errors import ConfigError

    tables = read_results(make_out(tmp_path / "out"))
    subjects = list(tables.subjects)
    bad = subjects[failing]
    real = fit_module.fit_subject

    def fails_for_one(subject, *args, **kwargs):
        if subject == bad:
            fit_module.emit("points-missing", subject=subject, points=2)
            raise ConfigError(f"subject {subject}: cannot be fitted")
        return real(subject, *args, **kwargs)

    monkeypatch.setattr(fit_module, "fit_subject", fails_for_one)
    with caplog.at_level(logging.INFO, logger="evtribo"), \
            ProcessPoolExecutor(2) as pool:  # forked after the patch: the workers have it
        with pytest.raises(ConfigError, match=f"subject {bad}: cannot be fitted") as raised:
            fit_study(tables, TABLE_1, ("h_L",),
                      mapper=lambda f, items: list(pool.map(f, items)))
    said = [r.getMessage() for r in caplog.records if r.name == "evtribo.fit.fit"]
    # the subjects before it said, then what it said before failing; none after it
    assert said[-1] == f"subject {bad}: 2 point(s) with missing values left out"
    for before in subjects[:failing]:
        assert any(m.startswith(f"subject {before}:") for m in said[:-1]), said
    assert not any(after in m for m in said for after in subjects[failing + 1:]), said
    assert any(f"fit of subject {bad}" in note for note in raised.value.__notes__)
