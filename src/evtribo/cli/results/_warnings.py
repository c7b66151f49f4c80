"""``evtribo analyze``'s warnings on its console (and ``evtribo compare``'s:
:func:`say_records`): each kind once, with the trials or cells it concerns, at the end
(:mod:`evtribo.warning.render`), rather than one line per trial as the analysis says them.

While the analysis runs, :func:`held` holds back the warnings of the analysis's loggers
(``evtribo.analysis``, ``evtribo.results``, ``evtribo.canlog``); :func:`say_grouped` then
says summary.json's warnings grouped, and any held warning summary.json does not keep as
it was. With ``-v`` nothing is held: each warning is said as it comes, and grouped at the
end.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from evtribo.documents.summary import SUMMARY_FILE, Summary
from evtribo.report.lead.scope import read_scope
from evtribo.warning.record import EFFECTS, WarningRecord
from evtribo.warning.render import console_lines, group

#: The loggers whose warnings the analysis keeps in summary.json.
_ANALYSIS = ("evtribo.analysis", "evtribo.results", "evtribo.canlog")


class _Hold(logging.Filter):
    """Keeps the analysis's warnings (not its errors) instead of letting them through."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []
        self.said = False

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno == logging.WARNING and record.name.startswith(_ANALYSIS):
            self.records.append(record)
            return False
        return True


@contextmanager
def held(verbose: int) -> Iterator[_Hold]:
    """Hold the analysis's warnings back from the console's handlers while open (nothing
    held with *verbose*); those :func:`say_grouped` did not say (an analysis stopped by an
    error) are said as they were on leaving."""
    hold = _Hold()
    handlers = [] if verbose else list(logging.getLogger().handlers)
    for h in handlers:
        h.addFilter(hold)
    try:
        yield hold
    finally:
        for h in handlers:
            h.removeFilter(hold)
        if not hold.said:
            _release(hold.records)


def _release(records: list[logging.LogRecord]) -> None:
    """Say *records* through their loggers, each message once."""
    for record in {r.getMessage(): r for r in records}.values():
        logging.getLogger(record.name).handle(record)


def say_grouped(summary: dict[str, Any], out_dir: Path | None, out: str,
                hold: _Hold | None) -> None:
    """Say the warnings held and not in summary.json as they were, then summary.json's
    grouped by kind, and where they are kept (on standard error)."""
    kept = Summary(dict(summary)).warnings
    if hold is not None:
        hold.said = True
        texts = {w.text for w in kept}
        _release([r for r in hold.records if r.getMessage() not in texts])
    say_records(kept, out_dir, "the analysis", Path(out) / SUMMARY_FILE)


def say_records(records: Sequence[WarningRecord], out_dir: Path | None, who: str,
                where: Path) -> None:
    """Say *records* grouped by kind, each kind once with the trials or cells it concerns,
    and where they are kept (on standard error; nothing when there are none).

    Parameters
    ----------
    records : sequence of WarningRecord
    out_dir : Path or None
        The result folder (its trials and cells, to say "all").
    who : str
        Who said them (``the analysis``, ``the comparison``).
    where : Path
        The file that keeps them.
    """
    if not records:
        return
    trials, cells = read_scope(out_dir) if out_dir is not None else ([], [])
    groups = group(records)
    for line in console_lines(groups, trials, cells):
        print(line, file=sys.stderr)
    counts = {e: sum(g.effect == e for g in groups) for e in EFFECTS}
    said = ", ".join(f"{n} {EFFECTS[e].split(' (')[0]}" for e, n in counts.items() if n)
    print(f"{len(records)} warning(s) of {len(groups)} kind(s) ({said}); each as {who} said "
          f"it in {where}", file=sys.stderr)
