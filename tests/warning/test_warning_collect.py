"""One way to say a warning: kept by the innermost collector, said on the console unless a
collector is quiet, carried out of worker processes with the result and said again there in
the caller's order."""

from __future__ import annotations

import logging
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import pytest
from _warning_work import analyse

from evtribo.warning.collect import collected, collecting, emitter, replay
from evtribo.warning.record import Scope

emit = emitter("evtribo.results.aggregate")
TRIALS = [("P01", "run-01", 2), ("P01", "run-02", 4), ("P02", "run-01", 0),
          ("P02", "run-02", 3)]


def test_records_cross_worker_processes_and_are_said_again_in_the_callers_order(caplog):
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(2, mp_context=ctx) as pool:
        futures = [pool.submit(collected, analyse, t, n, scope=Scope(s, t))
                   for s, t, n in TRIALS]
        done = []
        for f in futures:
            err = f.exception(timeout=600)
            done.append((f.result()[1], None) if err is None else (err.records, err))
    with caplog.at_level(logging.WARNING), collecting() as summary:
        for records, _ in done:
            replay(records)
    expected = [f"{s}/{t}: the normal cell's zero offset was {-k - 0.5:+.1f} mN, {11 + k} % "
                "of the normal force measured (0.300 N); removed, but tare the load cells "
                "before recording" for s, t, n in TRIALS for k in range(5 - n)]
    assert [r.text for r in summary] == expected
    assert [r.getMessage() for r in caplog.records] == expected
    assert {r.name for r in caplog.records} == {"evtribo.analysis.trial"}
    assert [r.scope for r in summary[:3]] == [Scope("P01", "run-01")] * 3
    assert str(done[2][1]) == "run-01: no window"  # the failed trial's records rode on it


def test_a_worker_says_nothing_itself_and_its_failure_carries_what_it_said(caplog):
    with caplog.at_level(logging.DEBUG):
        result, records = collected(analyse, "run-01", 3, scope=Scope("P01", "run-01"))
        with pytest.raises(RuntimeError) as failed:
            collected(analyse, "run-02", 0)
    assert result == "run-01" and len(records) == 2 and not caplog.records
    assert [r.text[:4] for r in failed.value.records] == ["the "] * 5  # no scope: the study's


def test_collectors_nest_the_innermost_keeps_and_a_quiet_one_silences_those_within(caplog):
    with caplog.at_level(logging.WARNING), collecting(Scope("P01")) as outer:
        emit("no-mu")
        with collecting() as inner:
            emit("mu-scatter", scatter_pct=8.4)
        assert [r.kind for r in outer] == ["no-mu"]  # the inner one hands nothing on
        assert inner[0].text.startswith("P01: the OFF windows'")  # the outer's scope
        replay(inner)
        with collecting(quiet=True) as quiet, collecting() as within:
            emit("no-mu", Scope("P02"))
        assert not quiet and [r.text for r in within] == [
            "P02: no OFF windows to estimate mu from; no electrostatic force"]
    assert [r.kind for r in outer] == ["no-mu", "mu-scatter"]
    assert [r.getMessage()[:4] for r in caplog.records] == ["P01:", "P01:", "P01:"]
    assert {r.name for r in caplog.records} == {"evtribo.results.aggregate"}


def test_outside_any_collector_a_warning_is_said_and_returned(caplog):
    with caplog.at_level(logging.WARNING):
        record = emit("no-window")
    assert record.text == "no steady-sliding window found"  # a trial's, said of no trial
    assert [r.getMessage() for r in caplog.records] == [record.text]


def test_an_unknown_kind_or_a_missing_value_is_refused():
    with collecting(quiet=True) as got:
        with pytest.raises(KeyError, match="no warning kind 'normal-zeros'"):
            emit("normal-zeros")
        with pytest.raises(KeyError, match="normal_N"):
            emit("normal-zero", change_pct=2.0)
    assert got == []
