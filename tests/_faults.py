"""A fault nobody planned for, in the analysis of one trial."""

from __future__ import annotations

from evtribo.results import workers as trial_workers

MESSAGE = "a fault nobody planned for"


def fail_trial(monkeypatch, trial: str) -> None:
    """Make the analysis of *trial* (its name, ``"run-02"``) raise ZeroDivisionError in
    this process (``jobs=1``); the other trials are analysed as ever."""
    real = trial_workers.analyze_signals

    def flaky(signals, meta, **kw):
        if meta.trial == trial:
            raise ZeroDivisionError(MESSAGE)
        return real(signals, meta, **kw)
    monkeypatch.setattr(trial_workers, "analyze_signals", flaky)
